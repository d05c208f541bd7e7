"""Builds PidController.fmu, the controller of the controller-in-the-loop master, with the FMU builder of fmi/."""

from __future__ import annotations

import shutil
import tempfile
import uuid
from pathlib import Path

from ...fmi.builder import finish_fmu, now_iso, shim_resources

HERE = Path(__file__).resolve().parent


def build_pid_fmu(output: Path) -> Path:
    """Build PidController.fmu at `output` (not yet validated: the caller does)."""
    from pythonfmu.builder import FmuBuilder

    from ...version import __version__

    xml = (HERE / "PidController.template.xml").read_text()
    xml = xml.replace("{{GUID}}", str(uuid.uuid4())).replace("{{VERSION}}", __version__).replace("{{DATE}}", now_iso())
    output = Path(output).resolve()
    output.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="pid_build_") as tmp:
        entry = Path(tmp) / "fem_pendulum_pid_entry.py"
        shutil.copy2(HERE / "fem_pendulum_pid_entry.py", entry)
        built = Path(FmuBuilder.build_FMU(entry, dest=Path(tmp) / "out.fmu"))
        shutil.move(str(built), output)
    finish_fmu(output, "PidController", xml, shim_resources(()))
    return output
