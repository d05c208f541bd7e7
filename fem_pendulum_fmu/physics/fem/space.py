"""The FE model's discretisation of a scene (mesh, spaces, the bodies on it, evaluation fields), the
step forms' inputs on it, and the model's state.

Everything else of the FE model (the step forms of fem/schemes.py, the head
sampling of fem/head.py, the outputs of fem/outputs.py) is built on one
`FemSpace`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from ngsolve import CF, CoefficientFunction, FESpace, GridFunction, Mesh, NumberSpace, Parameter, VectorH1, x, y

from ..fe_boundary import hinge_torque_load
from ..geometry import make_mesh
from ..protocol import ModelState, Outputs, check_state_fidelity, model_state
from ..scene import Material, Scene
from .start_iterate import GuessErrors
from .step_load import JacobianPoint, StepLoad

FIDELITY = "fem"
DEFORMABLE_WALL_FACE_SIZE = 0.005  # m; contact zone on the wall face is ~5 mm wide


@dataclass
class FemState:
    """Displacement, velocity (numpy copies) and the energy bookkeeping of one instant."""

    u: np.ndarray
    v: np.ndarray
    hinge_multipliers: np.ndarray  # the hinge constraint's Lagrange multipliers (a state's "lam")
    torque_work: float
    a: np.ndarray | None = None  # acceleration, carried by the Newmark schemes only
    drift: np.ndarray | None = None  # the mean velocity (u1 - u0) / dt of the energy-momentum step that led here
    guess_errors: GuessErrors | None = None  # the misses of the start iterates before (fem/start_iterate.py)
    energies: tuple[float, float, float, float] | None = None  # kinetic, potential, strain, contact (FemOutputs)

    def to_model_state(self, time: float, outputs: Outputs, held_jacobian: JacobianPoint | None) -> ModelState:
        """The model's state at this instant: its arrays (copies), the held Jacobian's point, and the
        advance summary of `outputs` (protocol.model_state)."""
        scalars = {"torque_work": self.torque_work}
        arrays = {"u": self.u.copy(), "v": self.v.copy(), "lam": self.hinge_multipliers.copy()}
        if self.a is not None:
            arrays["a"] = self.a.copy()
        if self.drift is not None:
            arrays["drift"] = self.drift.copy()
        if self.guess_errors is not None:
            guess_scalars, guess_arrays = self.guess_errors.to_entries()
            scalars.update(guess_scalars)
            arrays.update(guess_arrays)
        if held_jacobian is not None:
            jac_scalars, jac_arrays = held_jacobian.to_entries()
            scalars.update(jac_scalars)
            arrays.update(jac_arrays)
        return model_state(FIDELITY, time, outputs, scalars, arrays)

    @classmethod
    def from_model_state(
        cls, state: ModelState, n_displacements: int, carries_acceleration: bool
    ) -> tuple[FemState, JacobianPoint | None]:
        """Inverse of to_model_state (the arrays copied), for a model of n_displacements displacement dofs
        whose scheme carries the acceleration or not; ValueError for a state that does not fit it."""
        check_state_fidelity(state, FIDELITY)
        arr, sc = state.arrays, state.scalars
        shape = arr.get("u", np.empty(0)).shape
        if shape != (n_displacements,):
            raise ValueError(
                f"fem state with displacements of shape {shape} does not fit this fem model "
                f"({n_displacements} displacement dofs)"
            )
        if carries_acceleration != ("a" in arr):
            raise ValueError("state of another time integration scheme (solver.scheme) than this fem model's")
        fem_state = cls(
            arr["u"].copy(),
            arr["v"].copy(),
            arr["lam"].copy(),
            sc["torque_work"],
            arr["a"].copy() if carries_acceleration else None,
            drift=arr["drift"].copy() if "drift" in arr else None,
            guess_errors=GuessErrors.from_entries(sc, arr, n_displacements),
        )
        return fem_state, JacobianPoint.from_entries(sc, arr) if "jac_w" in arr else None


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


@dataclass
class StepInputs:
    """What a step form reads besides its unknowns: the start state, the step size and the torque load
    (ngsolve fields and parameters on the space, set from a StepLoad by fem/step_loader.py)."""

    u0: GridFunction
    v0: GridFunction
    a0: GridFunction  # start acceleration: read by the Newmark form only
    dt: Parameter
    torque_load: Parameter  # the torque times torque_scale
    torque_weight: CoefficientFunction  # the hinge edge's load weight x / w (coefficient function)
    torque_scale: float  # 1 / moment of the unit-weight load
    _u0_v0: tuple[np.ndarray, np.ndarray] | None = field(default=None, init=False, repr=False, compare=False)

    def torque_load_of(self, torque: float) -> float:
        """The torque (N.m) as the forms take it: the factor on the unit-weight load (the one place it is scaled)."""
        return torque * self.torque_scale

    @property
    def unit_torque_weight(self) -> CoefficientFunction:
        """The hinge edge's load weight of a unit torque (1 N.m), torque_scale x / w."""
        return self.torque_scale * self.torque_weight

    def _views(self) -> tuple[np.ndarray, np.ndarray]:
        """numpy views of u0's and v0's vectors, made once (two views cost 8 us a step; the vectors stay put)."""
        if self._u0_v0 is None:
            self._u0_v0 = (self.u0.vec.FV().NumPy(), self.v0.vec.FV().NumPy())
        return self._u0_v0

    def set(self, load: StepLoad, torque_load: float) -> None:
        """Set the inputs to a step's, its torque as torque_load_of gives it."""
        self.dt.Set(load.dt)
        self.torque_load.Set(torque_load)
        u0, v0 = self._views()
        u0[:] = load.u0
        v0[:] = load.v0
        if load.a0 is not None:
            self.a0.vec.FV().NumPy()[:] = load.a0


def step_inputs(space: FemSpace) -> StepInputs:
    weight, scale = hinge_torque_load(space.mesh, space.scene.geometry)
    V = space.V
    return StepInputs(GridFunction(V), GridFunction(V), GridFunction(V), Parameter(1e-3), Parameter(0.0), weight, scale)
