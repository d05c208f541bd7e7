"""Strain energy of the reduced fidelity's modal field (reduced/model.py has the model's energies).

Stiff bodies use the quadratic modal energy, soft ones the FE model's Neo-Hookean law integrated
over the mesh's quadrature points in the compiled core (physics/core/reduced_step.c; the numpy form is its
test reference): the reduced
model's hot loop never calls into the FE assembly.
"""

from __future__ import annotations

import numpy as np

from ..scene import Scene
from .kernel import reduced_kernel
from .modes import ModalBasis


def uses_linear_strain(scene: Scene) -> bool:
    """Stiff bodies (steel: strains ~1e-6) use the quadratic modal strain energy: exact to O(strain^3),
    while evaluating the Neo-Hookean energy there would lose ~4 digits to cancellation
    (tr C - 2 - 2 ln J is O(strain^2) from O(strain) terms). Soft bodies use the Neo-Hookean energy."""
    return not scene.pendulum.soft


def strain_energy(scene: Scene, basis: ModalBasis) -> LinearStrain | NeoHookeanStrain:
    """The scene's strain energy: quadratic (stiff bodies) or Neo-Hookean (soft ones)."""
    if uses_linear_strain(scene):
        return LinearStrain(basis.omega2)
    return NeoHookeanStrain(scene, basis.phi, basis.omega2)


class LinearStrain:
    """1/2 sum omega_j^2 q_j^2: linear elasticity in the rotating frame."""

    def __init__(self, omega2: np.ndarray):
        self.omega2 = omega2
        self.linear_hessian = np.diag(omega2)

    def kernel_fields(self) -> dict:
        """This energy's fields of the compiled kernel's data (reduced/kernel.py)."""
        return {"m": len(self.omega2), "neo": 0, "omega2": self.omega2}

    def energy(self, q: np.ndarray) -> float:
        return 0.5 * float(self.omega2 @ (q * q))

    def gradient(self, q: np.ndarray) -> np.ndarray:
        return self.omega2 * q

    def hessian(self, q: np.ndarray) -> np.ndarray:
        return self.linear_hessian


class NeoHookeanStrain:
    """The FE model's Neo-Hookean energy of the modal displacement field w = phi q, integrated on
    the FE mesh (rotation-invariant, so the floating frame stays exact at large strains).

    The modes' displacement gradients are sampled once at the mesh's quadrature points; an
    evaluation is then F = I + G q and the energy law at those points, in the compiled kernel
    (numpy where none was built): the reduced model's hot loop never calls into the FE assembly."""

    def __init__(self, scene: Scene, phi: np.ndarray, omega2: np.ndarray):
        import ngsolve as ngs

        from ..scene import element_order
        from .modes import fe_space

        mesh, V = fe_space(scene)
        rule = ngs.IntegrationRule(ngs.TRIG, 2 * element_order(scene))
        points = mesh.MapToAllElements(rule, ngs.VOL)
        jac_det = ngs.Det(ngs.specialcf.JacobianMatrix(2))(points).ravel()
        self._weights = scene.pendulum.thickness * np.abs(jac_det) * np.tile([ip.weight for ip in rule], mesh.ne)
        gf = ngs.GridFunction(V)
        grad = ngs.Grad(gf)
        G = np.empty((len(self._weights), 4, phi.shape[1]))  # rows d wx/dx, d wx/dy, d wy/dx, d wy/dy
        for j in range(phi.shape[1]):
            gf.vec.FV().NumPy()[:] = phi[:, j]
            G[..., j] = np.asarray(grad(points)).reshape(-1, 4)
        self._G = G.reshape(-1, phi.shape[1])
        self._lame_lambda, self._mu = scene.pendulum.lame
        self.linear_hessian = np.diag(omega2)  # the tangent at q = 0
        weighted = self._G * np.repeat(self._weights, 4)[:, None]
        # the kernel's read-only fields, built once: this energy's kernel and the model's share them
        self._fields = {
            "m": len(omega2),
            "neo": 1,
            "omega2": omega2,
            "nqp": len(self._weights),
            "GT": np.ascontiguousarray(self._G.T),
            "qw": self._weights,
            "k_mu": self._mu * (weighted.T @ self._G),
            "lame_lambda": self._lame_lambda,
            "mu": self._mu,
        }
        self._kernel = reduced_kernel(**self.kernel_fields())

    def kernel_fields(self) -> dict:
        """This energy's fields of the compiled kernel's data (reduced/kernel.py), with a
        scratch buffer of its own for each kernel."""
        m, nqp = self._fields["m"], self._fields["nqp"]
        return {**self._fields, "work": np.zeros(nqp * (4 + 10 * m))}

    def _kinematics(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        F = (self._G @ q).reshape(-1, 2, 2)
        F[:, 0, 0] += 1.0
        F[:, 1, 1] += 1.0
        J = F[:, 0, 0] * F[:, 1, 1] - F[:, 0, 1] * F[:, 1, 0]
        return F, J

    def energy(self, q: np.ndarray) -> float:
        if self._kernel is not None:
            return self._kernel.strain_energy(q)
        F, J = self._kinematics(q)
        with np.errstate(invalid="ignore", divide="ignore"):
            log_j = np.log(J)  # nan for an inverted point: the step fails and is retried smaller
        stretch = np.einsum("pij,pij->p", F, F) - 2.0 - 2.0 * log_j
        density = 0.5 * self._mu * stretch + 0.5 * self._lame_lambda * log_j * log_j
        return float(self._weights @ density)

    @staticmethod
    def _inverse_and_log(F: np.ndarray, J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """F^-1 and ln J at every point (nan where an element is inverted)."""
        inv = np.empty_like(F)
        inv[:, 0, 0], inv[:, 0, 1] = F[:, 1, 1], -F[:, 0, 1]
        inv[:, 1, 0], inv[:, 1, 1] = -F[:, 1, 0], F[:, 0, 0]
        with np.errstate(invalid="ignore", divide="ignore"):
            inv /= J[:, None, None]
            return inv, np.log(J)

    def gradient(self, q: np.ndarray) -> np.ndarray:
        if self._kernel is not None:
            return self._kernel.strain_gradient(q)
        F, J = self._kinematics(q)
        inv, log_j = self._inverse_and_log(F, J)
        inv_t = inv.transpose(0, 2, 1)
        P = self._mu * (F - inv_t) + (self._lame_lambda * log_j)[:, None, None] * inv_t  # first Piola-Kirchhoff
        return ((self._weights[:, None, None] * P).reshape(-1)) @ self._G

    def hessian(self, q: np.ndarray) -> np.ndarray:
        """Exact tangent: sum_p w_p G_p^T A_p G_p with the Neo-Hookean elasticity tensor
        A_iJkL = mu d_ik d_JL + (mu - lame_lambda ln J) Fi_Li Fi_Jk + lame_lambda Fi_Ji Fi_Lk (Fi = F^-1)."""
        if self._kernel is not None:
            return self._kernel.strain_hessian(q)
        F, J = self._kinematics(q)
        inv, log_j = self._inverse_and_log(F, J)
        n = len(J)
        A = np.einsum("pli,pjk->pijkl", inv, inv).reshape(n, 4, 4) * (self._mu - self._lame_lambda * log_j)[
            :, None, None
        ] + self._lame_lambda * np.einsum("pji,plk->pijkl", inv, inv).reshape(n, 4, 4)
        A += self._mu * np.eye(4)
        G = self._G.reshape(n, 4, -1)
        AG = A @ G
        return np.einsum("pam,pan->mn", G * self._weights[:, None, None], AG, optimize=True)
