"""The README's examples run as written (as scikit-fem's tests/test_examples.py runs its examples).

So do the examples that moved from README.md into the user guide (GUIDE_PAGES): the blocks of those pages that
CHECKS or SHELL name run here as the README's do; their other blocks are not run.

Each ```python block of README.md runs as a script in a fresh interpreter, in a folder where
`dist/FemPendulum.fmu` exists (the session's build), and must exit 0 and print what it promises.
A new block needs an entry in CHECKS: the test fails on a block it does not know.

Each ```bash block runs with `bash -e`, as written, in a folder laid out as a clean clone after the
main job, and its check reads what it printed and wrote; or SHELL lists it as not run, with the
reason and what is checked instead. A new block needs an entry in SHELL.
"""

from __future__ import annotations

import csv
import importlib
import importlib.metadata
import importlib.util
import json
import math
import re
import shlex
import subprocess
import sys
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.MULTILINE | re.DOTALL)


# the user guide's pages that hold examples moved out of README.md
GUIDE_PAGES = ("docs/guide/getting_started.md", "docs/guide/hosts.md", "docs/guide/sweeps.md")


def python_blocks(text: str) -> list[str]:
    return BLOCK.findall(text)


def documents() -> str:
    """README.md and GUIDE_PAGES, one text."""
    return "\n".join((ROOT / name).read_text() for name in ("README.md", *GUIDE_PAGES))


def python_examples() -> list[str]:
    """Every ```python block of README.md, and those of GUIDE_PAGES that CHECKS names."""
    guide = python_blocks("\n".join((ROOT / name).read_text() for name in GUIDE_PAGES))
    return python_blocks((ROOT / "README.md").read_text()) + [b for b in guide if any(key in b for key in CHECKS)]


def _numbers(stdout: str) -> list[float]:
    return [float(word) for word in stdout.split()]


def check_fmpy_api(stdout: str) -> None:
    # theta at 1 s and the smallest gap, released from 15 deg against the rigid wall
    theta, gap_min = _numbers(stdout)
    # measured: theta(1 s) = 0.2447 rad, gap_min = -2.09e-5 m (21 um penetration at the impact)
    assert abs(theta) <= math.radians(15.0) * 1.001  # no torque: never beyond the release angle
    assert -1e-4 < gap_min < 0.0  # it reaches the wall, and the stiff penalty keeps it within 0.1 mm


def check_physics(stdout: str) -> None:
    # theta at 0.5 s of the rubber pendulum released at 20 deg, and its energy less the torque's work
    theta, energy = _numbers(stdout)
    assert abs(theta) <= math.radians(20.0) * 1.001  # no torque: never beyond the release angle
    from fem_pendulum_fmu.physics.fidelity import create
    from fem_pendulum_fmu.physics.scene import rubber

    start = create(rubber(**{"wall.kind": "rigid"})).outputs().energy_total
    # energy-consistent through the impact: measured |E - E0 - W| = 4e-14 J over 0.5 s (E0 = -0.2328 J);
    # the bound leaves room for the Newton tolerance on another machine's arithmetic
    assert abs(energy - start) < 1e-9 * abs(start)


def check_controller_test(out: str) -> None:
    assert re.search(r"\b1 passed\b", out), out


# a word that identifies a block -> the check of its output
CHECKS: dict[str, Callable[[str], None]] = {
    "def test_my_controller(pendulum_loop)": check_controller_test,
    "simulate_fmu(": check_fmpy_api,
    "from fem_pendulum_fmu import create, problems, rubber": check_physics,
}


def test_the_readme_has_python_examples():
    blocks = python_blocks((ROOT / "README.md").read_text())
    assert len(blocks) >= 2
    for block in blocks:
        assert sum(key in block for key in CHECKS) == 1, f"no check (or several) for this README block:\n{block}"
    for key in CHECKS:
        assert sum(key in block for block in python_examples()) == 1, f"CHECKS' {key!r} is no example (or several)"


