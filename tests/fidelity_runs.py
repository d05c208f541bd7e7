"""One way to drive a model in the tests: communication steps as an FMU master takes them, one row of outputs each.

`run` returns a numpy record array with a field per column of COLUMNS (out.theta, out["gap_min"]), the same
columns for every fidelity, so that two runs compare bit for bit with `same_bits`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from fem_pendulum_fmu.physics.protocol import ModelState, Outputs

DT = 1e-3  # the masters' communication step (s)

# every field of Outputs (protocol.py); gap_min is the smallest gap at any internal step of the communication step
COLUMNS = tuple(f.name for f in dataclasses.fields(Outputs))


def run(
    model,
    t_end: float,
    torque: float | Callable[[float], float] = 0.0,
    dt: float = DT,
    states: dict[int, ModelState | None] | None = None,
) -> np.recarray:
    """Advance `model` from its time t0 to t_end in communication steps of dt, ending at t0 + (k + 1) dt; torque
    is a number or a function of the step's start time.

    states: keys k (pre-filled with None) are the rows before which the state is saved: states[k] is the state
    at the start of row k's step (after k steps)."""
    t0 = model.time
    rows = []
    for k in range(int(round((t_end - t0) / dt))):
        if states is not None and k in states:
            states[k] = model.get_state()
        start = t0 + k * dt
        o = model.advance(t0 + (k + 1) * dt, torque(start) if callable(torque) else torque)
        rows.append(dataclasses.astuple(o))
    return np.rec.fromrecords(rows, names=COLUMNS)


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Two runs' tables hold the same bits (stricter than ==: -0.0 differs from 0.0)."""
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def finite(out: np.ndarray) -> bool:
    """Every output of every row is a finite number."""
    return all(bool(np.all(np.isfinite(out[name]))) for name in out.dtype.names)
