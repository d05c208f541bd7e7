"""Time the FE iteration's two largest kernel calls alone: the stress residual and the held LU solve.

    python benchmarks/kernel_calls.py [--mesh-size H] [--preset steel|rubber] [--calls 300] [--repeat 5]

A model of the scene (on the mesh of --mesh-size, model.mesh_size; 0: the scene's default) is advanced
50 ms in 1 ms steps; then femp_stress_residual (every body, at the solver's current iterate) and the held
factors' solve (HeldFactor.solve, the compiled one) are each called `calls` times in a loop, `repeat`
times; the best loop's time per call is printed, in microseconds (docs/notes/fem.md, change 24). It needs the
compiled kernels (native.py): without a C compiler it says so and exits with 1.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.scene import PRESETS


def best_per_call(call, calls: int, repeat: int) -> float:
    """The least time per call (s) over `repeat` loops of `calls` calls."""
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(calls):
            call()
        best = min(best, (time.perf_counter() - start) / calls)
    return best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh-size", type=float, default=0.0, help="model.mesh_size (0: the scene's default)")
    parser.add_argument("--preset", choices=PRESETS, default="steel", help="the scene")
    parser.add_argument("--calls", type=int, default=300, help="calls per timed loop")
    parser.add_argument("--repeat", type=int, default=5, help="timed loops; the best is printed")
    args = parser.parse_args()
    model = FemModel(PRESETS[args.preset](**({"model.mesh_size": args.mesh_size} if args.mesh_size else {})))
    split = model.form.split
    if split is None or split.elastic._lib is None:
        print("kernel_calls: the compiled kernels are not available (no C compiler?)", file=sys.stderr)
        return 1
    for i in range(1, 51):
        model.advance(i * 1e-3, 0.0)
    newton, elastic = model.newton, split.elastic
    w = newton._w_np.copy()
    out = np.zeros(len(w))
    lib = elastic._lib

    def stress() -> None:
        for head, middle in elastic.kernel_args:
            lib.femp_stress_residual(*head, w.ctypes.data, *middle, out.ctypes.data)

    b, x = np.cos(np.arange(len(w))), np.zeros(len(w))
    t_stress = best_per_call(stress, args.calls, args.repeat)
    t_solve = best_per_call(lambda: newton._factor.solve(b, x), args.calls, args.repeat)
    print(f"{len(w)} unknowns: stress residual {t_stress * 1e6:.1f} us, LU solve {t_solve * 1e6:.1f} us per call")
    return 0


if __name__ == "__main__":
    sys.exit(main())
