"""Scene parameters: geometry, materials, wall, contact, model and solver settings.

Plain frozen dataclasses, one per group, so that a parameter's FMI name
("pendulum.E", "solver.max_step") is the attribute path into a `Scene`.
`problems` lists every out-of-range value, naming the parameter, its value and
what is allowed; `validate` raises one ValueError that lists them all.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

from .names import RenamedKeys, dotted_keywords, warn_renamed

WallKind = Literal["rigid", "deformable", "none"]
Fidelity = Literal["auto", "rigid", "reduced", "fem"]
Scheme = Literal["energy_momentum", "newmark_fixed", "newmark_gap_rule"]  # the Newmark ones: the seed's, for benchmarks
WALL_KINDS: tuple[WallKind, ...] = get_args(WallKind)
FIDELITIES: tuple[Fidelity, ...] = get_args(Fidelity)
SCHEMES: tuple[Scheme, ...] = get_args(Scheme)


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


# E / rho (m^2/s^2) at or under which a body is soft: it strains by tens of per cent where a stiff one
# strains by 1e-6 (rubber 1e3, steel 2.7e7); the FE model's element order, discrete gradient and energy
# guard and the reduced model's strain energy follow it
SOFT_LIMIT = 1e5


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

    @property
    def soft(self) -> bool:
        """E / rho <= SOFT_LIMIT."""
        return self.E / self.rho <= SOFT_LIMIT


@dataclass(frozen=True)
class Wall:
    kind: WallKind = "rigid"
    E: float = 2.1e11
    nu: float = 0.3
    rho: float = 7850.0


@dataclass(frozen=True)
class Contact:
    stiffness: float = 2e12  # penalty k in Pa/m: pressure = k * penetration


@dataclass(frozen=True)
class ModelSettings:
    fidelity: Fidelity = "fem"
    mesh_size: float = 0.03
    order: int = 0  # AUTO_ORDER: element_order() picks it
    compute_stress: bool = False
    threads: int = 1  # NGSolve TaskManager threads; 1 keeps results bit-identical
    modes: int = 6  # elastic modes of the reduced fidelity


@dataclass(frozen=True)
class SolverSettings:
    max_step: float = 2e-3  # largest internal step in free flight, s
    tolerance: float = 1e-3  # accuracy target of step control (see stepping.py)
    max_substeps: int = 0  # internal steps allowed per doStep (advance); 0 = no limit
    scheme: Scheme = "energy_momentum"  # fem only: or the seed's Newmark schemes (fem/seed_stepping.py)


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

    def with_values(self, values: Mapping[str, Any]) -> Scene:
        """A copy with some parameters changed (the scene is frozen: a copy is the way to change it).

        Parameters
        ----------
        values : mapping
            Parameter values by their FMU names, e.g. ``{"pendulum.E": 1e6, "model.fidelity": "rigid"}``.

        Returns
        -------
        Scene
            Not validated: `problems`, `validate` or `create` check it.

        Raises
        ------
        KeyError
            A name that is not a parameter.
        """
        return replace_path(self, values)


AUTO_ORDER = 0
SOFT_ORDER, STIFF_ORDER = 3, 2


def element_order(scene: Scene) -> int:
    """model.order, or for 0 (auto) the order the pendulum's material needs: order 2 puts a rubber
    pendulum's gap 3 mm off through an impact, order 3 within 1 mm (benchmarks/mesh_study.py --preset compliant);
    for steel order 2 is within 0.5 % of order 3 at a third of the cost."""
    if scene.model.order != AUTO_ORDER:
        return scene.model.order
    return SOFT_ORDER if scene.pendulum.soft else STIFF_ORDER


def steel(**values: Any) -> Scene:
    """The steel pendulum (the default scene), with `values` changed.

    Parameters
    ----------
    **values
        Parameters by their FMU names, each '.' written '_' (``pendulum_E=1e9``, ``model_fidelity="rigid"``).

    Returns
    -------
    Scene
        Not validated: `validate` or `create` refuses a bad value.

    Raises
    ------
    KeyError
        A keyword that names no parameter.
    """
    return _preset(Scene(), values)


def rubber(**values: Any) -> Scene:
    """The rubber pendulum: E 1 MPa, nu 0.45, rho 1000, k 5e9 Pa/m, with `values` changed (as `steel`).

    model.order auto (element_order) gives it order-3 elements: the coarsest discretisation whose angle
    and gap stay within 0.5 degree and 1 mm of a fine reference through an impact
    (benchmarks/mesh_study.py --preset rubber)."""
    return _preset(_rubber(), values)


def _rubber() -> Scene:
    return Scene(pendulum=Material(E=1e6, nu=0.45, rho=1000.0), contact=Contact(stiffness=5e9))


def _preset(base: Scene, values: Mapping[str, Any]) -> Scene:
    """`base` with keyword values (names.dotted_keywords; its warning points at the preset's caller)."""
    return base.with_values(dotted_keywords(values, scene_names(), stacklevel=4))


def stiff(**values: Any) -> Scene:
    """Deprecated name of `steel`."""
    warn_renamed("stiff", "steel", "the preset")
    return _preset(Scene(), values)


def compliant(**values: Any) -> Scene:
    """Deprecated name of `rubber`."""
    warn_renamed("compliant", "rubber", "the preset")
    return _preset(_rubber(), values)


class _Presets(RenamedKeys):
    """PRESETS: preset name -> function; the old names still index it (with a DeprecationWarning)."""

    old_names = {"stiff": "steel", "compliant": "rubber"}
    what = "the preset"


PRESETS = _Presets(steel=steel, rubber=rubber)
"""The scenes by the name the command lines and benchmarks give them."""


@functools.lru_cache(maxsize=1)
def scene_names() -> tuple[str, ...]:
    """Every parameter's dotted name, the Scene's attribute path ("theta0", "pendulum.E", "geometry.head_radius")."""
    names: list[str] = []
    for name, value in vars(Scene()).items():
        fields = dataclasses.fields(value) if dataclasses.is_dataclass(value) else ()
        names.extend([f"{name}.{f.name}" for f in fields] or [name])
    return tuple(names)


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
    "model.mesh_size": (0.0, 0.1, False, True),  # the lower limit is the memory estimate below
    "solver.max_step": (1e-7, 0.1, True, True),
    "solver.tolerance": (1e-8, 0.1, True, True),
}
_INT_RANGES = {
    "model.threads": (1, 64),
    "model.modes": (1, 200),
    "solver.max_substeps": (0, 10**9),
}
_CHOICES: dict[str, tuple[str, ...]] = {"wall.kind": WALL_KINDS, "model.fidelity": FIDELITIES, "solver.scheme": SCHEMES}


