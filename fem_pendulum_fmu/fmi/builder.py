"""Builds this project's FMUs: FemPendulum.fmu (and, through masters/pid, PidController.fmu).

pythonfmu packages an entry script, project files and its binary. Its own
modelDescription.xml (no units, no InitialUnknowns) is then replaced by the
rendered template, its linux64 binary by ours (shim/: the whole FMI 2.0
interface in C, calling the Python slave; compiled here with the system C
compiler against this Python's headers, with the FMU's GUID and capability
flags) and the resources get what the binary reads: the interpreter to start in a host without Python
(python_environment.txt), the packages to check (requirements.txt) and the
check itself (femp_preflight.py). Every FMU must pass fmpy's validation.
"""

from __future__ import annotations

import datetime
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import uuid
import zipfile
from importlib import metadata
from pathlib import Path

from .binary_config import capability_defines, variables_header
from .host_env import python_environment
from .interface import TEMPLATE_NAME, render

FMI_DIR = Path(__file__).resolve().parent
PACKAGE_DIR = FMI_DIR.parent
SHARED_SOURCES = (
    "fmu_state_calls.c",
    "values.c",
    "call_frame.c",
    "slave.c",
    "state_machine.c",
    "variables.c",
    "fmu_states.c",
    "python_runtime.c",
)
SHIM_SOURCES = ("fmi2_functions.c", "fmi2_states.c", *SHARED_SOURCES)  # the FMI 2.0 binary
# what the pendulum FMU imports at run time besides pythonfmu, which pythonfmu ships in every FMU's
# resources (fmpy and the masters' packages are not among them)
PENDULUM_REQUIREMENTS = ("ngsolve", "numpy", "scipy")


def now_iso() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


def requirements_txt(names: tuple[str, ...]) -> str:
    """The named dependencies as this package declares them (minimum versions, no pins), one a line."""
    declared = {}
    for spec in metadata.requires("fem_pendulum_fmu") or []:
        name = re.match(r"[A-Za-z0-9_.\-]+", spec)
        if name and ";" not in spec:  # with a marker: an extra's requirement
            declared[name.group(0).lower()] = spec.replace(" ", "")
    return "".join(f"{declared.get(name, name)}\n" for name in names)


def python_environment_txt() -> str:
    return "".join(f"{key}={value}\n" for key, value in python_environment().items())


def compile_shim(output: Path, model_description: str, names: tuple[str, ...] = SHIM_SOURCES) -> bool:
    """Compile the FMU's binary (shim/: the files `names`) to `output`; False where there is no compiler or
    headers. The modelDescription's fmiVersion decides for which FMI (binary_config.capability_defines)."""
    import fmpy

    include = Path(sysconfig.get_paths()["include"])
    compiler = shutil.which("cc") or shutil.which("gcc")
    if not sys.platform.startswith("linux") or compiler is None or not (include / "Python.h").is_file():
        return False
    sources = [str(FMI_DIR / "shim" / name) for name in names]
    generated = output.parent / "generated"
    generated.mkdir(exist_ok=True)
    (generated / "fmu_variables.h").write_text(variables_header(model_description))
    subprocess.run(
        [
            compiler,
            "-shared",
            "-fPIC",
            "-O2",
            "-Wall",
            f"-I{Path(fmpy.__file__).parent / 'c-code'}",
            f"-I{include}",
            f"-I{FMI_DIR / 'shim'}",
            f"-I{generated}",
            *capability_defines(model_description),
            *sources,
            "-ldl",
            "-lpthread",
            "-lm",
            "-Wl,-z,defs",
            "-o",
            str(output),
        ],
        check=True,
    )
    return True


def finish_fmu(
    fmu: Path,
    model_identifier: str,
    model_description: str,
    resources: dict[str, str],
    platform: str = "linux64",
    names: tuple[str, ...] = SHIM_SOURCES,
    extra: dict[str, str] | None = None,
) -> None:
    """Rewrite pythonfmu's (or pythonfmu3's) archive: our modelDescription.xml, our binary (compiled from
    shim/'s `names`) in place of its binaries/<platform> one, the extra resources files, and `extra` files
    (archive name: text); its C++ sources (pythonfmu3's) are left out."""
    binary = f"binaries/{platform}/{model_identifier}.so"
    with tempfile.TemporaryDirectory() as tmp:
        shim = Path(tmp) / "shim.so"
        has_shim = compile_shim(shim, model_description, names)
        if not has_shim:
            print(
                f"{fmu.name}: no C compiler or Python headers; the FMU has pythonfmu's binary alone (no fmi2Error, "
                "no state machine, no Python for native hosts, pythonfmu's crash at exit; docs/guide/hosts.md)"
            )
        staged = fmu.with_suffix(".tmp")
        with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(staged, "w", zipfile.ZIP_DEFLATED) as dst:
            for item in src.infolist():
                name = item.filename
                if name == "modelDescription.xml" or name.startswith("sources/") or name in (extra or {}):
                    continue
                if name.startswith("resources/") and name[len("resources/") :] in resources:
                    continue
                data = src.read(item.filename)
                if item.filename == binary and has_shim:
                    dst.write(shim, binary)
                else:
                    dst.writestr(item, data)
            dst.writestr("modelDescription.xml", model_description)
            for name, text in resources.items():
                dst.writestr(f"resources/{name}", text)
            for name, text in (extra or {}).items():
                dst.writestr(name, text)
        staged.replace(fmu)


def shim_resources(requirements: tuple[str, ...]) -> dict[str, str]:
    """The resources files the front binary reads."""
    return {
        "python_environment.txt": python_environment_txt(),
        "requirements.txt": requirements_txt(requirements),
        "femp_preflight.py": (FMI_DIR / "preflight.py").read_text(),
    }


def validate(fmu: Path) -> Path:
    from fmpy.validation import validate_fmu

    problems = validate_fmu(str(fmu))
    if problems:
        raise SystemExit(f"{fmu} failed fmpy's validation:\n" + "\n".join(f"  - {p}" for p in problems))
    return fmu


def stage_package(target: Path) -> None:
    """Copy what the FMU runs (the package's physics and FMI layer, not the masters) to `target`."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "shim", "builder*.py", "preflight.py")
    target.mkdir(parents=True)
    for name in ("__init__.py", "version.py"):
        shutil.copy2(PACKAGE_DIR / name, target / name)
    for sub in ("physics", "fmi"):
        shutil.copytree(PACKAGE_DIR / sub, target / sub, ignore=ignore)


def build_pendulum(output: Path) -> Path:
    """Build FemPendulum.fmu at `output`, validated."""
    from pythonfmu.builder import FmuBuilder

    from ..version import __version__

    xml = render(str(uuid.uuid4()), now_iso(), __version__)
    output = Path(output).resolve()
    output.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="fem_pendulum_build_") as tmp:
        tmp_path = Path(tmp)
        (tmp_path / TEMPLATE_NAME).write_text(xml)
        stage_package(tmp_path / "fem_pendulum_fmu")
        entry = tmp_path / "femp_slave_entry.py"
        shutil.copy2(FMI_DIR / "femp_slave_entry.py", entry)
        built = Path(
            FmuBuilder.build_FMU(
                entry, dest=output, project_files=[tmp_path / "fem_pendulum_fmu", tmp_path / TEMPLATE_NAME]
            )
        )
    if built.resolve() != output:
        shutil.move(str(built), output)
    finish_fmu(output, "FemPendulum", xml, shim_resources(PENDULUM_REQUIREMENTS))
    return validate(output)