@pytest.mark.slow  # measured under load: the fmpy example 31 s, the physics example 58 s (18 s of CPU)
@pytest.mark.parametrize("index", range(len(python_examples())))
def test_readme_example_runs(index, fmus, tmp_path):
    block = python_examples()[index]
    (tmp_path / "dist").mkdir()
    (tmp_path / "dist" / "FemPendulum.fmu").symlink_to(fmus[0])
    script = tmp_path / "example.py"
    command = [sys.executable, str(script)]
    if "(pendulum_loop)" in block:  # a test file: pytest runs it, the plugin's fixture finding dist/FemPendulum.fmu
        script = tmp_path / "test_example.py"
        command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(script)]
    script.write_text(block)
    run = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, f"README example {index} failed:\n{block}\n{run.stderr[-3000:]}"
    for key, check in CHECKS.items():
        if key in block:
            check(run.stdout)


# ---------------------------------------------------------------------------------------------------------------------
# The ```bash blocks. Each runs with `bash -e` as written, in a folder laid out as a clean clone after the main job
# (clean_clone: `.venv` is this test's environment, `examples/` the repository's, `dist/` the session's FMUs), and
# its check reads what it printed and wrote; or it is listed as NotRun with the reason, and its check tests what can
# be tested without running it. SHELL is the one table of both; a block it does not know fails the test.

SHELL_BLOCK = re.compile(r"^```bash\n(.*?)^```", re.MULTILINE | re.DOTALL)


def bash_blocks(text: str) -> list[str]:
    return SHELL_BLOCK.findall(text)


def readme() -> str:
    return (ROOT / "README.md").read_text()


def clean_clone(folder: Path, fmus: tuple[Path, Path] | None) -> Path:
    """`folder` laid out as a clean clone after the main job: `.venv` (this interpreter's environment),
    `examples/` and, unless `fmus` is None, `dist/FemPendulum.fmu` and `dist/PidController.fmu`."""
    (folder / ".venv").symlink_to(Path(sys.prefix))
    (folder / "examples").symlink_to(ROOT / "examples")
    if fmus is not None:
        (folder / "dist").mkdir()
        for fmu in fmus:
            (folder / "dist" / fmu.name).symlink_to(fmu)
    return folder


def bash(script: str, folder: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["bash", "-ec", script], cwd=folder, capture_output=True, text=True, timeout=900)


def commands(block: str) -> list[list[str]]:
    """The block's command lines as argument lists: continuations joined, comments dropped, split at `&&`."""
    found = []
    for line in block.replace("\\\n", " ").splitlines():
        words = shlex.split(line, comments=True)
        while words:
            end = words.index("&&") if "&&" in words else len(words)
            found.append(words[:end])
            words = words[end + 1 :]
    return found


def fem_pendulum_arguments(block: str) -> list[list[str]]:
    """The arguments after `fem-pendulum` of every fem-pendulum command of a block."""
    return [words[1:] for words in commands(block) if words and words[0].endswith("fem-pendulum")]


def parses(arguments: list[str]) -> None:
    """The current command line accepts these arguments (argparse exits 2 on an unknown option or value)."""
    from fem_pendulum_fmu.cli import parser

    try:
        parser().parse_args(arguments)
    except SystemExit as exc:
        raise AssertionError(f"`fem-pendulum {shlex.join(arguments)}` is not a valid command line") from exc


def _output(run: subprocess.CompletedProcess[str]) -> str:
    return f"exit {run.returncode}\nstdout:\n{run.stdout[-3000:]}\nstderr:\n{run.stderr[-3000:]}"


# the line `fem-pendulum run` prints at the end of a complete run (masters/open_loop.py summary)
RUN_LINE = re.compile(
    r"^wrote (\S+) and (\S+); (\d+) impacts, min gap (\S+) m, max contact force (\S+) N, max \|E - E0 - W\| (\S+) J$",
    re.MULTILINE,
)


def check_run_lines(folder: Path, stdout: str, prefixes: list[str], stop_time: float) -> list[re.Match]:
    """Each prefix's run printed its summary line, wrote PREFIX.csv (up to the stop time) and PREFIX.png, met the
    wall (the torque examples all drive it there within the time given) and kept its energy balance."""
    lines = list(RUN_LINE.finditer(stdout))
    assert [m.group(1) for m in lines] == [f"{p}.csv" for p in prefixes], stdout
    for m, prefix in zip(lines, prefixes, strict=True):
        assert m.group(2) == f"{prefix}.png" and (folder / f"{prefix}.png").stat().st_size > 0
        with open(folder / f"{prefix}.csv") as f:
            rows = list(csv.DictReader(f))
        assert abs(float(rows[-1]["time"]) - stop_time) < 1e-9
        assert int(m.group(3)) >= 1 and float(m.group(4)) < 0.0 and float(m.group(5)) > 0.0, m.group(0)
        assert float(m.group(6)) < 1e-6, m.group(0)  # J; measured 2e-9 at most (energy-consistent scheme)
    return lines


