"""Elastic modes of the hinged pendulum, and the small tensors the reduced fidelity needs.

The pendulum's displacement in a frame rotating with it is written as
w(X) = sum_j phi_j(X) q_j. The basis: the lowest eigenmodes of the linearised
FE model (the same mesh, order, material and hinge condition as fem/model.py,
i.e. zero mean displacement of the hinge edge) and static corrections for the
loads the pendulum sees (contact patches on the head, the hinge torque), made
mass-orthonormal together by Rayleigh-Ritz. The rigid rotation about the pivot
is the zero-frequency mode and is left out; every basis vector is mass
orthogonal to it, so the frame's angle is exactly the FE model's best-fit
angle (the Tisserand frame).

Everything the time integration needs is reduced here, once, to plain numpy
data (`ModalBasis`) and cached on disk like the mesh: mass moments, the
gyroscopic coupling between modes, the gravity and torque participations and
the modes sampled on the head boundary where contact is evaluated.
"""

from __future__ import annotations

import io
import math
from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from ..scene import Scene, element_order
from ..sparse import scipy_matrix

if TYPE_CHECKING:
    from ngsolve import CoefficientFunction, FESpace, Mesh
    from scipy.sparse import csr_matrix

BASIS_VERSION = 7  # bump when the reduction changes: part of the cache key
HEAD_RULE_ORDER = 120  # Gauss points per head boundary element: 61, i.e. ~0.5 mm apart on the default mesh
CONTACT_PATCHES = 5  # static correction vectors for the head's contact zone (load_corrections)
LOAD_CORRECTIONS = CONTACT_PATCHES + 1  # and one for the hinge torque
PATCH_WIDTH = 0.01  # m
EIGEN_SHIFT = -1.0  # rad^2/s^2; shift-invert below the zero-frequency rotation


@dataclass(frozen=True)
class ModalBasis:
    """Mass-normalised elastic modes of the hinged pendulum, reduced to small arrays (SI units,
    all mass integrals include density and thickness)."""

    omega2: np.ndarray  # (m + LOAD_CORRECTIONS,) squared angular frequencies of the basis vectors
    eigen_omega2: np.ndarray  # (m,) squared angular eigenfrequencies of the eigenmodes among them
    inertia0: float  # int rho h |X|^2: moment of inertia about the pivot
    mass: float
    first_moment: np.ndarray  # (2,) int rho h X
    a: np.ndarray  # (m,) int rho h X . phi_j
    gyro: np.ndarray  # (m, m) int rho h phi_i x phi_j (antisymmetric)
    moment_modes: np.ndarray  # (2, m) int rho h phi_j
    tisserand: np.ndarray  # (m,) int rho h X x phi_j: zero up to round-off (checked)
    torque_modes: np.ndarray  # (m,) work of the unit hinge torque load on each mode
    head_X: np.ndarray  # (P, 2) reference positions of the head boundary sample points
    head_phi: np.ndarray  # (P, 2, m) the modes at those points
    head_weights: np.ndarray  # (P,) reference arc length belonging to each point
    phi: np.ndarray  # (ndof, m) the modes as FE coefficient vectors (for stress output)

    @property
    def count(self) -> int:
        return len(self.omega2)

    def to_bytes(self) -> bytes:
        buf = io.BytesIO()
        # Any: numpy's stub lets ** also fill savez's allow_pickle (bool), a keyword numpy < 2.1 does not have
        arrays: dict[str, Any] = {f.name: np.asarray(getattr(self, f.name)) for f in fields(self)}
        np.savez(buf, **arrays)
        return buf.getvalue()

    @staticmethod
    def from_bytes(data: bytes) -> ModalBasis:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            values: dict[str, Any] = {f.name: np.array(npz[f.name]) for f in fields(ModalBasis)}
        for name in ("inertia0", "mass"):
            values[name] = float(values[name])
        return ModalBasis(**values)


def modal_key(scene: Scene) -> dict:
    """What the modes depend on (the cache key)."""
    return {
        "geometry": asdict(scene.geometry),
        "pendulum": asdict(scene.pendulum),
        "mesh_size": scene.model.mesh_size,
        "order": element_order(scene),
        "modes": scene.model.modes,
        "head_rule": HEAD_RULE_ORDER,
        "patches": CONTACT_PATCHES,
        "patch_width": PATCH_WIDTH,
        "version": BASIS_VERSION,
    }


def modal_basis(scene: Scene) -> ModalBasis:
    """The scene's modal basis, from the disk cache or computed (a few seconds)."""
    from ..cache import load_or_build

    return ModalBasis.from_bytes(load_or_build("modes", modal_key(scene), lambda: compute_modes(scene).to_bytes()))


