"""Hyper-reduction of the reduced fidelity's Neo-Hookean strain energy (soft bodies).

Energy-conserving sampling and weighting: the strain energy sum_p w_p W(F_p(q)) over all the
mesh's quadrature points is replaced by sum_{p in S} xi_p W(F_p(q)) over a small subset S with
non-negative weights xi. The reduced energy is still the energy of a (differently integrated)
hyperelastic body, so the discrete-gradient step conserves it exactly and stays stable; only the
force it derives from is approximated.

The subset and weights are fitted once per basis, on training displacements q that need no
simulation: random directions of the modal space, scaled to strain energies from 1e-6 to 1 of
the energy of a half turn of the pendulum, and single modes at the same energies (the
small-energy ones fix the linear stiffness). The fit asks every training state's generalised
force and energy to be matched to FIT_TOLERANCE of its size (least squares, non-negative weights,
points added greedily until the tolerance is met), and is cached on disk like the basis.
"""

from __future__ import annotations

import io
from typing import TYPE_CHECKING

import numpy as np

from ..modes import ModalBasis, modal_key

if TYPE_CHECKING:
    from ..scene import Scene
    from .reduced_strain import NeoHookeanStrain

ECSW_VERSION = 2  # bump when the fit changes: part of the cache key
FIT_TOLERANCE = 5e-5  # relative residual of the stacked training forces and energies
RANDOM_STATES = 300
ENERGY_DECADES = (-6.0, 0.0)  # training strain energies, log10 of the share of the half-turn energy
MIN_JACOBIAN = 0.05  # training states that compress a point below this area ratio are left out
MAX_POINTS = 400


def training_states(basis: ModalBasis, gravity: float, strain: NeoHookeanStrain) -> np.ndarray:
    """(S, m) training displacements: random directions and single modes at energies spread over
    ENERGY_DECADES of the half-turn energy 2 g |first moment| (seeded, so the fit is reproducible)."""
    rng = np.random.default_rng(20261201)
    m = basis.count
    scale = 2.0 * gravity * float(np.hypot(*basis.first_moment))
    directions = rng.standard_normal((RANDOM_STATES, m))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    energies = scale * 10.0 ** rng.uniform(*ENERGY_DECADES, RANDOM_STATES)
    singles = np.concatenate([np.eye(m), -np.eye(m)])
    single_energies = scale * np.logspace(*ENERGY_DECADES, 4)
    amplitudes = np.concatenate(
        [np.sqrt(2.0 * energies)[:, None] * directions] + [np.sqrt(2.0 * e) * singles for e in single_energies]
    )
    states = amplitudes / np.sqrt(basis.omega2)  # 1/2 omega^2 q^2 = the energy, in the linear limit
    keep = [np.min(strain.jacobians(q)) > MIN_JACOBIAN for q in states]
    return states[np.array(keep)]


def fit_system(strain: NeoHookeanStrain, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(C, b): for every training state, the points' contributions to the generalised force and to
    the energy (columns: points, weighted with their full-rule weights) and their sums, each state's
    rows divided by the size of its force so that every state counts alike."""
    blocks, targets = [], []
    for q in states:
        forces, energies = strain.point_terms(q)
        rows = np.vstack([forces.T, energies[None, :]])  # (m + 1, P)
        total = rows.sum(axis=1)
        size = float(np.linalg.norm(total[:-1]))
        rows[-1] *= size / max(abs(float(total[-1])), 1e-300)  # the energy row weighs like the force
        blocks.append(rows / size)
        targets.append(total / size)
        targets[-1][-1] = np.sign(total[-1])
    return np.vstack(blocks), np.concatenate(targets)


def greedy_nnls(C: np.ndarray, b: np.ndarray, tolerance: float, max_columns: int) -> np.ndarray:
    """Non-negative x with |C x - b| <= tolerance |b|, with few non-zeros: the active-set
    (Lawson-Hanson) iteration, stopped as soon as the tolerance is met. Works on the normal
    equations (C^T C is formed once), so an iteration costs a solve of the active set's size."""
    gram, cb, bb = C.T @ C, C.T @ b, float(b @ b)
    x = np.zeros(C.shape[1])
    active: list[int] = []
    goal = tolerance * tolerance * bb

    def residual2(x: np.ndarray) -> float:
        return bb - 2.0 * float(cb @ x) + float(x @ gram @ x)

    while residual2(x) > goal and len(active) < max_columns:
        gradient = cb - gram @ x
        gradient[active] = -np.inf
        j = int(np.argmax(gradient))
        if gradient[j] <= 0.0:
            break
        active.append(j)
        while True:
            trial = np.linalg.solve(gram[np.ix_(active, active)], cb[active])
            if np.all(trial > 0.0):
                x[active] = trial
                break
            current = x[active]
            falling = trial <= 0.0
            alpha = float(np.min(current[falling] / (current[falling] - trial[falling])))
            x[active] = current + alpha * (trial - current)
            active = [k for k in active if x[k] > 0.0]
    return x


def fit(basis: ModalBasis, gravity: float, strain: NeoHookeanStrain) -> tuple[np.ndarray, np.ndarray]:
    """(point indices, their new weights) of the hyper-reduced strain energy."""
    C, b = fit_system(strain, training_states(basis, gravity, strain))
    x = greedy_nnls(C, b, FIT_TOLERANCE, MAX_POINTS)
    points = np.flatnonzero(x > 0.0)
    return points, x[points] * strain.weights[points]


def cached_fit(scene: Scene, basis: ModalBasis, strain: NeoHookeanStrain) -> tuple[np.ndarray, np.ndarray]:
    """fit(), from the disk cache or computed (a few seconds)."""
    from ..cache import load_or_build

    key = {**modal_key(scene), "ecsw": ECSW_VERSION, "gravity": scene.gravity, "tolerance": FIT_TOLERANCE}

    def build() -> bytes:
        points, weights = fit(basis, scene.gravity, strain)
        buf = io.BytesIO()
        np.savez(buf, points=points, weights=weights)
        return buf.getvalue()

    with np.load(io.BytesIO(load_or_build("ecsw", key, build)), allow_pickle=False) as npz:
        return np.array(npz["points"]), np.array(npz["weights"])
