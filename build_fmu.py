"""Build dist/FemPendulum.fmu (and dist/PidController.fmu) and check them with fmpy.

    python build_fmu.py [--output dist/FemPendulum.fmu]

pythonfmu packages the entry script, the fem_pendulum_fmu package and its
binary; its own modelDescription.xml (no units, no InitialUnknowns) is then
replaced by modelDescription.template.xml rendered with a GUID, the date and
the version. The result must pass fmpy's validation with no problem.
"""
from __future__ import annotations

import argparse
import datetime
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parent
PACKAGE = ROOT / "fem_pendulum_fmu"
REQUIREMENTS = ("ngsolve", "numpy", "scipy", "pythonfmu", "fmpy")  # what the FMU imports at run time


def requirements_txt() -> str:
    return "".join(f"{name}=={metadata.version(name)}\n" for name in REQUIREMENTS)


def replace_model_description(fmu: Path, xml: str) -> None:
    """Rewrite the FMU archive with our modelDescription.xml."""
    tmp = fmu.with_suffix(".tmp")
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            if item.filename != "modelDescription.xml":
                dst.writestr(item, src.read(item.filename))
        dst.writestr("modelDescription.xml", xml)
    tmp.replace(fmu)


def compile_status_shim(workdir: Path) -> Path | None:
    """Compile the fmi2Error shim (fem_pendulum_fmu/shim) for Linux; None where it cannot be built."""
    import fmpy

    if not sys.platform.startswith("linux") or shutil.which("cc") is None:
        return None
    out = workdir / "shim.so"
    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["cc", "-shared", "-fPIC", "-O2", f"-I{headers}", str(PACKAGE / "shim" / "fmi2_error_shim.c"),
                    "-ldl", "-o", str(out)], check=True)
    return out


def install_status_shim(fmu: Path, model_identifier: str) -> bool:
    """Put the shim in front of pythonfmu's linux64 binary, which becomes <id>_core.so."""
    with tempfile.TemporaryDirectory() as tmp:
        shim = compile_status_shim(Path(tmp))
        if shim is None:
            print("no C compiler: the FMU answers refused input with fmi2Discard instead of fmi2Error")
            return False
        binary = f"binaries/linux64/{model_identifier}.so"
        tmp_fmu = fmu.with_suffix(".tmp")
        with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(tmp_fmu, "w", zipfile.ZIP_DEFLATED) as dst:
            for item in src.infolist():
                data = src.read(item.filename)
                if item.filename == binary:
                    dst.writestr(f"binaries/linux64/{model_identifier}_core.so", data)
                    dst.write(shim, binary)
                else:
                    dst.writestr(item, data)
        tmp_fmu.replace(fmu)
    return True


def validate(fmu: Path) -> None:
    from fmpy.validation import validate_fmu

    problems = validate_fmu(str(fmu))
    if problems:
        raise SystemExit(f"{fmu} failed fmpy's validation:\n" + "\n".join(f"  - {p}" for p in problems))


def build_pendulum(output: Path) -> Path:
    from pythonfmu.builder import FmuBuilder

    sys.path.insert(0, str(ROOT))
    from fem_pendulum_fmu import __version__
    from fem_pendulum_fmu.interface import TEMPLATE_NAME, render

    xml = render(str(uuid.uuid4()), datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                 __version__)
    output.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="fem_pendulum_build_") as tmp:
        tmp = Path(tmp)
        (tmp / TEMPLATE_NAME).write_text(xml)
        (tmp / "requirements.txt").write_text(requirements_txt())
        stage = tmp / "fem_pendulum_fmu"
        shutil.copytree(PACKAGE, stage, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        built = FmuBuilder.build_FMU(stage / "femp_slave_entry.py", dest=output,
                                     project_files=[stage, tmp / TEMPLATE_NAME, tmp / "requirements.txt"])
    built = Path(built)
    if built.resolve() != output.resolve():
        shutil.move(str(built), output)
    replace_model_description(output, xml)
    install_status_shim(output, "FemPendulum")
    validate(output)
    return output


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--output", type=Path, default=ROOT / "dist" / "FemPendulum.fmu")
    parser.add_argument("--no-controller", action="store_true", help="do not build the PID controller FMU")
    args = parser.parse_args()
    print(build_pendulum(args.output.resolve()))
    if not args.no_controller:
        from fem_pendulum_fmu.masters.pid_fmu import build_pid_fmu

        controller = build_pid_fmu(args.output.resolve().parent / "PidController.fmu")
        validate(controller)
        print(controller)


if __name__ == "__main__":
    main()
