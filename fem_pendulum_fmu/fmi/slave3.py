"""The FMI 3.0 co-simulation slave: pythonfmu3's Fmi3Slave in front of the FMI 2.0 slave's logic.

The FMI 3.0 FMU's binary (shim/fmi3_*.c) calls the methods of pythonfmu3's Fmi3Slave interface
(get_float64, set_int64, do_step, ...). This class answers them with the FMI 2.0 slave it holds
(`PendulumSlave`, fmi/slave.py: variables, life cycle, FMU states, refusals), so both FMUs run the same
Python and the same models and give the same results. What FMI 3.0 adds lives here: the independent
variable `time`, the array output gap_profile (computed by physics/head_gaps.py), Enumerations read as
Int64, early return at contact onset and the intermediate update (the host's callback, reached through
the binary's fem_pendulum_intermediate_update), and the contact's onset and release reported as events.
No physics: the model stops where the slave's `stop` says so (physics/stepping.py). docs/reference/fmi3.md.
"""

from __future__ import annotations

from typing import Any

from pythonfmu3 import Fmi3Slave

from ..physics.head_gaps import head_boundary_gaps
from .fmi_logging import close_library, find_binary_function
from .fmi_names import FMI3_NAMES
from .model_description3 import ARRAY_OUTPUTS, array_references, time_reference
from .slave import PendulumSlave


