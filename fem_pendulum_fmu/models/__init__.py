"""Fidelities behind one protocol; `create` picks the class for a scene."""
from __future__ import annotations

from ..scene import Scene, validate
from .base import ModelState, Outputs, PendulumModel, StepFailed

AVAILABLE = ("rigid", "fem")


def resolve_fidelity(scene: Scene) -> str:
    """The fidelity that runs for a scene. "auto" runs the full FE model until the
    selection rule of issue 4 (rigid / reduced / fem by scene) is in place."""
    fidelity = scene.model.fidelity
    if fidelity == "auto":
        return "fem"
    return fidelity


def create(scene: Scene) -> PendulumModel:
    """Validate the scene and build the model it asks for."""
    validate(scene)
    fidelity = resolve_fidelity(scene)
    if fidelity not in AVAILABLE:
        raise ValueError(f"parameter model.fidelity = {fidelity!r} is not available yet: choose one of {', '.join(AVAILABLE)}")
    if fidelity == "rigid":
        if scene.wall.kind == "deformable":
            raise ValueError("parameter wall.kind = 'deformable' is not available with model.fidelity = 'rigid': choose rigid or none, or model.fidelity = 'fem'")
        from .rigid import RigidModel
        return RigidModel(scene)
    from .fem import FemModel
    return FemModel(scene)


__all__ = ["create", "resolve_fidelity", "ModelState", "Outputs", "PendulumModel", "StepFailed"]
