"""Scene parameters: geometry, materials, wall, contact, model and solver settings.

Plain frozen dataclasses, one per group, so that a parameter's FMI name
("pendulum.E", "solver.max_step") is the attribute path into a `Scene`.
`validate` rejects every out-of-range value with a ValueError that names the
parameter, its value and what is allowed.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

WALL_KINDS = ("rigid", "deformable", "none")
FIDELITIES = ("auto", "rigid", "reduced", "fem")


@dataclass(frozen=True)
class PendulumGeometry:
    """The seed's pendulum: a rod hanging from the pivot (0, 0) and a ring head."""

    rod_half_width: float = 0.015
    head_centre_depth: float = 0.24
    head_radius: float = 0.06
    hole_radius: float = 0.03


@dataclass(frozen=True)
class WallBlock:
    """The wall block, an axis-aligned rectangle; its right face is the contact face."""

    x_min: float = -0.085
    x_max: float = -0.06
    y_min: float = -0.365
    y_max: float = -0.115


@dataclass(frozen=True)
class Material:
    E: float = 2.1e11
    nu: float = 0.3
    rho: float = 7850.0
    thickness: float = 0.01

    @property
    def lame(self) -> tuple[float, float]:
        """Plane-stress Lame parameters (lambda*, mu)."""
        return self.E * self.nu / (1.0 - self.nu**2), self.E / (2.0 * (1.0 + self.nu))


@dataclass(frozen=True)
class Wall:
    kind: str = "rigid"
    E: float = 2.1e11
    nu: float = 0.3
    rho: float = 7850.0


@dataclass(frozen=True)
class Contact:
    stiffness: float = 2e12  # penalty k in Pa/m: pressure = k * penetration


@dataclass(frozen=True)
class ModelSettings:
    fidelity: str = "fem"
    mesh_size: float = 0.03
    order: int = 2
    compute_stress: bool = False
    threads: int = 1  # NGSolve TaskManager threads; 1 keeps results bit-identical
    modes: int = 6  # elastic modes of the reduced fidelity


@dataclass(frozen=True)
class SolverSettings:
    max_step: float = 2e-3  # largest internal step in free flight, s
    tolerance: float = 1e-3  # accuracy target of step control (see stepping.py)


@dataclass(frozen=True)
class Scene:
    theta0: float = math.radians(20.0)
    omega0: float = 0.0
    gravity: float = 9.81
    pendulum: Material = field(default_factory=Material)
    wall: Wall = field(default_factory=Wall)
    contact: Contact = field(default_factory=Contact)
    model: ModelSettings = field(default_factory=ModelSettings)
    solver: SolverSettings = field(default_factory=SolverSettings)
    geometry: PendulumGeometry = field(default_factory=PendulumGeometry)
    block: WallBlock = field(default_factory=WallBlock)

    def with_values(self, values: Mapping[str, Any]) -> "Scene":
        """A copy with values given by dotted names, e.g. {"pendulum.E": 1e6}."""
        return replace_path(self, values)


def stiff(**values: Any) -> Scene:
    """Steel pendulum (the default scene)."""
    return Scene().with_values(_dotted(values))


def compliant(**values: Any) -> Scene:
    """Rubber-like pendulum: E 1 MPa, nu 0.45, rho 1000, k 5e9 Pa/m.

    Order-3 elements: the coarsest discretisation whose angle and gap stay
    within 0.5 degree and 1 mm of a fine reference through an impact
    (benchmarks/mesh_study.py --preset compliant, docs/fem.md)."""
    base = Scene(pendulum=Material(E=1e6, nu=0.45, rho=1000.0), contact=Contact(stiffness=5e9),
                 model=ModelSettings(order=3))
    return base.with_values(_dotted(values))


PRESETS = {"stiff": stiff, "compliant": compliant}


def _dotted(values: Mapping[str, Any]) -> dict[str, Any]:
    """Keyword form pendulum__E=... to dotted form pendulum.E=..."""
    return {k.replace("__", "."): v for k, v in values.items()}


def replace_path(scene: Scene, values: Mapping[str, Any]) -> Scene:
    """Return `scene` with the dotted-path values replaced (unknown names are a KeyError)."""
    groups: dict[str, dict[str, Any]] = {}
    top: dict[str, Any] = {}
    for name, value in values.items():
        head, _, tail = name.partition(".")
        if not hasattr(scene, head):
            raise KeyError(f"unknown scene parameter {name!r}")
        if tail:
            sub = getattr(scene, head)
            if not dataclasses.is_dataclass(sub) or tail not in {f.name for f in dataclasses.fields(sub)}:
                raise KeyError(f"unknown scene parameter {name!r}")
            groups.setdefault(head, {})[tail] = value
        else:
            top[head] = value
    for head, changes in groups.items():
        top[head] = dataclasses.replace(getattr(scene, head), **changes)
    return dataclasses.replace(scene, **top)


def get_path(scene: Scene, name: str) -> Any:
    obj: Any = scene
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


# name -> (low, high, low_inclusive, high_inclusive) for real-valued parameters
_RANGES: dict[str, tuple[float, float, bool, bool]] = {
    "theta0": (-math.pi, math.pi, True, True),
    "omega0": (-100.0, 100.0, True, True),
    "gravity": (0.0, 100.0, True, True),
    "pendulum.E": (0.0, math.inf, False, False),
    "pendulum.nu": (0.0, 0.5, True, False),
    "pendulum.rho": (0.0, math.inf, False, False),
    "pendulum.thickness": (0.0, math.inf, False, False),
    "wall.E": (0.0, math.inf, False, False),
    "wall.nu": (0.0, 0.5, True, False),
    "wall.rho": (0.0, math.inf, False, False),
    "contact.stiffness": (0.0, math.inf, True, False),
    "model.mesh_size": (0.002, 0.1, True, True),
    "solver.max_step": (1e-7, 0.1, True, True),
    "solver.tolerance": (1e-8, 0.1, True, True),
}
_INT_RANGES = {"model.order": (2, 5), "model.threads": (1, 64), "model.modes": (1, 40)}  # order 1: see docs/fem.md
_CHOICES = {"wall.kind": WALL_KINDS, "model.fidelity": FIDELITIES}


def _interval(lo: float, hi: float, lo_in: bool, hi_in: bool) -> str:
    return f"{'[' if lo_in else '('}{lo:g}, {hi:g}{']' if hi_in else ')'}"


def validate(scene: Scene) -> Scene:
    """Check every parameter; raise ValueError naming the first bad one. Returns the scene."""
    for name, (lo, hi, lo_in, hi_in) in _RANGES.items():
        value = get_path(scene, name)
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        if ok:
            ok = (value >= lo if lo_in else value > lo) and (value <= hi if hi_in else value < hi)
        if not ok:
            raise ValueError(
                f"parameter {name} = {value!r} is out of range: allowed is a finite number in "
                f"{_interval(lo, hi, lo_in, hi_in)}"
            )
    for name, (lo, hi) in _INT_RANGES.items():
        value = get_path(scene, name)
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise ValueError(f"parameter {name} = {value!r} is out of range: allowed is an integer in [{lo}, {hi}]")
    for name, choices in _CHOICES.items():
        value = get_path(scene, name)
        if value not in choices:
            raise ValueError(f"parameter {name} = {value!r} is not allowed: choose one of {', '.join(choices)}")
    if not isinstance(scene.model.compute_stress, bool):
        raise ValueError(f"parameter model.compute_stress = {scene.model.compute_stress!r}: allowed is true or false")
    return scene