def check_main_job(block: str, folder: Path) -> None:
    # The block's commands after the install run verbatim, building their own dist/. Measured: 41 s, 35 of them
    # drawing the 201 frames of the animation.
    install = "python3 -m venv .venv && .venv/bin/pip install . && "
    assert block.startswith(install) and block.count("\n") == 1, block
    run = bash(block[len(install) :], folder)
    assert run.returncode == 0, _output(run)
    built, controller, *rest = run.stdout.splitlines()
    assert (folder / built).resolve() == (folder / "dist" / "FemPendulum.fmu").resolve(), run.stdout
    assert (folder / controller).resolve() == (folder / "dist" / "PidController.fmu").resolve(), run.stdout
    check_run_lines(folder, run.stdout, ["out/run"], 2.0)
    assert rest[-1] == "wrote out/run.gif: 201 frames of the field output in out/run_fields", run.stdout
    from PIL import Image

    with Image.open(folder / "out" / "run.gif") as gif:
        assert gif.n_frames == 201  # a frame every 10 ms from 0 to 2 s, as the README says
    assert (folder / "out" / "run_fields" / "pendulum.pvd").is_file()


def check_ci(block: str, folder: Path) -> None:
    # the README says what .ci/run does; these are the lines that do it
    assert block == "bash .ci/run\n"
    lines = (ROOT / ".ci" / "run").read_text().splitlines()
    for line in (
        "rm -rf .venv dist/wheel",  # the README: it deletes .venv and builds it again
        "python3 -m venv .venv",
        ".venv/bin/python -m pip wheel --quiet --no-deps --wheel-dir dist/wheel .",
        '.venv/bin/python -m pip install --quiet "${wheel}[test,docs]"',
        ".venv/bin/ruff check .",
        ".venv/bin/mypy fem_pendulum_fmu",
        '.venv/bin/mkdocs build --strict --site-dir "$(mktemp -d)"',  # the README: it builds the documentation
    ):
        assert line in lines, line
    assert any(line.startswith(".venv/bin/pytest -q") for line in lines), lines  # the whole suite, in any workers
    assert "`bash .ci/run` deletes `.venv` and builds it again" in " ".join(readme().split())


def check_fmpy_command(folder: Path, run: subprocess.CompletedProcess[str]) -> None:
    # out.csv up to the modelDescription's stop time of 2 s, the pendulum reaching the wall on the way
    # (measured: gap_min -2.0e-5 m, 4.5 s wall time), and no Discard on the way
    assert "[DISCARD]" not in run.stdout + run.stderr, _output(run)
    with open(folder / "out.csv") as f:
        rows = list(csv.DictReader(f))
    assert abs(float(rows[-1]["time"]) - 2.0) < 1e-9
    assert min(float(row["gap_min"]) for row in rows) < 0.0


def check_open_loop(folder: Path, run: subprocess.CompletedProcess[str]) -> None:
    # measured: 3 impacts each, min gap -1.2e-4 m, energy error 6e-10 J (fem) and 2e-9 J (auto); 5 s and 2 s
    check_run_lines(folder, run.stdout, ["out/sine", "out/auto"], 2.0)


def check_field_output(folder: Path, run: subprocess.CompletedProcess[str]) -> None:
    # one impact in the first half second (measured at 0.18 s), 51 frames 10 ms apart; 3 s
    check_run_lines(folder, run.stdout, ["out/fields"], 0.5)
    index = (folder / "out" / "fields" / "pendulum.pvd").read_text()
    frames = re.findall(r'<DataSet timestep="([^"]+)" group="" part="0" file="([^"]+)"/>', index)
    assert [float(t) for t, _ in frames] == pytest.approx([0.01 * k for k in range(51)], abs=1e-9), index
    last = (folder / "out" / "fields" / frames[-1][1]).read_text()
    for name in ("displacement", "velocity", "von_mises"):
        assert f'Name="{name}"' in last


