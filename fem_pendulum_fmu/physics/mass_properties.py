"""Mass, centre of mass and moment of inertia of the pendulum body, and the energy of its swing.

Integrated over the very mesh geometry the FE model uses (geometry.make_mesh,
fine and highly curved), so the fidelities describe the same body; the rigid
model takes its inertia from here, and everything that needs "the swing
energy" (tests, benchmarks, the fidelity rule) takes it from `swing_energy`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import lru_cache

from .cache import load_or_build_json
from .geometry import make_mesh
from .scene import PendulumGeometry, Scene

# Mesh for the mass properties: converged to ~1e-10 relative (0.005/order 5 agrees to 1e-10).
MASS_MESH_SIZE = 0.004
MASS_MESH_ORDER = 6


@lru_cache(maxsize=16)
def geometry_moments(geo: PendulumGeometry) -> tuple[float, float, float]:
    """(area, first moment int y dA, polar moment int x^2 + y^2 dA) of the pendulum face (symmetric
    about x = 0 by construction). Times rho h these are the mass, m y_com and I about the pivot;
    they depend on the geometry only, so they are computed once per geometry and process."""

    def integrate() -> list[float]:
        from ngsolve import CF, Integrate, x, y  # only on a cache miss: a cached rigid model needs no ngsolve

        mesh = make_mesh(geo, MASS_MESH_SIZE, MASS_MESH_ORDER)
        order = 2 * MASS_MESH_ORDER + 2
        return [
            float(Integrate(CF(1.0), mesh, order=order)),
            float(Integrate(y, mesh, order=order)),
            float(Integrate(x * x + y * y, mesh, order=order)),
        ]

    key = {"geometry": asdict(geo), "mesh_size": MASS_MESH_SIZE, "order": MASS_MESH_ORDER}
    return tuple(load_or_build_json("moments", key, integrate))


@dataclass(frozen=True)
class MassProperties:
    """Of the pendulum body (SI units): mass m, depth d of the centre of mass below the pivot,
    moment of inertia I about the pivot."""

    total_mass: float
    com_depth: float
    inertia: float


def mass_properties(scene: Scene) -> MassProperties:
    """The scene's pendulum: its geometry's moments times rho h."""
    area, first_moment, polar = geometry_moments(scene.geometry)
    rho_h = scene.pendulum.rho * scene.pendulum.thickness
    return MassProperties(total_mass=rho_h * area, com_depth=-first_moment / area, inertia=rho_h * polar)


def gravity_moment(scene: Scene) -> float:
    """m g d: the largest gravity moment about the pivot (N m)."""
    body = mass_properties(scene)
    return body.total_mass * scene.gravity * body.com_depth


def swing_energy(scene: Scene, theta: float | None = None) -> float:
    """m g d (1 - cos theta): the gravity energy a swing released at rest at angle theta (default the
    scene's theta0) turns into motion at the bottom (J). The scale energy errors are measured against.

    Parameters
    ----------
    scene : the scene whose pendulum swings.
    theta : release angle (rad); scene.theta0 when None.
    """
    return gravity_moment(scene) * (1.0 - math.cos(scene.theta0 if theta is None else theta))
