"""Newton's start iterate in free flight: the last step's mean velocity, plus the error it is predicted to make.

After an impact the bodies ring (the steel plate at about 1 kHz), and 1 ms steps
do not resolve that ringing: the guess u0 + dt (u0 - u_prev) / dt missed the
step's end by 1e-5 to 5e-4 m where it missed it by 2e-6 m before the first
impact, and the held Jacobian, which gains about two digits an iteration, took
5 to 6 iterations a step instead of 4. Those
misses are not noise: at equal steps a linear body's modes each follow a
fixed two-term recurrence, and so does their sum of a few dominant ones. So
the misses of the last WINDOW + DEPTH equal free-flight steps are kept
(`GuessErrors`, part of the model's state: a restored model starts the same
iterates), a recurrence of DEPTH terms is fitted to them by least squares
(from their inner products, kept with them), and the next miss predicted by
it. On the steel scene it predicted the miss to a median 1.3e-3 of its size,
on the 0.005 m mesh and the meshed wall as well; on the rubber, whose misses come
from its large deformation, it explained a quarter of them, and is not used
(FIT_LEFT). Any prediction is only a start: the step solves to the same
tolerance from it.
"""

from __future__ import annotations

import numpy as np

from ..core import ffi, lib, pointer

# past misses the prediction combines, and the steps the recurrence is fitted over: on the steel scene's swing
# the prediction missed by a median 2.2e-3 of the miss with 6 and 4, 1.3e-3 with 8 and 4, 8e-4 with 8 and 8
DEPTH = 8
WINDOW = 4
KEPT = DEPTH + WINDOW
# the prediction is used where the fit leaves less than this share of the window's squared misses unexplained
FIT_LEFT = 1e-2
# the normal equations' ridge, a share of their largest diagonal entry: a few dominant modes make the past
# misses nearly dependent, and the fit's coefficients along what they do not tell apart stay small
RIDGE = 1e-12
SAME_STEP = 1e-9  # relative difference of two step sizes taken as equal (an advance's last step lands on its end)


class GuessErrors:
    """The misses u1 - (u0 + dt drift) of the last equal free-flight steps of size dt, newest first (rows of
    `errors`), their inner products (`gram`) and the next miss they predict (`next_miss`, None where the fit
    declines), in one block (the core's layout, core/fem_start_iterate.c). Never changed in place."""

    def __init__(self, dt: float, block: np.ndarray, k: int, n: int, predicted: bool):
        self.dt, self.k, self.n, self._block, self._predicted = dt, k, n, block, predicted
        self.address = pointer(block)

    @property
    def errors(self) -> np.ndarray:
        return self._block[: self.k * self.n].reshape(self.k, self.n)

    @property
    def gram(self) -> np.ndarray:
        return self._block[self.k * self.n : self.k * (self.n + self.k)].reshape(self.k, self.k)

    @property
    def next_miss(self) -> np.ndarray | None:
        return self._block[self.k * (self.n + self.k) :] if self._predicted else None

    def to_entries(self) -> tuple[dict[str, float], dict[str, np.ndarray]]:
        """The ModelState scalars and arrays (copies) of these misses (the prediction is made again from them)."""
        return {"guess_dt": self.dt}, {"guess_errors": self.errors.copy(), "guess_gram": self.gram.copy()}

    @staticmethod
    def from_entries(scalars: dict[str, float], arrays: dict[str, np.ndarray], n: int) -> GuessErrors | None:
        """Inverse of to_entries for a model of n displacement dofs (None where the state has none);
        ValueError where the arrays do not fit."""
        if "guess_errors" not in arrays:
            return None
        errors, gram = arrays["guess_errors"], arrays.get("guess_gram", np.empty(0))
        k = errors.shape[0] if errors.ndim == 2 else -1
        if not (0 < k <= KEPT and errors.shape[1] == n and gram.shape == (k, k)) or "guess_dt" not in scalars:
            raise ValueError(
                f"fem state's start-iterate misses of shape {errors.shape} and inner products of shape "
                f"{gram.shape} do not fit this fem model (at most {KEPT} misses of {n} dofs)"
            )
        if not (np.all(np.isfinite(errors)) and np.all(np.isfinite(gram))):
            raise ValueError("fem state's start-iterate misses or their inner products are not all finite")
        block = np.concatenate([errors.ravel(), gram.ravel(), np.zeros(n)]).astype(float)
        return GuessErrors(float(scalars["guess_dt"]), block, k, n, _predict(block, k, n))


def _same_step(a: float, b: float) -> bool:
    return abs(a - b) <= SAME_STEP * max(abs(a), abs(b))


def _predict(block: np.ndarray, k: int, n: int) -> bool:
    """Write the next miss into the block's tail from its misses and inner products; False where the fit
    declines (or there are fewer than KEPT misses)."""
    if k < KEPT:
        return False
    return bool(lib.femp_misses_predict(n, k, pointer(block), DEPTH, WINDOW, RIDGE, FIT_LEFT))


def recorded(history: GuessErrors | None, dt: float, miss: np.ndarray) -> GuessErrors:
    """The misses with that of a new step of dt added (the oldest dropped beyond KEPT), and the next one
    predicted; a step of another size than the history's starts a new history."""
    n = len(miss)
    kept = history if history is not None and history.n == n and _same_step(history.dt, dt) else None
    k = 1 if kept is None else min(kept.k + 1, KEPT)
    block = np.empty(k * (n + k) + n)
    block[:n] = miss
    old = (0, ffi.NULL) if kept is None else (kept.k, kept.address)
    predicted = lib.femp_misses_record(n, *old, k, pointer(block), DEPTH, WINDOW, RIDGE, FIT_LEFT)
    return GuessErrors(dt, block, k, n, bool(predicted))


def predicted_miss(history: GuessErrors | None, dt: float) -> np.ndarray | None:
    """The next miss of a step of dt, sum_j c_j errors[j] with the c that best reproduce each of the WINDOW
    newest misses from the DEPTH before it (made when the last miss was recorded); None without KEPT misses
    of that step size or where that fit leaves more than FIT_LEFT of them unexplained."""
    if history is None or not _same_step(history.dt, dt):
        return None
    return history.next_miss