def check_controller(folder: Path, run: subprocess.CompletedProcess[str]) -> None:
    # the printed line and out/control.csv against the figures the README states and the loop's physics; 6 s
    import pendulum_closed_form as closed

    from fem_pendulum_fmu.masters.control.figure import wall_impacts
    from fem_pendulum_fmu.physics.scene import Scene

    stated = re.search(
        r"(\d+) rebounds in the first such half-period, (\d+) wall impacts in\s+all and an RMS tracking error of "
        r"([\d.]+) degrees",
        readme(),
    )
    assert stated, "the README's controller figures"
    line = re.fullmatch(
        r"wrote out/control.csv, out/control.png and out/control.json; RMS tracking error (\S+) deg, "
        r"(\d+) wall impacts, largest contact force (\S+) N, (\S+) s at the drive limit",
        run.stdout.strip(),
    )
    assert line, run.stdout
    # The bouncing is chaotic: its figures move with the arithmetic's last bits. Measured with `--set
    # solver.tolerance=T` added to the README's command, T = 1e-3 (the default), 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5:
    # RMS 8.93-9.10 deg; 17, 19, 15, 17, 20, 15, 16 impacts, and 16, 17, 14, 16, 19, 14, 15 rebounds while the
    # set-point is negative (2/3 s to 4/3 s). The ranges are the measured ones widened by 3 either way.
    assert abs(float(line.group(1)) - float(stated.group(3))) < 0.2, line.group(0)
    assert (folder / "out" / "control.png").stat().st_size > 0
    metrics = json.loads((folder / "out" / "control.json").read_text())["metrics"]
    data = np.genfromtxt(folder / "out" / "control.csv", delimiter=",", names=True)
    impacts = wall_impacts(data)
    during = impacts[(impacts > 0.66) & (impacts < 1.34)]
    assert metrics["impacts"]["value"] == int(line.group(2)) and abs(data["time"][-1] - 2.0) < 1e-9
    assert 12 <= int(line.group(2)) <= 23 and 12 <= int(stated.group(2)) <= 23, (line.group(0), impacts)
    assert 11 <= len(during) <= 22 and 11 <= int(stated.group(1)) <= 22, (stated.group(0), impacts)
    # every swing while the set-point is negative ends on the wall, none while it is positive
    assert np.all(np.diff(during) < 0.1) and not np.any((impacts > 0.1) & (impacts < 0.66)), impacts
    # the energy balance (measured 6e-10 to 3.9e-9 J), and no deeper into the wall than the most energetic swing
    # and the drive can press the head (measured 49.4-49.5 um against a bound of about 75 um)
    balance = data["energytotal"] - data["energytotal"][0] - data["energytorque_work"]
    assert np.max(np.abs(balance)) < 1e-6 and metrics["energy_error"]["value"] < 1e-6, metrics["energy_error"]
    drive = (float(np.max(data["energytotal"])), float(np.max(np.abs(data["torque"]))), 1e-3)
    assert 0.0 < -np.min(data["gap_min"]) <= closed.deepest_in_a_driven_run(Scene(), *drive), np.min(data["gap_min"])


def check_my_controller(folder: Path, run: subprocess.CompletedProcess[str]) -> None:
    # the PID FMU with the README's gains on the rigid pendulum; the metrics file holds every figure named
    assert run.stdout.startswith("wrote out/my_controller.csv, out/my_controller.png and out/my_controller.json; ")
    report = json.loads((folder / "out" / "my_controller.json").read_text())
    assert report["controller_set"] == ["Kp=20", "Ki=30", "Kd=0.6"] and report["disturbance"] == "step:-2,1.5"
    m = {name: entry["value"] for name, entry in report["metrics"].items()}
    assert {"overshoot", "rise_time", "settling_time", "steady_state_error", "max_impulse", "energy_error"} <= set(m)
    # the integral term removes the steady-state error the disturbance makes: measured 0.0147 rad over the last
    # 0.3 s, still recovering from the step at 1.5 s; without the disturbance it would be 0
    assert m["impacts"] == 0 and abs(m["steady_state_error"]) < 0.03
    table = np.genfromtxt(folder / "out" / "my_controller.csv", delimiter=",", names=True, deletechars="")
    assert table["disturbance"][table["time"] > 1.5001].max() == -2.0 and table["disturbance"][1:1500].max() == 0.0


