"""An FMU state of the pendulum: what fmi2GetFMUstate keeps, its bytes, and whether an instance may take it.

The FMU's binary (shim/fmi2_states.c) holds the Python object between the
calls and frames the bytes in its own header (format, version, GUID, time);
the bytes here are its payload: an .npz of the head (torque and its
derivatives, parameter values, whether initialised, time) as JSON and the
model's own state bytes.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..physics.protocol import ModelState

_HEAD_KEYS = ("torque", "values", "initialised", "time")
_RATES_KEY = "torque_rates"  # absent from states of versions without input derivatives: none set


@dataclass(frozen=True)
class FmuState:
    """model: the model's state, None for a state taken before initialisation. values: the parameter
    values. time: the communication time, before initialisation the start time. torque_rates: the
    torque's first and second time derivative set for the next doStep."""

    model: ModelState | None
    torque: float
    values: dict[str, Any]
    initialised: bool
    time: float
    torque_rates: tuple[float, float] = (0.0, 0.0)

    def to_bytes(self) -> bytes:
        head = {"torque": self.torque, "values": self.values, "initialised": self.initialised, "time": self.time}
        head[_RATES_KEY] = list(self.torque_rates)
        model = self.model.to_bytes() if self.model is not None else b""
        buf = io.BytesIO()
        np.savez(
            buf,
            head=np.frombuffer(json.dumps(head).encode(), dtype=np.uint8),
            model=np.frombuffer(model, dtype=np.uint8),
        )
        return buf.getvalue()

    @staticmethod
    def from_bytes(data: bytes) -> FmuState:
        """The state `to_bytes` wrote; ValueError saying why the bytes are not one."""
        try:
            with np.load(io.BytesIO(bytes(data)), allow_pickle=False) as npz:
                head = json.loads(npz["head"].tobytes().decode())
                model = npz["model"].tobytes()
            state = ModelState.from_bytes(model) if model else None
        except Exception as exc:  # zipfile, json, numpy, ModelState: all mean foreign or corrupt bytes
            raise ValueError(
                f"the bytes are not a serialised state of this FMU ({type(exc).__name__}: {exc})"
            ) from None
        if not isinstance(head, dict) or set(head) - {_RATES_KEY} != set(_HEAD_KEYS):
            raise ValueError("its contents are not those of a state of this FMU")
        rates = head.get(_RATES_KEY, [0.0, 0.0])
        if (
            not isinstance(head["values"], dict)
            or not all(isinstance(head[k], (int, float)) for k in ("torque", "time"))
            or not (isinstance(rates, list) and len(rates) == 2 and all(isinstance(r, (int, float)) for r in rates))
        ):
            raise ValueError("its parameter values, torque, torque derivatives or time are malformed")
        return FmuState(
            state,
            float(head["torque"]),
            head["values"],
            bool(head["initialised"]),
            float(head["time"]),
            (float(rates[0]), float(rates[1])),
        )

    def mismatch(self, values: dict[str, Any], initialised: bool) -> str | None:
        """Why an instance with parameter `values`, initialised or not, cannot take this state, or None.
        An initialised instance takes only a state taken with its parameters; one not yet initialised
        any state of this FMU."""
        if set(self.values) != set(values):
            return "it is not a state of this FMU (its parameters have other names)"
        if not initialised:
            return None
        if self.model is None:
            return "it was taken before initialisation and this instance is initialised"
        for name, value in self.values.items():
            if values.get(name) != value:
                return f"it was taken with parameter {name} = {value!r}, this instance has {values.get(name)!r}"
        return None
