"""ecos (PyPI ecospy), a C++ co-simulation engine, as a host of the FMU: its Python API, its command line
and its C API step the pendulum exactly as fmpy's FMU2Slave does, and every process exits with 0.

ecos calls setupExperiment at 0 without stop time or tolerance, applies a parameter set in initialization
mode, then doStep(t, h) with t advanced by t + h; tests/ecos_runs.py makes the same calls through fmpy for
the reference. ecos drops Enumeration variables (none of its interfaces can set `model.fidelity`; the Integer
alias `model.fidelity_index` of modelDescription.template.xml is the way), and it ignores every status
the FMU answers: a refusal shows only as the FMU's message in ecos's log at debug level (last test).
The wheel's binaries need Debian's libtbb12 and are installed without the executable bit.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import stat
import subprocess
import sys
from itertools import accumulate
from pathlib import Path
from typing import Any

import pytest

TESTS = Path(__file__).resolve().parent
ECOS_RUNS = TESTS / "ecos_runs.py"
# the package's folder, found without importing it (importing loads libecosc.so into this process)
BINARIES = Path(importlib.util.find_spec("ecospy").submodule_search_locations[0]) / "binaries"
STEPS = 200  # of 1 ms
RUNS = 5
CASES = {"rigid": ["model.fidelity_index=2"], "fem": ["model.fidelity_index=4", "model.mesh_size=0.06"]}
ONLY_PATH = {"PATH": os.environ.get("PATH", "")}  # a native host's environment: the FMU needs nothing else
MISMATCH = ("fmi2Warning", "fmi2Discard", "fmi2Error", "fmi2Fatal")  # how ecos logs the FMU's non-OK messages


def in_pairs(commands: list[list[str]], **kwargs: Any) -> list[subprocess.CompletedProcess]:
    """The commands run two at a time (the machine has 2 cores); each result as subprocess.run gives it."""
    results = []
    for k in range(0, len(commands), 2):
        started = [
            subprocess.Popen(c, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kwargs)
            for c in commands[k : k + 2]
        ]
        for c, p in zip(commands[k : k + 2], started, strict=True):
            out, err = p.communicate(timeout=300)
            results.append(subprocess.CompletedProcess(c, p.returncode, out, err))
    return results


def ecos_runs(tmp_path: Path, verb: str, fmu: Path, *args: str, runs: int = 1) -> list[tuple[dict, str]]:
    """`runs` runs of tests/ecos_runs.py VERB, each in a fresh interpreter that must exit with 0: what
    each wrote, with what ecos logged."""
    outs = [tmp_path / f"{verb}{k}.json" for k in range(runs)]
    commands = [[sys.executable, str(ECOS_RUNS), verb, str(out), str(fmu), str(STEPS), *args] for out in outs]
    results = in_pairs(commands)
    codes = [r.returncode for r in results]
    assert codes == [0] * runs, "\n".join(r.stdout[-2000:] + r.stderr[-3000:] for r in results)
    return [(json.loads(out.read_text()), r.stdout) for out, r in zip(outs, results, strict=True)]


def fmpy_theta(fmu: Path, folder: Path, cases: list[str], env: dict | None = None) -> dict[str, list[float]]:
    """theta after every step through fmpy's FMU2Slave, with the calls ecos makes, per case, in processes with
    the environment `env` (None: this one's). The environment takes part: numpy's OpenBLAS picks its kernels
    by it (OPENBLAS_CORETYPE, which some machines set), and kernels of another core type round the FE
    model's last bits otherwise."""

    def command(case: str) -> list[str]:
        return [
            sys.executable,
            str(ECOS_RUNS),
            "fmpy",
            str(folder / f"{case}.json"),
            str(fmu),
            str(STEPS),
            *CASES[case],
        ]

    results = in_pairs([command(case) for case in cases], env=env)
    for r in results:
        assert r.returncode == 0, r.stderr[-3000:]
    return {case: json.loads((folder / f"{case}.json").read_text())["theta"] for case in cases}


@pytest.fixture(scope="module")
def reference(fmus, tmp_path_factory) -> dict[str, list[float]]:
    """theta through fmpy, per case, in this process's environment (the one ecospy's runs below have)."""
    theta = fmpy_theta(fmus[0], tmp_path_factory.mktemp("fmpy"), list(CASES))
    assert theta["rigid"] != theta["fem"]  # the fidelities differ: the parameters took effect
    assert all(abs(theta[case][-1] - theta[case][0]) > 0.2 for case in CASES)  # released at 0.349 rad: it swung
    return theta


@pytest.mark.parametrize("case", CASES)
def test_python_api_matches_fmpy_bit_for_bit(fmus, tmp_path, reference, case):
    """Five runs through ecospy, each in its own interpreter (the FMU's slave runs in that interpreter)."""
    fmu, _ = fmus
    for result, log in ecos_runs(tmp_path, "api", fmu, *CASES[case], runs=RUNS):
        assert result["init"] is True
        assert result["fidelity_index"] == {"pendulum": int(CASES[case][0].split("=")[1])}
        assert result["enumeration_readable"] is False  # ecos knows no `model.fidelity`
        assert result["times"] == list(accumulate([1e-3] * STEPS))  # t + h, step after step
        assert result["theta"]["pendulum"] == reference[case]
        assert len(result["threads"]["do_step"]) == STEPS
        assert not any(status in log for status in MISMATCH), log[-3000:]


def test_two_instances_in_one_simulation_each_match_fmpy(fmus, tmp_path, reference):
    """A rigid and a fem instance of the FMU in one ecos simulation. ecos steps its instances in parallel
    (std::execution::par on TBB) whenever a worker thread is free: the slave is then called from a thread
    Python did not start (from none to half of the calls on the 2-core machine, 2026-12-02)."""
    fmu, _ = fmus
    ((result, log),) = ecos_runs(tmp_path, "pair", fmu)
    assert result["fidelity_index"] == {"rigid": 2, "fem": 4}
    assert result["theta"]["rigid"] == reference["rigid"]
    assert result["theta"]["fem"] == reference["fem"]
    assert len(result["threads"]["do_step"]) == 2 * STEPS
    assert not any(status in log for status in MISMATCH), log[-3000:]


@pytest.mark.parametrize("case", CASES)
def test_reset_and_a_second_initialisation_repeat_the_run(fmus, tmp_path, reference, case):
    """ecos's reset calls fmi2Reset on every instance; init then sets the FMU up again from the start."""
    fmu, _ = fmus
    ((result, log),) = ecos_runs(tmp_path, "reset", fmu, *CASES[case])
    assert result["theta"] == [reference[case], reference[case]]
    assert "Resetting simulation" in log
    assert not any(status in log for status in MISMATCH), log[-3000:]


SSD = """<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    name="pendulums" version="1.0">
  <ssd:System name="pendulums">
    <ssd:Elements>
{components}
    </ssd:Elements>
  </ssd:System>
</ssd:SystemStructureDescription>
"""
COMPONENT = """      <ssd:Component name="{name}" source="{fmu}">
        <ssd:ParameterBindings><ssd:ParameterBinding source="{name}.ssv"/></ssd:ParameterBindings>
      </ssd:Component>"""
SSV = """<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0"
    name="run">
  <ssv:Parameters>
{parameters}
  </ssv:Parameters>
</ssv:ParameterSet>
"""
CSV_CONFIG = """<?xml version="1.0" encoding="UTF-8"?>
<ecos:CsvConfig xmlns:ecos="http://github.com/Ecos-platform/ecos">
  <ecos:components>
{components}
  </ecos:components>
</ecos:CsvConfig>
"""


def ssp_folder(folder: Path, fmu: Path) -> Path:
    """An SSP system (a folder with SystemStructure.ssd) holding a rigid and a fem instance of the FMU, each
    bound to its own parameter values in the parameter set "run", and a CSV configuration recording theta
    and the parameters."""
    folder.mkdir()
    components = []
    for case, pairs in CASES.items():
        components.append(COMPONENT.format(name=case, fmu=fmu))
        lines = []
        for pair in pairs:
            name, value = pair.split("=")
            kind = "Integer" if name.endswith("_index") else "Real"
            lines.append(f'    <ssv:Parameter name="{name}"><ssv:{kind} value="{value}"/></ssv:Parameter>')
        (folder / f"{case}.ssv").write_text(SSV.format(parameters="\n".join(lines)))
    (folder / "SystemStructure.ssd").write_text(SSD.format(components="\n".join(components)))
    recorded = [
        f'    <ecos:component name="{case}"><ecos:variable name="theta"/>'
        + "".join(f'<ecos:variable name="{pair.split("=")[0]}"/>' for pair in pairs)
        + "</ecos:component>"
        for case, pairs in CASES.items()
    ]
    (folder / "csv.xml").write_text(CSV_CONFIG.format(components="\n".join(recorded)))
    return folder


@pytest.mark.slow
def test_command_line_with_an_ssp_parameter_set_matches_fmpy(fmus, tmp_path, reference):
    """`ecos simulate` on an SSP folder, parameters from its parameter set, in an environment holding only
    PATH: the FMU starts the Python recorded at build time itself. ecos's CSV writes each Real with
    std::to_string, 6 decimals: every theta must read as fmpy's rounded so."""
    fmu, _ = fmus
    ecos = tmp_path / "ecos"  # the wheel installs it without the executable bit
    shutil.copy(BINARIES / "ecos", ecos)
    ecos.chmod(ecos.stat().st_mode | stat.S_IXUSR)
    systems = [ssp_folder(tmp_path / f"pendulums{k}", fmu) for k in range(RUNS)]
    # ecos stops when t + h would pass the stop time, t summed step by step: --stopTime 0.2 makes 199 steps
    options = ["--stepSize", "0.001", "--stopTime", "0.2005", "--parameterSet", "run", "--logLevel", "debug"]
    commands = [[str(ecos), "simulate", "--path", str(s), "--csvConfig", str(s / "csv.xml"), *options] for s in systems]
    results = in_pairs(commands, cwd=tmp_path, env=ONLY_PATH)
    codes = [r.returncode for r in results]
    assert codes == [0] * RUNS, "\n".join(r.stdout[-2000:] + r.stderr[-2000:] for r in results)
    for system, result in zip(systems, results, strict=True):
        assert not any(status in result.stdout for status in MISMATCH), result.stdout[-3000:]
        # ecos writes its CSV into the working directory, named after the SSP folder
        header, *rows = [
            [cell.strip() for cell in line.split(",")] for line in (tmp_path / f"{system.name}.csv").open()
        ]
        columns = {name: [row[header.index(name)] for row in rows] for name in header}
        assert columns["iterations"] == [str(k) for k in range(STEPS + 1)]
        assert columns["rigid::model.fidelity_index[INT]"] == ["2"] * (STEPS + 1)
        assert columns["fem::model.fidelity_index[INT]"] == ["4"] * (STEPS + 1)
        assert columns["fem::model.mesh_size[REAL]"] == ["0.060000"] * (STEPS + 1)
        for case in CASES:
            assert columns[f"{case}::theta[REAL]"][0] == "0.349066"  # the row of t = 0: 20 degrees
            assert columns[f"{case}::theta[REAL]"][1:] == [f"{theta:.6f}" for theta in reference[case]], case


@pytest.fixture(scope="module")
def c_host(tmp_path_factory) -> Path:
    """tests/ecos_c_host.c compiled against the wheel's libecosc.so."""
    binary = tmp_path_factory.mktemp("ecos_c") / "ecos_c_host"
    compiler = shutil.which("cc") or shutil.which("gcc")
    assert compiler, "a C compiler is needed for the FMU's binary and this host"
    subprocess.run(
        [compiler, "-O1", "-Wall", "-Wextra", "-Werror", str(TESTS / "ecos_c_host.c"), f"-L{BINARIES}"]
        + ["-l:libecosc.so", f"-Wl,-rpath,{BINARIES}", "-o", str(binary)],
        check=True,
    )
    return binary


@pytest.mark.parametrize(
    ("case", "env", "expected"),
    [("rigid", ONLY_PATH, "rigid"), ("fem", ONLY_PATH, "fem"), ("fem", {}, "fem")],
    ids=["rigid", "fem", "fem-empty-environment"],
)
def test_c_api_program_matches_fmpy_bit_for_bit(fmus, c_host, tmp_path, case, env, expected):
    """A C program on ecos's C API (ecospy's Python API is ctypes on the same library: the runs above use
    it too), against fmpy in the same environment (fmpy_theta). With an empty environment too: the FMU's fem
    fidelity runs the package's compiled core, bit for bit."""
    fmu, _ = fmus
    reference = fmpy_theta(fmu, tmp_path, [expected], env=env)
    values = [pair.split("=")[1] for pair in CASES[case]]
    results = in_pairs([[str(c_host), str(fmu), str(STEPS), *values]] * 2, env=env)
    assert [r.returncode for r in results] == [0] * 2, "\n".join(r.stdout[-2000:] + r.stderr for r in results)
    for r in results:
        lines = r.stdout.splitlines()
        assert lines[0] == "ecos 0.7.2"
        assert f"fidelity_index {values[0]}" in lines
        rows = [line.split() for line in lines if line.startswith("theta ")]
        assert [float(row[1]) for row in rows] == list(accumulate([1e-3] * STEPS))
        assert [float(row[2]) for row in rows] == reference[expected]
        assert not any(status in r.stdout for status in MISMATCH), r.stdout[-3000:]


def test_a_refused_parameter_shows_only_in_the_debug_log(fmus, tmp_path):
    """ecos ignores the FMU's statuses: with an invalid parameter its init still reports success and the
    run exits with 0, while the FMU refuses exitInitializationMode and every doStep after it (its slave is
    never stepped) and says so through the logger, which ecos prints at debug level."""
    fmu, _ = fmus
    ((result, log),) = ecos_runs(tmp_path, "api", fmu, "model.fidelity_index=2", "pendulum.nu=0.5")
    assert result["init"] is True
    assert result["threads"]["do_step"] == []
    assert len(set(result["theta"]["pendulum"])) == 1
    assert "fmi2Error invalid parameters: parameter pendulum.nu = 0.5 is not allowed" in log, log[-3000:]
    assert log.count("fmi2Error fmi2DoStep refused in state initializationMode") == STEPS