def check_sweep_extra(block: str, folder: Path) -> None:
    # the test environment has the sweep extra's packages: the test extra lists them all
    tomllib = pytest.importorskip("tomllib")
    assert block == '.venv/bin/pip install ".[sweep]"\n'
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert set(extras["sweep"]) <= set(extras["test"]), extras
    for module in ("dask", "distributed", "pandas", "pyarrow"):
        assert importlib.util.find_spec(module) is not None, module


SWEEP_LINE = "6 samples: 6 ok, 0 error; wrote out/sweep/results.parquet and out/sweep/series.parquet"


def check_sweep(folder: Path, run: subprocess.CompletedProcess[str]) -> None:
    # The varied parameters matter for the rigid fidelity, as the README says (measured: first contact at 0.182 s
    # and 0.196 s; largest penetration 0.49, 0.19 and 0.078 mm at 2e10, 2e11, 2e12 Pa/m from 0.2 rad); 6 s.
    import pandas as pd

    out = folder / "out" / "sweep"
    assert run.stdout.splitlines()[0] == SWEEP_LINE, _output(run)
    assert run.stdout.splitlines()[1:] == ["out/sweep/summary.png"], run.stdout
    for name in ("results.parquet", "results.csv", "series.parquet", "summary.png"):
        assert (out / name).stat().st_size > 0, name
    table = pd.read_parquet(out / "results.parquet")
    assert len(table) == 6 and (table["status"] == "ok").all(), table
    assert set(table["model.fidelity"]) == {"rigid"}, table["model.fidelity"]
    assert sorted(set(table["theta0"])) == [0.2, 0.35]
    for _, same_angle in table.groupby("theta0"):
        depth = same_angle.sort_values("contact.stiffness")["largest_penetration"].to_numpy()
        assert np.all(depth[1:] < depth[:-1] / 1.5), depth  # 10 times stiffer: at least 1.5 times shallower
    for _, same_contact in table.groupby("contact.stiffness"):
        first = same_contact.set_index("theta0")["first_contact_time"]
        assert first[0.35] - first[0.2] > 5e-3, first  # released further from the wall, it gets there later
    soft, stiff = (table[(table["theta0"] == 0.2) & (table["contact.stiffness"] == k)] for k in (2e10, 2e12))
    assert float(soft["largest_penetration"].iloc[0]) == pytest.approx(0.49e-3, rel=0.1)  # the README's figures
    assert float(stiff["largest_penetration"].iloc[0]) == pytest.approx(0.08e-3, rel=0.1)
    series = pd.read_parquet(out / "series.parquet")
    assert set(series["sample_id"]) == set(table["sample_id"])


def check_cluster(block: str, folder: Path) -> None:
    # the Dask commands take these options, and the sweep is the local one (on the scheduler instead of local
    # workers, into a folder of its own)
    scheduler, worker, sweep = commands(block)
    assert scheduler[:2] == ["dask", "scheduler"] and worker[:2] == ["dask", "worker"], block
    for words in (scheduler, worker):
        helped = subprocess.run(
            [str(Path(sys.prefix) / "bin" / "dask"), words[1], "--help"], capture_output=True, text=True, timeout=120
        )
        assert helped.returncode == 0, helped.stderr
        for option in (w for w in words if w.startswith("--")):
            assert option in helped.stdout, f"dask {words[1]} has no {option}"
    parses(sweep[1:])
    (local,) = (b for b in bash_blocks(documents()) if "--workers 1 --out out/sweep" in b)
    (local_sweep,) = fem_pendulum_arguments(local)

    def without(words: list[str], option: str) -> list[str]:
        k = words.index(option)
        return words[:k] + words[k + 2 :]

    cluster = without(without(sweep[1:], "--scheduler"), "--out")
    assert cluster == without(without(local_sweep, "--workers"), "--out"), (sweep, local_sweep)