class PendulumSlave3(Fmi3Slave):
    """The pendulum's FMI 3.0 slave: an FMI 2.0 `PendulumSlave` behind pythonfmu3's interface."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.inner = PendulumSlave(**kwargs)
        self.inner.fmi = FMI3_NAMES  # its messages name FMI 3.0's functions and statuses (fmi_names.py)
        self.author = self.inner.author
        self.description = self.inner.description
        self.log_queue = self.inner._get_log_queue()  # one queue: the binary forwards what either logs
        self.time_vr = time_reference()
        self.arrays = {vr: ARRAY_OUTPUTS[k] for k, vr in enumerate(array_references().values())}
        self._special = {self.time_vr, *self.arrays}  # the Float64 variables the FMI 2.0 slave does not have
        self.event_mode_used = self.early_return_allowed = self.has_callback = False
        self.event_handling_needed = False  # the last doStep saw the contact begin or end
        self.early_return = False  # the last doStep returned before its end
        # the binary's library handle and fem_pendulum_intermediate_update, looked up at the first intermediate update
        self._update: tuple[int, Any] | None = None
        self._looked = False

    def configure(self, event_mode_used: int, early_return_allowed: int, has_callback: int) -> None:
        """How the host instantiated the FMU (fmi3InstantiateCoSimulation's arguments; the binary calls this)."""
        self.event_mode_used = bool(event_mode_used)
        self.early_return_allowed = bool(early_return_allowed)
        self.has_callback = bool(has_callback)

    # -------------------------------------------------------------- life cycle
    def setup_experiment(
        self, start_time: float, stop_time: float | None = None, tolerance: float | None = None
    ) -> None:
        self.inner.setup_experiment(start_time, stop_time, tolerance)

    def enter_initialization_mode(self) -> None:
        self.inner.enter_initialization_mode()

    def exit_initialization_mode(self) -> None:
        self.inner.exit_initialization_mode()

    def enter_event_mode(self) -> None:
        pass  # the contact's change needs nothing done: fmi3UpdateDiscreteStates has no discrete state to update

    def update_discrete_states(self) -> None:
        self.event_handling_needed = False

    def enter_step_mode(self) -> None:
        self.event_handling_needed = False

    def terminate(self) -> None:
        self.inner.terminate()

    def release(self) -> None:
        self.inner.release()
        found, self._update, self._looked = self._update, None, False
        if found is not None:
            close_library(found[0])

    @property
    def communication_time(self) -> float:
        return self.inner.communication_time

    @property
    def cannot_continue(self) -> bool:
        return self.inner.cannot_continue

    # ------------------------------------------------------------------ doStep
    def do_step(self, current_time: float, step_size: float) -> bool:
        """The FMI 2.0 slave's doStep; stops early where `_stop` says so; flags the contact's change."""
        inner = self.inner
        before = inner.outputs
        in_contact = before is not None and before.contact_force > 0.0
        stop = self._stop if self.early_return_allowed or self.has_callback else None
        self.early_return = self.event_handling_needed = False
        done = inner.do_step(current_time, step_size, stop)
        after = inner.outputs
        if done and after is not None and inner.model is not None:
            self.early_return = inner.model.time < current_time + step_size
            in_contact_after = after.contact_force > 0.0
            onset = not in_contact and (in_contact_after or after.gap_min <= 0.0)  # an impact within the step too
            self.event_handling_needed = onset or (in_contact and not in_contact_after)
        return done

    def _stop(self, time: float, gap_before: float, gap_after: float) -> bool:
        """After an internal step at `time`: stop there? At contact onset when early return is allowed, and
        where the host's intermediate-update callback asks for it."""
        onset = self.early_return_allowed and gap_before > 0.0 >= gap_after
        if self.has_callback:
            if not self._looked:
                self._looked = True
                self._update = find_binary_function(self.resources, "fem_pendulum_intermediate_update")
            if self._update is not None and self._update[1](time, int(self.early_return_allowed)):
                return True
        return onset

    # ------------------------------------------------------ getters and setters
    def get_float64(self, vrs: list[int]) -> list[float]:
        """The template's Real variables through the FMI 2.0 slave; `time` and the arrays (flattened) here."""
        if not self._special.intersection(vrs):
            return self.inner.get_real(vrs)
        values: list[float] = []
        for vr in vrs:
            if vr == self.time_vr:
                values.append(self.communication_time)
            elif vr in self.arrays:
                values.extend(self._array(vr))
            else:
                values.extend(self.inner.get_real([vr]))
        return values

    def _array(self, vr: int) -> list[float]:
        """An array output's values (ARRAY_OUTPUTS: gap_profile, physics/head_gaps.py); zeros without a model,
        as the scalar outputs read then."""
        size = self.arrays[vr].size
        model = self.inner.output_model()
        return [0.0] * size if model is None else head_boundary_gaps(model).tolist()

    def set_float64(self, vrs: list[int], values: list[float]) -> None:
        self.inner.set_real(vrs, values)

    def get_int32(self, vrs: list[int]) -> list[int]:
        return self.inner.get_integer(vrs)

    def set_int32(self, vrs: list[int], values: list[int]) -> None:
        self.inner.set_integer(vrs, values)

    def get_int64(self, vrs: list[int]) -> list[int]:  # the Enumerations
        return self.inner.get_integer(vrs, enumeration=True)

    def set_int64(self, vrs: list[int], values: list[int]) -> None:
        self.inner.set_integer(vrs, values, enumeration=True)

    def get_boolean(self, vrs: list[int]) -> list[bool]:
        return self.inner.get_boolean(vrs)

    def set_boolean(self, vrs: list[int], values: list[bool]) -> None:
        self.inner.set_boolean(vrs, values)

    def get_string(self, vrs: list[int]) -> list[str]:
        return self.inner.get_string(vrs)

    def set_string(self, vrs: list[int], values: list[str]) -> None:
        self.inner.set_string(vrs, values)

    def get_output_derivatives(self, vrs: list[int], orders: list[int]) -> list[float]:
        """fmi3GetOutputDerivatives: the FMI 2.0 slave's output derivatives (docs/reference/fmi2.md)."""
        return self.inner.get_real_output_derivatives(vrs, orders)

    # ---------------------------------------------------------------- FMU state
    def _get_fmu_state(self) -> Any:
        return self.inner._get_fmu_state()

    def _set_fmu_state(self, state: Any) -> None:
        self.inner._set_fmu_state(state)

    def _fmu_state_to_bytes(self, state: Any) -> bytes:
        return self.inner._fmu_state_to_bytes(state)

    def _fmu_state_from_bytes(self, data: bytes) -> Any:
        return self.inner._fmu_state_from_bytes(data)