def first_elastic_frequency(scene: Scene) -> float:
    """Lowest elastic eigenfrequency (Hz) of the hinged pendulum on the scene's mesh (cached)."""
    from ..cache import load_or_build_json

    key = {k: v for k, v in modal_key(scene).items() if k not in ("modes", "head_rule")}

    def build() -> float:
        _, _, K, M, C = assemble(scene)
        omega2, _ = hinged_eigenmodes(K, M, C, 1)
        return float(math.sqrt(max(omega2[0], 0.0)) / (2.0 * math.pi))

    return float(load_or_build_json("first_frequency", key, build))


def assemble(scene: Scene) -> tuple[Mesh, FESpace, csr_matrix, csr_matrix, csr_matrix]:
    """(mesh, space, K, M, C) of the linearised pendulum: stiffness, mass and the hinge's
    mean-displacement rows, as scipy matrices."""
    import scipy.sparse as sp
    from ngsolve import BilinearForm, Grad, InnerProduct, LinearForm, Sym, Trace, ds, dx

    mat = scene.pendulum
    h, rho = mat.thickness, mat.rho
    lame_lambda, mu = mat.lame
    mesh, V = fe_space(scene)
    u, v = V.TnT()
    eps_u, eps_v = Sym(Grad(u)), Sym(Grad(v))
    energy = lame_lambda * Trace(eps_u) * Trace(eps_v) + 2.0 * mu * InnerProduct(eps_u, eps_v)
    stiffness = BilinearForm(h * energy * dx)
    mass_form = BilinearForm(rho * h * InnerProduct(u, v) * dx)
    K, M = scipy_matrix(stiffness.Assemble().mat), scipy_matrix(mass_form.Assemble().mat)
    C = sp.csr_matrix(np.array([LinearForm(v[i] * ds("hinge")).Assemble().vec.FV().NumPy() for i in range(2)]))
    return mesh, V, K, M, C