def check_other_machine(block: str, folder: Path) -> None:
    # the wheel's name, pythonfmu's deploy option and what it installs: the FMU's resources/requirements.txt
    wheel, deploy, run_deploy = commands(block)
    assert wheel == ["pip", "install", "fem_pendulum_fmu-*.whl"] and deploy == ["pip", "install", "pythonfmu"]
    assert run_deploy == ["pythonfmu", "deploy", "-f", "FemPendulum.fmu"], block
    helped = subprocess.run(
        [str(Path(sys.prefix) / "bin" / "pythonfmu"), "deploy", "--help"], capture_output=True, text=True, timeout=120
    )
    assert helped.returncode == 0 and "-f FMU" in helped.stdout, helped.stdout + helped.stderr
    with zipfile.ZipFile(folder / "dist" / "FemPendulum.fmu") as fmu:
        needed = fmu.read("resources/requirements.txt").decode().split()
    assert [re.split("[<>=]", r)[0] for r in needed] == ["ngsolve", "numpy", "scipy"], needed  # as the README says
    for requirement in needed:
        importlib.metadata.version(re.split("[<>=]", requirement)[0])  # installed here


def check_host_env(folder: Path, run: subprocess.CompletedProcess[str]) -> None:
    # the two variables are exported (the test's own line after the block prints them) and name this environment
    libpython, python = run.stdout.splitlines()[-2:]
    assert Path(libpython).is_file() and Path(libpython).name.startswith("libpython"), libpython
    prefix = subprocess.run([python, "-c", "import sys; print(sys.prefix)"], capture_output=True, text=True)
    assert prefix.stdout.strip() == sys.prefix, (python, prefix.stdout)


def check_c_host(folder: Path, run: subprocess.CompletedProcess[str]) -> None:
    # 300 rigid steps of 1 ms from the default 20 degrees, the NaN torque refused with fmi2Error (3), and the
    # restored state replaying bit-identically; the value references the README passes are those of the FMU
    from fmpy import read_model_description

    variables = {v.name: v for v in read_model_description(str(folder / "out" / "fmu")).modelVariables}
    assert [v.valueReference for v in (variables["model.fidelity"], variables["theta"])] == [25, 1]
    assert {i.name: int(i.value) for i in variables["model.fidelity"].declaredType.items}["rigid"] == 2
    extracted, *lines = run.stdout.splitlines()
    assert extracted == "out/fmu"  # what fmpy.extract printed
    steps = np.array([[float(x) for x in line.split()] for line in lines[:300]])
    assert steps[:, 0] == pytest.approx(1e-3 * np.arange(1, 301), abs=1e-12)
    assert abs(steps[0, 1] - math.radians(20.0)) < 1e-3 and steps[-1, 1] < steps[0, 1] - 0.1  # it swings down
    assert lines[300] == "nan-torque-status 3" and lines[301].startswith("serialised-state-bytes ")
    passes = [line.split() for line in lines[302:]]
    assert [p[0] for p in passes] == ["pass0"] * 5 + ["pass1"] * 5 and passes[:5] == [
        ["pass0", v] for _, v in passes[5:]
    ]
    assert (folder / "fmi2_host").is_file()


def check_fmi3_build(folder: Path, run: subprocess.CompletedProcess[str]) -> None:
    # the FMI 3.0 FMU built where the README says, valid, and its run the FMI 2.0 FMU's to the last bit
    from fmpy import simulate_fmu
    from fmpy.validation import validate_fmu

    fmu3 = folder / "dist" / "FemPendulum3.fmu"
    assert run.stdout.splitlines()[0] == "dist/FemPendulum3.fmu" or Path(run.stdout.split()[0]) == fmu3.resolve()
    assert validate_fmu(str(fmu3)) == []
    rows = np.genfromtxt(folder / "out3.csv", delimiter=",", names=True)
    fmi2 = simulate_fmu(str(folder / "dist" / "FemPendulum.fmu"), stop_time=0.5, start_values={"model.fidelity": 2})
    assert len(rows) == len(fmi2) == 501 and np.array_equal(rows["theta"], fmi2["theta"])


@dataclass(frozen=True)
class Runs:
    """A block that runs as written: `check(folder, run)` after it exited 0."""

    check: Callable[[Path, subprocess.CompletedProcess[str]], None]
    after: str = ""  # the test's own lines after the block's (to print what the block only sets)
    slow: bool = False  # 4 s or more: the slow lane, as tests/conftest.py's SLOW_CASES


