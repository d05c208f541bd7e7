"""The reduced model's modal displacement w = phi q as a field on the FE mesh: its von Mises stress and
the nodal fields of field output. NGSolve's pieces are built when first asked for, so a model that
never reports stress or fields never assembles them."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..protocol import BodyField
from ..scene import Scene

if TYPE_CHECKING:
    from ngsolve import CoefficientFunction, GridFunction

    from ..fields import VertexSampler

_J = np.array([[0.0, -1.0], [1.0, 0.0]])


class ModalField:
    """The field phi q of the modal basis `phi` (FE dofs by modes) on the scene's FE space."""

    def __init__(self, scene: Scene, phi: np.ndarray):
        self.scene = scene
        self.phi = phi
        # (field, von Mises of it, the elements' integration points), built when first asked for
        self._stress: tuple[GridFunction, CoefficientFunction, Any] | None = None
        self._sampler: VertexSampler | None = None

    def von_mises_max(self, z: np.ndarray) -> float:
        """Largest von Mises stress of the modal displacement field (frame-invariant), on the FE mesh."""
        gf, cf, points = self._modal_stress()
        gf.vec.FV().NumPy()[:] = self.phi @ z[1:]
        return float(np.max(cf(points)))

    def _modal_stress(self) -> tuple[GridFunction, CoefficientFunction, Any]:
        """(field of the modal displacement, its von Mises stress, the stress's sample points), built once."""
        if self._stress is None:
            import ngsolve as ngs

            from .. import material
            from .modes import fe_space

            mesh, V = fe_space(self.scene)
            gf = ngs.GridFunction(V)
            cf = material.von_mises_plane_stress(material.deformation_gradient(gf), *self.scene.pendulum.lame)
            self._stress = (gf, cf, mesh.MapToAllElements(ngs.IntegrationRule(ngs.TRIG, 4), ngs.VOL))
        return self._stress

    def body_fields(self, z: np.ndarray, rate: np.ndarray) -> list[BodyField]:
        """Nodal fields at z, dz/dt = rate: x = R(theta) (X + w), w = phi q on the FE mesh, so the
        displacement is x - X, the velocity omega J x + R(theta) phi dq/dt, and the von Mises stress
        that of w (frame-invariant)."""
        from ..fields import VertexSampler, body_field

        gf, cf, _ = self._modal_stress()
        if self._sampler is None:
            self._sampler = VertexSampler(gf.space.mesh, "pendulum")
        sampler = self._sampler
        gf.vec.FV().NumPy()[:] = self.phi @ z[1:]
        w, von_mises = sampler.values(gf), sampler.values(cf)
        gf.vec.FV().NumPy()[:] = self.phi @ rate[1:]
        w_rate = sampler.values(gf)
        c, s = math.cos(z[0]), math.sin(z[0])
        rot = np.array([[c, -s], [s, c]])
        x = (sampler.points + w) @ rot.T
        velocity = rate[0] * (x @ _J.T) + w_rate @ rot.T
        return [body_field(sampler, x - sampler.points, velocity, von_mises)]