def _interval(lo: float, hi: float, lo_in: bool, hi_in: bool) -> str:
    return f"{'[' if lo_in else '('}{lo:g}, {hi:g}{']' if hi_in else ')'}"


def validate(scene: Scene) -> Scene:
    """The scene every model is built from, once its parameters are checked.

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    Scene
        `scene` with model.order 0 (auto) resolved to the order its material needs (`element_order`).

    Raises
    ------
    ValueError
        One error listing every bad parameter (`problems`), so that one try shows them all.
    """
    found = problems(scene)
    if found:
        raise ValueError("; ".join(found) if len(found) == 1 else f"{len(found)} bad parameters: " + "; ".join(found))
    return scene.with_values({"model.order": element_order(scene)})


def problems(scene: Scene) -> list[str]:
    """Every bad parameter of `scene`, without raising (for a user interface that lists them).

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    list of str
        One sentence per bad parameter naming it, its value and what is allowed; empty for a good scene.
        The memory estimate of the mesh is checked only once the rest is good (it needs their values).
    """
    found = _range_problems(scene) + _choice_problems(scene)
    if found:
        return found
    resolved = scene.with_values({"model.order": element_order(scene)})
    memory = _memory_problem(resolved)
    return [memory] if memory else []


def _range_problems(scene: Scene) -> list[str]:
    """The real and integer parameters outside their ranges."""
    found = []
    for name, (lo, hi, lo_in, hi_in) in _RANGES.items():
        value = get_path(scene, name)
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        if ok:
            ok = (value >= lo if lo_in else value > lo) and (value <= hi if hi_in else value < hi)
        if not ok:
            found.append(
                f"parameter {name} = {value!r} is not allowed: it must be a finite number in "
                f"{_interval(lo, hi, lo_in, hi_in)}"
            )
    for name, (ilo, ihi) in _INT_RANGES.items():
        value = get_path(scene, name)
        if isinstance(value, bool) or not isinstance(value, int) or not ilo <= value <= ihi:
            found.append(f"parameter {name} = {value!r} is not allowed: it must be an integer in [{ilo}, {ihi}]")
    # order 1 is refused: linear elements on the curved mesh lose the pendulum's angle (released at 0.349 rad,
    # theta is down to 0.04 rad within 20 ms)
    order = scene.model.order
    if isinstance(order, bool) or not isinstance(order, int) or not (order == AUTO_ORDER or 2 <= order <= 5):
        found.append(
            f"parameter model.order = {order!r} is not allowed: it must be an integer in [2, 5], "
            f"or {AUTO_ORDER} (auto: {SOFT_ORDER} for a soft pendulum, E / rho <= {SOFT_LIMIT:g} m^2/s^2, "
            f"else {STIFF_ORDER})"
        )
    return found


