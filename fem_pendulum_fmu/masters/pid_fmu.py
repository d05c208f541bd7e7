"""Builds the PID controller FMU used by the controller-in-the-loop example."""
from __future__ import annotations

import datetime
import shutil
import tempfile
import uuid
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent


def build_pid_fmu(output: Path) -> Path:
    from pythonfmu.builder import FmuBuilder

    from .. import __version__

    xml = (HERE / "PidController.template.xml").read_text()
    xml = (xml.replace("{{GUID}}", str(uuid.uuid4())).replace("{{VERSION}}", __version__)
           .replace("{{DATE}}", datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")))
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="pid_build_") as tmp:
        tmp = Path(tmp)
        entry = tmp / "fem_pendulum_pid_entry.py"
        shutil.copy2(HERE / "fem_pendulum_pid_entry.py", entry)
        built = Path(FmuBuilder.build_FMU(entry, dest=tmp / "out.fmu"))
        with zipfile.ZipFile(built) as src, zipfile.ZipFile(output, "w", zipfile.ZIP_DEFLATED) as dst:
            for item in src.infolist():
                if item.filename != "modelDescription.xml":
                    dst.writestr(item, src.read(item.filename))
            dst.writestr("modelDescription.xml", xml)
    return output
