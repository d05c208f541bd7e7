"""Fidelities behind one protocol; `create` picks the class for a scene."""

from __future__ import annotations

import importlib
import logging

from .protocol import ModelState, Outputs, PendulumModel, StepFailed
from .scene import AUTO_ORDER, Scene, element_order, validate
from .shared_state import SHARED_STATE

LOG = logging.getLogger("fem_pendulum_fmu")

AVAILABLE = ("rigid", "reduced", "fem")
MODEL_CLASSES = {"rigid": "RigidModel", "reduced": "ReducedModel", "fem": "FemModel"}


def resolve_fidelity(scene: Scene) -> str:
    """The fidelity that runs for a scene: the parameter, or for "auto" the rule of fidelity_rule.py (logged).
    The rule is imported only for "auto": its module imports SciPy for the reduced model's modes (and runs
    NGSolve), which a rigid scene would otherwise load for nothing (0.1-0.15 s of its start-up,
    docs/notes/latency.md)."""
    if scene.model.fidelity != "auto":
        return scene.model.fidelity
    from .fidelity_rule import choose

    choice = choose(scene)
    LOG.info("model.fidelity = auto picks %s: %s", choice.fidelity, choice.reason)
    return choice.fidelity


def create(scene: Scene) -> PendulumModel:
    """Validate the scene and build the model of the fidelity it asks for (model.fidelity).

    Parameters
    ----------
    scene : Scene
        The scene, e.g. ``steel()``, ``rubber(model_fidelity="rigid")`` or ``Scene().with_values({...})``.

    Returns
    -------
    PendulumModel
        At time 0, at theta0 turning at omega0: a RigidModel, ReducedModel or FemModel ("auto": the
        cheapest the scene needs, physics/fidelity_rule.py).

    Raises
    ------
    ValueError
        Every bad parameter of the scene at once (`problems`), or a wall the fidelity cannot model.

    Notes
    -----
    Built under shared_state.SHARED_STATE: one model is built at a time in a process (what each builds
    with netgen and NGSolve is theirs; stepping runs concurrently). The lock also covers the fidelities'
    modules, imported on first use here (a rigid scene loads no NGSolve): two threads importing two
    fidelities' trees at once can each wait for a module the other is importing, which Python breaks by
    handing one of them a module half imported.
    """
    with SHARED_STATE:
        if scene.model.order == AUTO_ORDER:
            LOG.info("model.order = %d (auto) picks %d for this material", AUTO_ORDER, element_order(scene))
        scene = validate(scene)
        fidelity = resolve_fidelity(scene)
        if fidelity not in AVAILABLE:
            raise ValueError(
                f"parameter model.fidelity = {fidelity!r} is not available: choose one of auto, {', '.join(AVAILABLE)}"
            )
        module = importlib.import_module(f"{__package__}.{fidelity}.model")
        return getattr(module, MODEL_CLASSES[fidelity])(scene)  # rigid and reduced refuse a deformable wall


__all__ = ["create", "resolve_fidelity", "ModelState", "Outputs", "PendulumModel", "StepFailed"]
