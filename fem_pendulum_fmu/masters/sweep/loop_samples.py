"""The samples of a loop sweep (`fem-pendulum sweep --control`): each sample a run of the controller
loop of `fem-pendulum control` (masters/control/), its values of three kinds, by name:

    NAME                    a parameter of the pendulum FMU, read as in an open-loop sweep (samples.py);
    controller.NAME         a parameter of the controller FMU, checked against its modelDescription;
    setpoint, disturbance   a signal's text as `--setpoint` / `--disturbance` take it
                            (masters/control/signals.py: a number, step:A[,T], sine:A,F, ramp:R, a CSV file).

A signal's forms hold commas (sine:20deg,0.75), so the values of a setpoint or disturbance axis are
separated by `;` (SIGNAL_SEPARATOR): --param 'setpoint=step:10deg;sine:20deg,0.75'. Every sample has
both signals (by default those of `fem-pendulum control`), so that the results table says what each
sample tracked. A sample's id hashes a signal by what it is (its kind and parameters in SI units, or
a CSV file's content), not by its text: step:10deg and step:0.17453292519943295 are one sample, an
edited CSV file makes a new one. The pendulum starts at theta0 = 0 unless a sample sets it, as in
`fem-pendulum control`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from ...fmi import interface
from ..control.command import DEFAULT_SETPOINT
from ..control.controllers import ControllerFmuSpec, controller_fmu, parameter_values
from ..control.hold import HoldChoice
from ..control.loop import DEFAULT_START_VALUES
from ..control.signals import Quantity, Signal, parse_signal
from ..failures import UsageError
from .samples import Sample, Value, file_digest, parse_value, sample_id

CONTROLLER = "controller."
SIGNALS: dict[str, Quantity] = {"setpoint": "angle", "disturbance": "torque"}
SIGNAL_SEPARATOR = ";"
DEFAULT_SIGNALS = {"setpoint": DEFAULT_SETPOINT, "disturbance": "0"}  # those of `fem-pendulum control`
DEFAULT_DRIVE_LIMIT = 15.0  # N.m, as `fem-pendulum control`


@dataclass(frozen=True)
class LoopSweep:
    """What every sample of a loop sweep shares: the controller FMU, its wiring (`--connect FROM=TO`
    items; none: by name, as `fem-pendulum control`), the drive's torque limit (N.m) and the hold
    order (masters/control/hold.py)."""

    controller: Path
    connect: tuple[str, ...] = ()
    drive_limit: float = DEFAULT_DRIVE_LIMIT
    hold: HoldChoice = "auto"

    def spec(self) -> ControllerFmuSpec:
        """The controller FMU and its wiring, checked (masters/control/controllers.py); UsageError."""
        if not (math.isfinite(self.drive_limit) and self.drive_limit > 0):
            raise UsageError(f"--drive-limit {self.drive_limit!r} is not allowed: it must be a finite torque > 0 (N.m)")
        if not Path(self.controller).is_file():
            raise UsageError(f"--controller {str(self.controller)!r} is not an FMU file")
        return controller_fmu(Path(self.controller), self.connect)

    def parameter_types(self) -> dict[str, str]:
        """The controller's parameters and their types (Real, Integer, Boolean, ...)."""
        from fmpy import read_model_description

        md = read_model_description(str(self.controller))
        return {v.name: v.type for v in md.modelVariables if v.causality == "parameter"}


def is_loop_name(name: str) -> bool:
    """A controller parameter or a signal, not a pendulum parameter."""
    return name in SIGNALS or name.startswith(CONTROLLER)


def signal_of(name: str, text: str) -> Signal:
    """The set-point or disturbance a sample's text describes; UsageError naming `name`."""
    return parse_signal(text, SIGNALS[name], name)


def signal_key(signal: Signal) -> str:
    """What a signal is, as text for a sample's id: a table by its file's content, a form by its
    kind and parameters in SI units (not by how they were written)."""
    if signal.kind == "table":
        return f"table {file_digest(signal.source)}"
    return json.dumps({k: v for k, v in signal.as_dict().items() if k != "description"}, sort_keys=True)


