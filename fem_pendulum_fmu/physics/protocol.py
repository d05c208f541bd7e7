"""The one protocol every fidelity implements, and the plain data it exchanges.

The FMI slave and the masters only ever see `PendulumModel`, `Outputs` and
`ModelState`; which physics runs behind them is chosen by `fidelity.create`.
"""

from __future__ import annotations

import functools
import inspect
import io
import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from .names import OLD_OUTPUT_NAMES, RenamedKeys, warn_renamed
from .scene import Scene
from .torque import Torque, TorqueProfile


class StepFailed(RuntimeError):
    """The model could not complete an advance; its state is as it was before the call.

    Attributes
    ----------
    shorter_step_helps : bool
        True: an advance over a shorter interval from the same state can succeed (the internal steps an
        advance may take ran out, solver.max_substeps). False: the nonlinear solve failed down to the
        smallest internal step, where only another input or an earlier state can.
    """

    def __init__(self, message: str, shorter_step_helps: bool = False):
        super().__init__(message)
        self.shorter_step_helps = shorter_step_helps


NO_SHORTER_STEP = "a shorter communication step cannot help"
"""What the FMU says of a discarded step whose StepFailed.shorter_step_helps is False (fmi/slave.py); a
master that reads it does not advise a shorter step (masters/failures.py what_to_try)."""


@dataclass
class Outputs:
    """Everything a model reports after an advance (SI units).

    Each field is the FMU output of the same name, its '.' written '_' (physics/names.py):
    `energy_total` is the FMU's energy.total. The names before that rule (`total`, `min_gap`, ...)
    still read, with a DeprecationWarning."""

    time: float = 0.0
    theta: float = 0.0
    omega: float = 0.0
    gap: float = 0.0
    contact_force: float = 0.0
    energy_kinetic: float = 0.0
    energy_potential: float = 0.0
    energy_strain: float = 0.0
    energy_contact: float = 0.0
    energy_total: float = 0.0
    energy_torque_work: float = 0.0
    stress_von_mises_max: float = 0.0
    solver_substeps: int = 0
    gap_min: float = math.nan  # smallest gap at the internal steps of the last advance; nan = not reported
    contact_force_max: float = 0.0  # largest contact force at the internal steps of the last advance (N)
    contact_impulse: float = 0.0  # |sum over those steps of the scheme's contact force times the step| (N.s)
    # the contact's hold at the end of the last advance (s): time in contact less time out of it since it
    # began, as the stepper counts it (stepping.py: a contact held longer than an impact takes larger steps)
    contact_hold: float = 0.0

    def as_dict(self) -> dict[str, float]:
        """Field name -> value; the old names still index it (with a DeprecationWarning)."""
        return RenamedKeys(asdict(self))


def _old_name(old: str, new: str) -> property:
    """A read-only property `old` that warns and reads the field `new`."""

    def read(self: Outputs) -> Any:
        warn_renamed(old, new, "Outputs field")
        return getattr(self, new)

    return property(read, doc=f"Deprecated name of `{new}`.")


def _accepting_old_keywords(init: Callable[..., None]) -> Callable[..., None]:
    """Outputs' __init__, taking the old field names as keywords too (with a DeprecationWarning)."""

    @functools.wraps(init)
    def __init__(self: Outputs, *args: Any, **values: Any) -> None:
        if values and not OLD_OUTPUT_NAMES.keys().isdisjoint(values):
            for old in OLD_OUTPUT_NAMES.keys() & values.keys():
                warn_renamed(old, OLD_OUTPUT_NAMES[old], "Outputs field")
                values[OLD_OUTPUT_NAMES[old]] = values.pop(old)
        init(self, *args, **values)

    return __init__


for _old, _new in OLD_OUTPUT_NAMES.items():
    setattr(Outputs, _old, _old_name(_old, _new))
del _old, _new
Outputs.__init__ = _accepting_old_keywords(Outputs.__init__)  # type: ignore[method-assign]

CONTINUOUS_OUTPUTS = (
    "theta",
    "omega",
    "gap",
    "contact_force",
    "energy_kinetic",
    "energy_potential",
    "energy_strain",
    "energy_contact",
    "energy_total",
    "energy_torque_work",
    "stress_von_mises_max",
)
"""The Outputs fields that are functions of the state at an instant, whose time derivatives exist."""

SUMMARY_OUTPUTS = {
    "solver_substeps": "it counts the internal steps of the last doStep",
    "gap_min": "it is the smallest gap over the internal steps of the last doStep",
    "contact_force_max": "it is the largest contact force over the internal steps of the last doStep",
    "contact_impulse": "it is the contact impulse over the whole last doStep",
    "contact_hold": "it is the contact's hold as the step control counts it",
}
"""The Outputs fields that summarise the last advance, and why they have no time derivative."""


