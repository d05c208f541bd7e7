"""fem/mass_moments.py: the mass's quadratic forms in one pass over the scalar mass equal the products with
the assembled matrices, and a matrix without the block form is left to those."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fem_pendulum_fmu.physics.fem.mass_moments import BlockMass
from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.scene import stiff


@pytest.mark.parametrize("wall", ["rigid", "deformable"])
def test_block_forms_equal_the_assembled_products(wall: str) -> None:
    """Kinetic energy (every body), u.M u and u.C v (the pendulum) at a state after 50 ms: equal to the
    products with the assembled matrices to 1e-13 of the sum of their terms' sizes (2e-16 measured: the
    y block is integrated apart from the x block)."""
    model = FemModel(stiff(**{"wall.kind": wall}))
    for i in range(1, 51):
        model.advance(i * 1e-3, 0.0)
    out, s = model.measures, model._state
    u, v = np.asarray(s.u), np.asarray(s.v)
    kinetic, rotation = BlockMass.of(out.mass), BlockMass.of(out.mass_p, out.cross)
    assert kinetic is not None and rotation is not None
    uMu, uCv = rotation.square_and_cross(u, v)
    for got, (a, m, b) in ((kinetic.square(v), (v, out.mass, v)), (uMu, (u, out.mass_p, u)), (uCv, (u, out.cross, v))):
        size = float(np.abs(a) @ (abs(m) @ np.abs(b)))
        assert abs(got - float(a @ (m @ b))) <= 1e-13 * size
        assert size > 0.0


def test_a_matrix_without_the_block_form_is_refused() -> None:
    s = sp.random(6, 6, density=0.5, random_state=3, format="csr") + sp.identity(6, format="csr")
    s = s + s.T
    block = sp.block_diag((s, s), format="csr")
    assert BlockMass.of(block) is not None
    assert BlockMass.of(sp.block_diag((s, 2.0 * s), format="csr")) is None
    assert BlockMass.of(sp.bmat([[s, s], [None, s]], format="csr")) is None
    assert BlockMass.of(block, sp.bmat([[None, s], [-s, None]], format="csr")) is None  # the cross form's sign
    assert BlockMass.of(block, sp.bmat([[None, -s], [s, None]], format="csr")) is not None
