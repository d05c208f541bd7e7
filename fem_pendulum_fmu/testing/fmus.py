"""The FMUs a test suite runs: the ones `fem-pendulum build` writes, built on first use."""

from __future__ import annotations

from pathlib import Path

DIST = Path("dist")


def default_fmu(name: str, folder: Path = DIST) -> Path:
    """folder/name (FemPendulum.fmu or PidController.fmu), built there first if it is missing (to a
    temporary file renamed into place, so that a reader never sees half an FMU)."""
    from ..physics.cache import write_atomically

    path = Path(folder) / name
    if not path.is_file():
        write_atomically(path, _build_pid if name == "PidController.fmu" else _build_pendulum)
    return path


def _build_pid(path: Path) -> None:
    from ..fmi.builder import validate
    from ..masters.pid.build import build_pid_fmu

    validate(build_pid_fmu(path))


def _build_pendulum(path: Path) -> None:
    from ..fmi.builder import build_pendulum

    build_pendulum(path)