@dataclass(frozen=True)
class NotRun:
    """A block that does not run as written in a test, why, and `check(block, folder)`: what is tested instead."""

    reason: str
    check: Callable[[str, Path], None]
    slow: bool = False


# a text that identifies one block -> how the test treats it
SHELL: dict[str, Runs | NotRun] = {
    "python3 -m venv .venv && .venv/bin/pip install . &&": NotRun(
        "the main job: it makes .venv and installs the checkout into it, which the test's environment already is "
        "(.ci/run installs the wheel instead); its commands after the install run verbatim",
        check_main_job,
        slow=True,
    ),
    "bash .ci/run": NotRun("the CI itself: it deletes .venv and runs the whole suite, this test included", check_ci),
    "fmpy simulate dist/FemPendulum.fmu": Runs(check_fmpy_command),
    "torque_sine.csv": Runs(check_open_loop, slow=True),
    "output.vtk_folder=out/fields": Runs(check_field_output),
    "--out out/control": Runs(check_controller, slow=True),
    "--out out/my_controller": Runs(check_my_controller),
    'pip install ".[sweep]"': NotRun(
        "installs into .venv; the test's environment has the sweep extra's packages", check_sweep_extra
    ),
    "--workers 1 --out out/sweep": Runs(check_sweep, slow=True),
    "dask scheduler": NotRun(
        "a Dask scheduler and workers on other machines, at the user's SCHEDULER_HOST", check_cluster
    ),
    "pythonfmu deploy": NotRun(
        "installs a wheel, or the FMU's requirements, into the current environment of another machine",
        check_other_machine,
    ),
    "fem-pendulum host-env": Runs(
        check_host_env, after='printf "%s\\n" "$FEM_PENDULUM_LIBPYTHON" "$FEM_PENDULUM_PYTHON"'
    ),
    "examples/c_host/fmi2_host.c": Runs(check_c_host),
    "--fmi-version 3": Runs(check_fmi3_build),
}


def test_every_bash_block_is_known():
    for block in bash_blocks(readme()):
        assert sum(key in block for key in SHELL) == 1, (
            f"no entry (or several) in SHELL for this README block:\n{block}"
        )
    blocks = bash_blocks(documents())
    for key in SHELL:
        assert sum(key in block for block in blocks) == 1, f"SHELL's {key!r} is no README or guide block (or several)"


def test_every_fem_pendulum_command_is_current():
    # the blocks' commands and the prose's (`fem-pendulum interface --write-readme README.md`, ...) parse with the
    # current command line; placeholders in capitals (COMMAND) are not commands
    text = documents()
    found = [a for block in bash_blocks(text) for a in fem_pendulum_arguments(block)]
    found += [shlex.split(s) for s in re.findall(r"`(?:\.venv/bin/)?fem-pendulum ([^`]*)`", text)]
    assert len(found) >= 12
    for arguments in found:
        if not any(word.isupper() for word in arguments):
            parses(arguments)


def _block(key: str) -> str:
    (block,) = [b for b in bash_blocks(documents()) if key in b]
    return block


def _id(key: str) -> str:
    return SHELL[key].check.__name__.removeprefix("check_")


def _cases(kind: type) -> list:
    return [
        pytest.param(k, marks=[pytest.mark.slow] if v.slow else [], id=_id(k))
        for k, v in SHELL.items()
        if isinstance(v, kind)
    ]


@pytest.mark.parametrize("key", _cases(Runs))
def test_readme_bash_block_runs(key, fmus, tmp_path):
    entry = SHELL[key]
    assert isinstance(entry, Runs)
    folder = clean_clone(tmp_path, fmus)
    run = bash(_block(key) + entry.after, folder)
    assert run.returncode == 0, _output(run)
    entry.check(folder, run)


@pytest.mark.parametrize("key", _cases(NotRun))
def test_readme_bash_block_not_run(key, request, tmp_path):
    entry = SHELL[key]
    assert isinstance(entry, NotRun) and entry.reason
    main_job = entry.check is check_main_job  # it builds its own dist/
    entry.check(_block(key), clean_clone(tmp_path, None if main_job else request.getfixturevalue("fmus")))
