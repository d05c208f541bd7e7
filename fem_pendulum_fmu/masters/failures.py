"""How a command fails: bad input before anything runs (UsageError: one line, exit 2) and a run that
stopped before its stop time (IncompleteRun: what the FMU said, where, what to try; exit 1).
cli.py turns both into a message and an exit code, never a traceback; the checks here run before a
simulation starts, so that a bad value costs seconds, not a run."""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..physics.fidelity_rule import Choice
    from ..physics.scene import Scene


class UsageError(ValueError):
    """Bad input to a command: the message names the value and what is allowed."""


class IncompleteRun(RuntimeError):
    """A run that ended before its stop time; what it wrote is kept."""


def not_instantiated(fmu: Path | str, problems: list[str]) -> IncompleteRun:
    """The IncompleteRun of an FMU that refused fmi2Instantiate, with what it logged (fmpy says only
    "Failed to instantiate model"): a missing package, another copy of its package already imported."""
    said = "; ".join(problems) or "it logged no message"
    return IncompleteRun(f"the FMU {fmu} could not be instantiated: {said}")


def what_to_try(said: str, lighter: str) -> str:
    """The advice after a run the pendulum FMU stopped: `lighter`, the command's own way to load it less
    ("a smaller torque"), a stiffer material, a finer mesh, and a shorter --step unless the FMU said
    (`said`) that a shorter step cannot help: the advice must not contradict the message it follows."""
    from ..physics.protocol import NO_SHORTER_STEP

    ideas = [lighter, "a stiffer material", "a finer mesh (model.mesh_size)"]
    if NO_SHORTER_STEP not in said:
        ideas.append("a shorter --step")
    return f"Try {', '.join(ideas[:-1])} or {ideas[-1]}"


def finite_cell(row: list[str], k: int) -> tuple[float | None, str]:
    """Cell k of a CSV row as a finite number (None if it is not one, or missing), and its text."""
    text = row[k].strip() if k < len(row) else ""
    try:
        value = float(text)
    except ValueError:
        return None, text
    return (value if math.isfinite(value) else None), text


def check_times(stop_time: float, step: float) -> None:
    """UsageError unless the stop time is finite and positive and the step positive and not above it."""
    if not (math.isfinite(stop_time) and stop_time > 0.0):
        raise UsageError(f"--stop-time {stop_time!r} is not allowed: it must be a finite time > 0 (s)")
    if not (math.isfinite(step) and 0.0 < step <= stop_time):
        raise UsageError(
            f"--step {step!r} is not allowed: it must be a finite step > 0 (s), at most --stop-time {stop_time!r}"
        )


def check_fmu(path: Path, option: str = "--fmu") -> Path:
    """The FMU's path, or UsageError saying how to get one."""
    if path.is_file():
        return path
    hint = " (build it with `fem-pendulum build`, or give its path)" if not path.exists() else ""
    raise UsageError(f"{option} {str(path)!r} is not an FMU file{hint}")


def check_output_prefix(prefix: Path, option: str = "--out") -> None:
    """UsageError unless files PREFIX.csv and PREFIX.png can be written (the folder is made if missing)."""
    folder = prefix.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise UsageError(f"{option} {str(prefix)!r}: cannot write in {str(folder)!r} ({reason})") from None
    if not os.access(folder, os.W_OK):
        raise UsageError(f"{option} {str(prefix)!r}: the folder {str(folder)!r} is not writable")


def check_start_values(values: Mapping[str, Any]) -> Scene:
    """The FMU's own checks of its parameters (fmi/interface.py scene_from_values, physics/scene.py
    problems), before it is loaded: UsageError listing every bad value; the scene they describe."""
    from ..fmi import interface
    from ..physics.scene import problems

    ifc = interface.load()
    parameters = {v.name for v in ifc.of_causality("parameter")}
    try:
        scene = interface.scene_from_values({k: v for k, v in values.items() if k in parameters}, ifc)
    except ValueError as exc:
        raise UsageError(f"--set: {exc}") from None
    found = problems(scene)
    if found:
        raise UsageError("--set: " + "; ".join(found))
    return scene


def auto_choice(scene: Scene) -> Choice | None:
    """What model.fidelity = auto picks for `scene` and why (physics/fidelity_rule.py); None when
    the scene names its fidelity."""
    if scene.model.fidelity != "auto":
        return None
    from ..physics.fidelity_rule import choose

    return choose(scene)


def fidelity_choice(scene: Scene) -> str | None:
    """`auto_choice` as a line to print before a run."""
    choice = auto_choice(scene)
    return None if choice is None else f"model.fidelity = auto picks {choice.fidelity}: {choice.reason}"
