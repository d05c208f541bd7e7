"""Child of tests/test_wheel.py: every fidelity from the package on sys.path, STEPS 1 ms steps at -1 N.m from
0.2 rad. Prints one JSON line: the compiled core's file and each fidelity's final theta (float.hex)."""

from __future__ import annotations

import json
import sys

import fem_pendulum_fmu.physics.core._femp_core as core
from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.scene import steel


def final_theta(fidelity: str, steps: int) -> float:
    model = create(steel(**{"model.fidelity": fidelity, "theta0": 0.2}))
    for k in range(1, steps + 1):
        model.advance(k * 1e-3, torque=-1.0)
    return model.outputs().theta


if __name__ == "__main__":
    steps = int(sys.argv[1])
    thetas = {fidelity: final_theta(fidelity, steps).hex() for fidelity in ("rigid", "reduced", "fem")}
    print(json.dumps({"core": core.__file__, "thetas": thetas}))