@dataclass
class OutputDerivatives:
    """d/dt and d^2/dt^2 of the CONTINUOUS_OUTPUTS (Outputs field name -> value, SI units per s and s^2)
    at one instant."""

    time: float
    first: dict[str, float]
    second: dict[str, float]

    def __post_init__(self) -> None:
        # indexed by users with the field names, the old ones included (with a DeprecationWarning)
        self.first, self.second = RenamedKeys(self.first), RenamedKeys(self.second)

    def of(self, field_name: str, order: int) -> float:
        """The derivative of one output.

        Parameters
        ----------
        field_name : str
            An Outputs field of CONTINUOUS_OUTPUTS, e.g. "energy_total".
        order : int
            1 or 2.

        Returns
        -------
        float
            In the field's unit per s (order 1) or per s^2 (order 2).

        Raises
        ------
        KeyError
            A field without a time derivative (SUMMARY_OUTPUTS) or no field.
        """
        return (self.first if order == 1 else self.second)[field_name]


@dataclass
class BodyField:
    """Nodal fields of one body on the vertices of its mesh (SI units): what field output writes."""

    name: str  # "pendulum", or "wall" for the meshed wall
    points: np.ndarray  # (N, 2) reference positions of the vertices
    cells: np.ndarray  # (M, 3) vertex indices of the triangles
    displacement: np.ndarray  # (N, 2) the deformed position is points + displacement
    velocity: np.ndarray  # (N, 2)
    von_mises: np.ndarray  # (N,) plane-stress von Mises stress, averaged over the triangles at a vertex


@dataclass
class ModelState:
    """A model's complete state: scalars plus named numpy arrays (deep-copied on the way in and out)."""

    fidelity: str
    time: float
    scalars: dict[str, float] = field(default_factory=dict)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    def copy(self) -> ModelState:
        return ModelState(
            self.fidelity, self.time, dict(self.scalars), {k: np.array(v, copy=True) for k, v in self.arrays.items()}
        )

    def to_bytes(self) -> bytes:
        """Serialise, for an FMU state a master stores (fmi2SerializeFMUstate).

        Returns
        -------
        bytes
            A self-describing .npz (no pickle: loading it runs no code).
        """
        header = {
            "format": "fem_pendulum_fmu.state",
            "version": 1,
            "fidelity": self.fidelity,
            "time": self.time,
            "scalars": self.scalars,
        }
        buf = io.BytesIO()
        # Any: numpy's stub lets ** also fill savez's allow_pickle (bool), a keyword numpy < 2.1 does not have
        arrays: dict[str, Any] = {f"a_{k}": v for k, v in self.arrays.items()}
        np.savez(buf, __header__=np.frombuffer(json.dumps(header).encode(), dtype=np.uint8), **arrays)
        return buf.getvalue()

    @staticmethod
    def from_bytes(data: bytes) -> ModelState:
        """The state `to_bytes` serialised.

        Parameters
        ----------
        data : bytes

        Returns
        -------
        ModelState

        Raises
        ------
        ValueError
            Anything that is not such a state, or one of an unknown version.
        """
        try:
            with np.load(io.BytesIO(bytes(data)), allow_pickle=False) as npz:
                header = json.loads(npz["__header__"].tobytes().decode())
                arrays = {k[2:]: np.array(npz[k]) for k in npz.files if k.startswith("a_")}
        except Exception as exc:  # zipfile, json, key errors: all mean corrupt bytes
            raise ValueError(f"not a serialised model state ({type(exc).__name__}: {exc})") from None
        if header.get("format") != "fem_pendulum_fmu.state" or header.get("version") != 1:
            raise ValueError(f"not a serialised model state of a known version: header {header!r}")
        return ModelState(
            str(header["fidelity"]), float(header["time"]), {k: float(v) for k, v in header["scalars"].items()}, arrays
        )


# asked after each internal step of an advance: (the step's end time, gap before, gap after) -> stop there?
StopAt = Callable[[float, float, float], bool]