def parse_loop_value(name: str, raw: object, types: Mapping[str, str], folder: Path | None = None) -> Value:
    """A loop sample's value of `name` (module docstring), checked; ValueError naming it and what is
    allowed. A signal's CSV file is found relative to `folder` (a table's), else to the working folder."""
    if name in SIGNALS:
        text = str(raw).strip()
        if folder is not None and text and (folder / text).is_file():
            text = str((folder / text).resolve())
        elif Path(text).is_file():
            text = str(Path(text).resolve())
        signal_of(name, text)
        return text
    if name.startswith(CONTROLLER):
        parameter = name.removeprefix(CONTROLLER)
        return parameter_values({parameter: raw}, types, written=CONTROLLER + "{}")[parameter]
    value = parse_value(name, str(raw))  # str() of a Python number is exact (its repr)
    if interface.load().by_name(name).type == "String":
        raise ValueError(f"{name}: the controller loop sets no String parameters (field output: open-loop sweeps)")
    return value


def parse_loop_param(item: str, types: Mapping[str, str]) -> tuple[str, list[Value]]:
    """`NAME=V1,V2,...` (or `setpoint=S1;S2;...`) -> (NAME, values), for a loop sweep's grid axis."""
    name, eq, text = (part.strip() for part in item.partition("="))
    separator = SIGNAL_SEPARATOR if name in SIGNALS else ","
    if not eq or not text:
        raise ValueError(f"expected NAME=VALUE1{separator}VALUE2{separator}...")
    return name, [parse_loop_value(name, part, types) for part in text.split(separator)]


def loop_samples(rows: list[dict], loop: LoopSweep, folder: Path | None = None) -> list[Sample]:
    """Rows (samples.grid or samples.read_table) -> loop samples, each with both signals (DEFAULT_SIGNALS
    where a row has none). A row's signal CSV paths are relative to `folder` (a table's). Every problem
    is reported at once, on one line: ValueError."""
    types = loop.parameter_types()
    problems: dict[str, list[int]] = {}  # a problem's text -> the samples that have it
    out: list[Sample] = []
    seen: dict[str, int] = {}
    for number, row in enumerate(rows, 1):
        if row.get("torque"):
            problems.setdefault("a torque column: a loop sample's torque comes from the controller", []).append(number)
            continue
        values: dict[str, Value] = {}
        merged = {**row, **{n: d for n, d in DEFAULT_SIGNALS.items() if row.get(n) in (None, "")}}
        for name, raw in merged.items():
            if name == "torque" or raw is None or raw == "":
                continue
            try:
                values[name] = parse_loop_value(name, raw, types, folder)
            except ValueError as exc:
                problems.setdefault(str(exc), []).append(number)
        if any(name not in values for name in SIGNALS):
            continue  # a signal that did not parse: reported above
        keys = {name: signal_key(signal_of(name, str(values[name]))) for name in SIGNALS}
        sample = Sample(sample_id({**values, **keys}, ""), values)
        if sample.sample_id in seen:
            problems.setdefault(f"repeats sample {seen[sample.sample_id]}", []).append(number)
        seen.setdefault(sample.sample_id, number)
        out.append(sample)
    if problems:
        found = [f"sample{'s' * (len(n) > 1)} {', '.join(map(str, n))}: {text}" for text, n in problems.items()]
        raise ValueError("cannot read the samples: " + "; ".join(found))
    return out


def pendulum_values(values: Mapping[str, Value]) -> dict[str, Value]:
    """A loop sample's pendulum parameters as the loop starts the pendulum (theta0 = 0 unless set)."""
    return {**DEFAULT_START_VALUES, **{k: v for k, v in values.items() if not is_loop_name(k)}}


def controller_values(values: Mapping[str, Value]) -> dict[str, float | int | bool]:
    """A loop sample's controller parameters, by the controller's own names (without `controller.`)."""
    return {k.removeprefix(CONTROLLER): cast(float, v) for k, v in values.items() if k.startswith(CONTROLLER)}