def _choice_problems(scene: Scene) -> list[str]:
    """The vocabularies, the flag and the combinations that are not allowed."""
    found = []
    for name, choices in _CHOICES.items():
        value = get_path(scene, name)
        if value not in choices:
            found.append(f"parameter {name} = {value!r} is not allowed: choose one of {', '.join(choices)}")
    if not isinstance(scene.model.compute_stress, bool):
        found.append(
            f"parameter model.compute_stress = {scene.model.compute_stress!r} is not allowed: it must be true or false"
        )
    if scene.solver.scheme != "energy_momentum" and scene.model.fidelity != "fem":
        found.append(
            f"parameter solver.scheme = {scene.solver.scheme!r} is an option of the fem fidelity only: "
            f"set model.fidelity = fem (it is {scene.model.fidelity!r}) or solver.scheme = energy_momentum"
        )
    return found


def _memory_problem(scene: Scene) -> str | None:
    """The mesh a meshed fidelity would not fit in this machine's memory (the rigid fidelity meshes
    nothing with these settings); None when it fits."""
    if scene.model.fidelity == "rigid":
        return None
    need, have = mesh_memory_estimate(scene), physical_memory()
    if need <= have:
        return None
    return (
        f"parameters model.mesh_size = {scene.model.mesh_size!r} with model.order = {scene.model.order} "
        f"would need about {need / 2**30:.3g} GiB (estimate), more than this machine's "
        f"{have / 2**30:.3g} GiB: model.mesh_size must be about {smallest_mesh_size(scene, have):.2g} m or more "
        "at this order"
    )


def refuse_deformable_wall(scene: Scene, fidelity: str) -> None:
    """Raise the ValueError of a fidelity that has no meshed wall (rigid, reduced) for wall.kind = deformable."""
    if scene.wall.kind == "deformable":
        raise ValueError(
            f"parameter wall.kind = 'deformable' is not available with model.fidelity = {fidelity!r}: "
            "choose rigid or none, or model.fidelity = 'fem'"
        )


# Memory of the FE model, measured (python benchmarks/robustness.py memory, docs/notes/robustness.md): peak
# resident size per unknown 5.4-8.3 kB for 5e3-1.2e5 unknowns at orders 2-5; the estimate takes
# (3 + order) kB per unknown, twice over, plus a fixed 64 MB.
_BYTES_PER_DOF_PER_ORDER = (3000.0, 1000.0)
_MEMORY_SAFETY = 2.0
_MEMORY_BASE = 64 * 2**20


def meshed_area(scene: Scene) -> float:
    """Area the FE mesh covers (m^2), slightly over-estimated: rod rectangle plus ring, plus the block when meshed."""
    g = scene.geometry
    area = 2.0 * g.rod_half_width * g.head_centre_depth + math.pi * (g.head_radius**2 - g.hole_radius**2)
    if scene.wall.kind == "deformable":
        b = scene.block
        area += (b.x_max - b.x_min) * (b.y_max - b.y_min)
    return area


def estimated_unknowns(scene: Scene, mesh_size: float | None = None) -> float:
    """Unknowns of the FE model: about 2.4 A / h^2 triangles with 1.1 order^2 vector unknowns each
    (within 25 % of netgen's counts from h = 0.0025 to 0.01 m)."""
    h = scene.model.mesh_size if mesh_size is None else mesh_size
    return 1.1 * scene.model.order**2 * 2.4 * meshed_area(scene) / (h * h)


def mesh_memory_estimate(scene: Scene, mesh_size: float | None = None) -> float:
    """Bytes the FE model would need (mesh, matrices, UMFPACK factors), a deliberate over-estimate."""
    per_dof = _BYTES_PER_DOF_PER_ORDER[0] + _BYTES_PER_DOF_PER_ORDER[1] * scene.model.order
    return _MEMORY_BASE + _MEMORY_SAFETY * per_dof * estimated_unknowns(scene, mesh_size)


def smallest_mesh_size(scene: Scene, memory: float) -> float:
    """The mesh size whose estimate just fits `memory` bytes."""
    per_unknown_h2 = mesh_memory_estimate(scene, 1.0) - _MEMORY_BASE
    return math.sqrt(per_unknown_h2 / max(memory - _MEMORY_BASE, 1.0))


def physical_memory() -> float:
    """This machine's physical memory in bytes (inf where the OS does not tell)."""
    import os

    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return math.inf