def hinged_eigenmodes(K: csr_matrix, M: csr_matrix, C: csr_matrix, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The `count` lowest elastic (omega^2, modes) with the hinge condition C u = 0; the rigid
    rotation about the pivot (omega = 0) is the lowest of all and left out."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla

    n = K.shape[0]
    K_aug = sp.bmat([[K, C.T], [C, None]], format="csc")
    M_aug = sp.bmat([[M, None], [None, sp.csr_matrix((C.shape[0], C.shape[0]))]], format="csc")
    values, vectors = sla.eigsh(K_aug, k=count + 1, M=M_aug, sigma=EIGEN_SHIFT, which="LM")
    order = np.argsort(values)[1:]
    return values[order], vectors[:n, order]


def fe_space(scene: Scene) -> tuple[Mesh, FESpace]:
    """(mesh, displacement space) of the pendulum alone, as the FE model discretises it."""
    from ngsolve import VectorH1

    from ..geometry import make_mesh

    order = element_order(scene)
    mesh = make_mesh(scene.geometry, scene.model.mesh_size, order)
    return mesh, VectorH1(mesh, order=order)


def load_corrections(
    scene: Scene, V: FESpace, K: csr_matrix, C: csr_matrix, l_rot: np.ndarray, l_torque: np.ndarray
) -> np.ndarray:
    """Static deflections of the hinged pendulum under the loads it sees: the hinge torque and
    pressure patches on the head's wall side.

    A penalty wall is far stiffer than a soft head, so an impact deforms the head locally and
    quasi-statically; eigenmodes need very many members to represent that (and converge
    erratically), static correction vectors represent it directly (modal truncation
    augmentation, as in Craig-Bampton). Patches: Gaussians of width PATCH_WIDTH centred on the
    head's outer circle at CONTACT_PATCHES positions around its point facing the wall. Each
    deflection has zero mean hinge displacement and no best-fit rotation (l_rot . s = 0): the
    moment of a load is carried by the rotation's inertia (inertia relief). The torque's
    deflection is the rod bending under a pivot torque, large for rubber (20 % strain at 0.3 N.m)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla
    from ngsolve import InnerProduct, LinearForm, ds, exp, specialcf, x, y

    geo = scene.geometry
    v = V.TestFunction()
    N = specialcf.normal(2)
    B = sp.vstack([C, sp.csr_matrix(l_rot[None, :])])
    solver = sla.splu(sp.bmat([[K, B.T], [B, None]], format="csc"))
    n = K.shape[0]

    def static(load: np.ndarray) -> np.ndarray:
        return solver.solve(np.concatenate([load, np.zeros(B.shape[0])]))[:n]

    columns = [static(l_torque)]
    half = (CONTACT_PATCHES - 1) / 2.0
    for k in range(CONTACT_PATCHES):
        angle = np.pi + (k - half) * PATCH_WIDTH / geo.head_radius
        cx = geo.head_radius * np.cos(angle)
        cy = -geo.head_centre_depth + geo.head_radius * np.sin(angle)
        weight = exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (PATCH_WIDTH * PATCH_WIDTH))
        load = LinearForm(-weight * InnerProduct(N, v) * ds("head")).Assemble().vec.FV().NumPy()
        columns.append(static(load))
    return np.column_stack(columns)


def rayleigh_ritz(vectors: np.ndarray, K: csr_matrix, M: csr_matrix) -> tuple[np.ndarray, np.ndarray]:
    """Mass-orthonormal basis of span(vectors) that diagonalises K: (phi, omega^2), ascending."""
    import scipy.linalg as la

    vectors = mass_orthonormal(vectors, M)
    Kr, Mr = vectors.T @ (K @ vectors), vectors.T @ (M @ vectors)
    Kr, Mr = 0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T)
    values, coeffs = la.eigh(Kr, Mr)
    phi = vectors @ coeffs
    phi = phi / np.sqrt(np.einsum("ij,ij->j", phi, M @ phi))
    return phi, values


def mass_orthonormal(vectors: np.ndarray, M: csr_matrix, drop: float = 1e-10) -> np.ndarray:
    """Modified Gram-Schmidt (twice) in the mass inner product; nearly dependent columns are dropped."""
    kept: list[np.ndarray] = []
    for col in vectors.T:
        v = col.copy()
        size = math.sqrt(float(v @ (M @ v)))
        for _ in range(2):
            for b in kept:
                v -= float(b @ (M @ v)) * b
        norm = math.sqrt(float(v @ (M @ v)))
        if norm > drop * size:
            kept.append(v / norm)
    return np.column_stack(kept)


def compute_modes(scene: Scene) -> ModalBasis:
    """Eigenmodes and load corrections of the hinged pendulum, reduced to a ModalBasis."""
    from ngsolve import CF, BilinearForm, GridFunction, InnerProduct, Integrate, LinearForm, ds, dx, specialcf, x, y

    from ..fe_boundary import head_points, hinge_torque_load

    mat = scene.pendulum
    h, rho = mat.thickness, mat.rho
    mesh, V, K, M, C = assemble(scene)
    u, v = V.TnT()
    eigen_omega2, eigen = hinged_eigenmodes(K, M, C, scene.model.modes)

    def functional(cf: CoefficientFunction, region: Any = dx) -> np.ndarray:
        return LinearForm(cf * region).Assemble().vec.FV().NumPy().copy()

    pos = CF((x, y))
    l_pos = functional(rho * h * InnerProduct(pos, v))
    l_rot = functional(rho * h * (x * v[1] - y * v[0]))
    N = specialcf.normal(2)
    weight, torque_scale = hinge_torque_load(mesh, scene.geometry)
    l_torque = functional(torque_scale * weight * InnerProduct(N, v), ds("hinge"))
    statics = load_corrections(scene, V, K, C, l_rot, l_torque)
    phi, omega2 = rayleigh_ritz(np.column_stack([eigen, statics]), K, M)
    l_x, l_y = functional(rho * h * v[0]), functional(rho * h * v[1])
    # NGSolve matrices are indexed [test, trial]: cross[k, l] = int rho h phi_l x phi_k, so
    # gyro_ij = int rho h phi_i x phi_j = (cross phi_i) . phi_j
    cross = scipy_matrix(BilinearForm(rho * h * (u[0] * v[1] - u[1] * v[0]) * dx).Assemble().mat)

    head = head_points(mesh, HEAD_RULE_ORDER)
    head_X = np.array(pos(head.points))
    gf = GridFunction(V)
    head_phi = np.empty((len(head_X), 2, phi.shape[1]))
    for j in range(phi.shape[1]):
        gf.vec.FV().NumPy()[:] = phi[:, j]
        head_phi[:, :, j] = gf(head.points)

    tisserand = l_rot @ phi
    inertia0 = float(Integrate(rho * h * (x * x + y * y), mesh))
    if np.max(np.abs(tisserand)) > 1e-6 * np.sqrt(inertia0):
        raise RuntimeError(f"elastic modes are not mass-orthogonal to the rotation: {tisserand}")
    return ModalBasis(
        omega2=omega2,
        eigen_omega2=eigen_omega2,
        inertia0=inertia0,
        mass=float(Integrate(rho * h, mesh)),
        first_moment=np.array([float(Integrate(rho * h * x, mesh)), float(Integrate(rho * h * y, mesh))]),
        a=l_pos @ phi,
        gyro=(cross @ phi).T @ phi,
        moment_modes=np.array([l_x @ phi, l_y @ phi]),
        tisserand=tisserand,
        torque_modes=l_torque @ phi,
        head_X=head_X,
        head_phi=head_phi,
        head_weights=head.weights,
        phi=phi,
    )
