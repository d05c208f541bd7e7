"""Loading a step into the step form: a `StepLoad` (fem/step_load.py) set as the form's inputs, its split
residual's, its rigid-wall contact set and its meshed-wall pairs.

The model loads each step through it, and the Newton solver holds it to rebuild a restored Jacobian at the
step it was assembled at; it refers to neither, so the solver the model owns never refers back to the model
(a reference cycle model -> solver -> model kept a dropped model's NGSolve objects until the garbage
collector's full pass: tests/test_fmu_memory.py).
"""

from __future__ import annotations

from dataclasses import replace

import ngsolve as ngs
import numpy as np

from .head import HeadBoundary
from .schemes import StepForm
from .space import StepInputs
from .step_load import StepLoad


class StepLoader:
    """Sets a step form's inputs to those of a step."""

    def __init__(self, inputs: StepInputs, form: StepForm, head: HeadBoundary):
        self._inputs, self._form, self._head = inputs, form, head

    def load(self, step: StepLoad) -> None:
        """The start state, size, torque load (computed here, once), contact set and the meshed wall's pairs."""
        inputs, form = self._inputs, self._form
        torque_load = inputs.torque_load_of(step.torque)
        inputs.set(step, torque_load)
        if form.split is not None:
            form.split.load(step.u0, step.v0, step.dt, torque_load)
        if form.active is not None and step.active is not None:  # both or neither (FemModel.load_step)
            self._activate(form.active, step.active)
        form.update_wall_pairs(inputs.u0)

    def _activate(self, bits: ngs.BitArray, elements: np.ndarray) -> None:
        """The rigid-wall contact set: the form's BitArray and the split residual's compiled term."""
        self._head.activate(bits, elements)
        if self._form.split is not None:
            self._form.split.contact_set(elements)

    def covering(self, step: StepLoad, u1: np.ndarray) -> StepLoad | None:
        """None if the rigid-wall contact set of the loaded `step` holds every head point inside the block
        at the end displacement u1; else `step` with the set widened to them, that set loaded (the
        other inputs stay as loaded)."""
        bits = self._form.active
        if bits is None or step.active is None:
            return None
        wider = self._head.widened_contact_set(u1)
        if wider is None:
            return None
        self._activate(bits, wider)
        return replace(step, active=wider)
