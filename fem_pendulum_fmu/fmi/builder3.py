"""Builds the FMI 3.0 FemPendulum FMU (`fem-pendulum build --fmi-version 3`).

pythonfmu3 packages the entry script (femp3_slave_entry.py: pythonfmu3's Fmi3Slave in front of the
FMI 2.0 slave's logic, fmi/slave3.py), the package's physics and FMI layer, pythonfmu's Python package
(the FMI 2.0 slave's base class) and its own binaries. Then, as for the FMI 2.0 FMU (builder.py): its
modelDescription.xml is replaced by the one rendered from the template (model_description3.py), its
x86_64-linux binary by ours (shim/: fmi3_*.c and the code both binaries share, compiled with
FMI3_BINARY and the instantiation token), its C++ sources are left out, and the resources get what the
binary reads. terminalsAndIcons/terminalsAndIcons.xml declares the hinge's rotational flange. The FMU
must pass fmpy's validation. docs/notes/fmu_layer.md.
"""

from __future__ import annotations

import shutil
import tempfile
import uuid
from pathlib import Path

from .builder import (
    FMI_DIR,
    PENDULUM_REQUIREMENTS,
    SHARED_SOURCES,
    finish_fmu,
    now_iso,
    shim_resources,
    stage_package,
    validate,
)
from .interface import TEMPLATE_NAME, render
from .model_description3 import to_fmi3

FMI3_SOURCES = ("fmi3_functions.c", "fmi3_step.c", "fmi3_states.c", "fmi3_unsupported.c", *SHARED_SOURCES)
ENTRY = "femp3_slave_entry.py"

# the hinge's rotational flange as a bus of signals, named as Modelica's rotational flange names them (phi, w,
# tau): the angle and the angular velocity are outputs, the torque the input that drives it. Not Modelica's
# acausal Flange (phi and the flow tau), which a causal co-simulation FMU cannot be: hence its own terminalKind
TERMINALS = """<?xml version="1.0" encoding="UTF-8"?>
<fmiTerminalsAndIcons fmiVersion="3.0">
  <Terminals>
    <Terminal name="hinge" matchingRule="bus" terminalKind="fem_pendulum_fmu.RotationalFlangeSignals"
        description="The hinge's rotational flange as signals: angle phi, angular velocity w out, torque tau in">
      <TerminalMemberVariable variableName="theta" memberName="phi" variableKind="signal"/>
      <TerminalMemberVariable variableName="omega" memberName="w" variableKind="signal"/>
      <TerminalMemberVariable variableName="torque" memberName="tau" variableKind="signal"/>
    </Terminal>
  </Terminals>
</fmiTerminalsAndIcons>
"""


def _pythonfmu_package(target: Path) -> Path:
    """pythonfmu's Python package (the FMI 2.0 slave's base class), without its binaries."""
    import pythonfmu

    source = Path(pythonfmu.__file__).parent
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "resources", "tests"))
    return target


def build_pendulum3(output: Path) -> Path:
    """Build the FMI 3.0 FemPendulum FMU at `output`, validated."""
    from pythonfmu3.builder import FmuBuilder

    from ..version import __version__

    token = "{" + str(uuid.uuid4()) + "}"
    xml2 = render(token, now_iso(), __version__, fmi_version=3)  # FMI 2.0's form, FMI 3.0's names (fmi_names.py)
    xml3 = to_fmi3(xml2, token)
    output = Path(output).resolve()
    output.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="fem_pendulum_build3_") as tmp:
        tmp_path = Path(tmp)
        (tmp_path / TEMPLATE_NAME).write_text(xml2)  # what the slave reads its variables from (interface.py)
        stage_package(tmp_path / "fem_pendulum_fmu")
        entry = tmp_path / ENTRY
        shutil.copy2(FMI_DIR / ENTRY, entry)
        project = [tmp_path / "fem_pendulum_fmu", tmp_path / TEMPLATE_NAME, _pythonfmu_package(tmp_path / "pythonfmu")]
        dist = tmp_path / "dist"
        built = Path(FmuBuilder.build_FMU(entry, dest=dist, project_files=project))
        shutil.move(str(built), output)
    finish_fmu(
        output,
        "FemPendulum",
        xml3,
        shim_resources(PENDULUM_REQUIREMENTS),
        platform="x86_64-linux",
        names=FMI3_SOURCES,
        extra={"terminalsAndIcons/terminalsAndIcons.xml": TERMINALS},
    )
    return validate(output)
