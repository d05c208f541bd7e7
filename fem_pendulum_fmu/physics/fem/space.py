"""The FE model's discretisation of a scene (mesh, spaces, the bodies on it, evaluation fields) and its state.

Everything else of the FE model (the step forms of fem/schemes.py, the head
sampling of fem/head.py, the outputs of fem/outputs.py) is built on one
`FemSpace`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from ngsolve import CF, CoefficientFunction, FESpace, GridFunction, Mesh, NumberSpace, VectorH1, x, y

from ..geometry import make_mesh
from ..scene import Material, Scene

DEFORMABLE_WALL_FACE_SIZE = 0.005  # m; contact zone on the wall face is ~5 mm wide


@dataclass
class FemState:
    """Displacement, velocity (numpy copies) and the energy bookkeeping of one instant."""

    u: np.ndarray
    v: np.ndarray
    lam: np.ndarray  # the hinge multipliers
    torque_work: float
    a: np.ndarray | None = None  # acceleration, carried by the Newmark schemes only
    drift: np.ndarray | None = None  # the mean velocity (u1 - u0) / dt of the energy-momentum step that led here
    energy: tuple[float, float] | None = None  # (total, in motion), computed when the energy guard asks


@dataclass
class FemSpace:
    """The mesh and spaces of the FE model, and what every part of it needs to know about them."""

    scene: Scene
    mesh: Mesh  # ngsolve Mesh: the pendulum, and the wall block when it is meshed
    V: FESpace  # VectorH1 displacement space (the wall's outer edges clamped when meshed)
    X: FESpace  # V x the two hinge multipliers: the space of the step's unknowns
    bodies: list[tuple[str, Material]]  # (region, material); the meshed wall is a plate of the pendulum's thickness
    deformable_wall: bool
    contact_on: bool  # penalty contact with the rigid (analytic) wall block
    contact_order: int  # integration order on the head boundary (contact forms, energies and gap points)
    pos: CoefficientFunction  # the coefficient function (x, y)
    gf_u: GridFunction  # evaluation fields: a state's u and v are loaded here to evaluate outputs and head points
    gf_v: GridFunction

    @property
    def nV(self) -> int:
        """Number of displacement unknowns."""
        return self.V.ndof

    @property
    def wall_contact_on(self) -> bool:
        """Contact with the meshed (deformable) wall block."""
        return self.deformable_wall and self.scene.contact.stiffness > 0


def fem_space(scene: Scene, refine_like_seed: bool = False) -> FemSpace:
    """Mesh the scene (the wall block too when wall.kind is deformable) and set up the spaces."""
    order = scene.model.order
    deformable = scene.wall.kind == "deformable"
    mesh = make_mesh(
        scene.geometry,
        scene.model.mesh_size,
        order,
        block=scene.block if deformable else None,
        wall_face_size=DEFORMABLE_WALL_FACE_SIZE,
        refine_like_seed=refine_like_seed,
    )
    V = VectorH1(mesh, order=order, dirichlet="wall_fixed" if deformable else "")
    Q = NumberSpace(mesh, definedon=mesh.Boundaries("hinge"))
    bodies = [("pendulum", scene.pendulum)]
    if deformable:
        bodies.append(("wall", replace(scene.pendulum, E=scene.wall.E, nu=scene.wall.nu, rho=scene.wall.rho)))
    return FemSpace(
        scene=scene,
        mesh=mesh,
        V=V,
        X=V * Q * Q,
        bodies=bodies,
        deformable_wall=deformable,
        contact_on=scene.wall.kind == "rigid" and scene.contact.stiffness > 0,
        contact_order=2 * order + 40,
        pos=CF((x, y)),
        gf_u=GridFunction(V),
        gf_v=GridFunction(V),
    )
