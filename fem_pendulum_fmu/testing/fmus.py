"""The FMUs a test suite runs: the ones `fem-pendulum build` writes, built on first use."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

DIST = Path("dist")


def default_fmu(name: str, folder: Path = DIST) -> Path:
    """folder/name (FemPendulum.fmu or PidController.fmu), built there first if it is missing; the
    build goes to a temporary file renamed into place, so that a reader never sees half an FMU."""
    path = Path(folder) / name
    if path.is_file():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}_", suffix=".fmu", dir=path.parent)
    os.close(fd)
    try:
        if name == "PidController.fmu":
            from ..fmi.builder import validate
            from ..masters.pid.build import build_pid_fmu

            validate(build_pid_fmu(Path(tmp)))
        else:
            from ..fmi.builder import build_pendulum

            build_pendulum(Path(tmp))
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path