@runtime_checkable
class PendulumModel(Protocol):
    """What the slave and the masters need from any fidelity (`create` builds one).

    Attributes
    ----------
    scene : Scene
        The validated scene the model was built from.
    fidelity : str
        "rigid", "reduced" or "fem": the model that runs ("auto" is resolved by `create`).
    time : float
        The model time (s), the absolute time that `advance` integrates up to.
    """

    scene: Scene
    fidelity: str
    time: float

    def advance(self, t_end: float, torque: Torque = 0.0, stop: StopAt | None = None) -> Outputs:
        """Integrate from the current time to the absolute time `t_end`.

        Parameters
        ----------
        t_end : float
            The time to reach (s): absolute, as an FMU's doStep reaches t + h, so that a sequence of
            advances never accumulates round-off in the model's time; it must lie after `time`.
        torque : float or TorqueProfile, default 0.0
            The drive torque at the hinge (N.m, counter-clockwise positive): a float is held constant
            over the advance; a TorqueProfile is a polynomial in the time since the advance's start
            (FMI input interpolation, physics/torque.py).
        stop : callable, optional
            Asked after every internal step with (its end time, the gap before it, the gap after it);
            the advance ends there when it answers True (an event an FMI 3.0 master stops at) and the
            model's time is then that step's end.

        Returns
        -------
        Outputs
            The outputs at the new time, with the summary of this advance (solver_substeps, gap_min,
            contact_force_max, contact_impulse).

        Raises
        ------
        StepFailed
            The advance cannot be completed; the state is as before the call, so that a master can
            retry (a shorter interval helps when `StepFailed.shorter_step_helps`).
        ValueError
            `t_end` not after `time`, or a torque that is not finite; the state is unchanged.
        """

    def output_derivatives(self, torque: TorqueProfile) -> OutputDerivatives:
        """The first and second time derivatives of the continuous outputs at the current state, for a
        master that extrapolates them over its next step (physics/output_rates.py).

        Parameters
        ----------
        torque : TorqueProfile
            The torque from now on: the derivatives depend on it through the acceleration.

        Returns
        -------
        OutputDerivatives
            The derivatives of each of CONTINUOUS_OUTPUTS; the state is unchanged.

        Raises
        ------
        StepFailed
            A fidelity that probes by advancing could not (its state is restored).
        """

    def outputs(self) -> Outputs:
        """The outputs at the current time, as the last advance (or the start) left them.

        Returns
        -------
        Outputs
            The object the last advance returned (each advance returns a new one).
        """

    def get_state(self) -> ModelState:
        """The full state, for a rollback (`set_state`) or for serialising (`ModelState.to_bytes`).

        Returns
        -------
        ModelState
            A deep copy: later advances do not change it.
        """

    def set_state(self, state: ModelState) -> None:
        """Restore a state taken with `get_state`; the next advance continues bit for bit as after it.

        Parameters
        ----------
        state : ModelState
            Taken from a model of the same fidelity built from the same scene.

        Raises
        ------
        ValueError
            A state of another fidelity, or one whose arrays do not fit this model.
        """

    def fields(self) -> list[BodyField]:
        """The nodal fields of the current state, for field output (ParaView).

        Returns
        -------
        list of BodyField
            The pendulum first, then the meshed wall if there is one.
        """


def protocol_doc(method: Callable[..., Any]) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """A decorator that gives a fidelity's method the protocol method's docstring, its own (what this
    fidelity does) as the Notes: help(model.advance) then says what every model's advance takes."""

    def decorate(implementation: Callable[..., Any]) -> Callable[..., Any]:
        own = inspect.cleandoc(implementation.__doc__ or "")
        notes = f"\n\nNotes\n-----\n{own}" if own else ""
        implementation.__doc__ = inspect.cleandoc(method.__doc__ or "") + notes
        return implementation

    return decorate


def check_advance_args(time: float, t_end: float, torque: Torque) -> None:
    """Shared argument check for advance(): a ValueError naming the bad value (math, not numpy:
    it runs at every doStep, and numpy's scalar calls cost microseconds)."""
    if isinstance(torque, TorqueProfile):
        problems = torque.problems()
        if problems:
            raise ValueError("; ".join(problems))
    elif not math.isfinite(torque):
        raise ValueError(f"torque = {torque!r} is not allowed: it must be a finite number (N.m)")
    if not math.isfinite(t_end) or t_end <= time:
        raise ValueError(f"t_end = {t_end!r} is not allowed: it must be a finite time after the current time {time!r}")


ADVANCE_SUMMARY_KEYS = {
    "solver_substeps": "substeps",
    "gap_min": "last_min_gap",
    "contact_force_max": "last_contact_force_max",
    "contact_impulse": "last_contact_impulse",
    "contact_hold": "last_contact_hold",
}
"""The outputs that describe the last advance rather than the state, and the ModelState scalars that
carry them (the state's keys are those of the states serialised before the outputs' renaming, so
that they still restore). Every fidelity's state has them (written once, by `model_state`), and
`restore_advance_summary` puts them back, so a restored model reports what the original did;
contact_hold also steers the next advance's steps, so a restored state steps exactly as the original."""


def model_state(
    fidelity: str, time: float, outputs: Outputs, scalars: dict[str, float], arrays: dict[str, np.ndarray]
) -> ModelState:
    """A ModelState of a fidelity's own scalars and arrays plus the advance summary of `outputs`."""
    summary = {key: float(getattr(outputs, name)) for name, key in ADVANCE_SUMMARY_KEYS.items()}
    return ModelState(fidelity, float(time), {**scalars, **summary}, arrays)


def restore_advance_summary(state: ModelState, outputs: Outputs) -> Outputs:
    """Set the advance summary of `outputs`, computed afresh from a restored state, to the one `state`
    was taken with (a state without it: no steps, the gap as gap_min, no contact)."""
    sc = state.scalars
    outputs.solver_substeps = int(sc.get("substeps", 0))
    outputs.gap_min = float(sc.get("last_min_gap", outputs.gap))
    for name in ("contact_force_max", "contact_impulse", "contact_hold"):
        setattr(outputs, name, float(sc.get(ADVANCE_SUMMARY_KEYS[name], 0.0)))
    return outputs


def check_state_fidelity(state: ModelState, fidelity: str) -> None:
    """ValueError unless `state` was taken from a model of `fidelity` at a finite time."""
    if state.fidelity != fidelity:
        raise ValueError(f"state of fidelity {state.fidelity!r} does not fit a {fidelity} model")
    if not math.isfinite(state.time):
        raise ValueError(f"{fidelity} model state has the non-finite time {state.time!r}")
