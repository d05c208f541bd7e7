"""A fingerprint of every fidelity's results, to check that a refactor changes none of them.

    PYTHONPATH=OLD_TREE python benchmarks/result_fingerprint.py > before.txt
    PYTHONPATH=NEW_TREE python benchmarks/result_fingerprint.py > after.txt
    diff before.txt after.txt        # no output: bit-identical

For each scene (fem steel, fem rubber at order 3, the deformable wall, reduced and rigid, with and
without the wall) it hashes the outputs of every 1 ms advance under a constant torque, through the
first impact; then a state taken at the end, the outputs of 20 advances after it is restored, and
its ModelState (scalars sorted, arrays by name); outputs by their values in field order, so that a
renamed output changes nothing. It prints one line per scene (its own hash) and the hash of all,
and on stderr where the package came from (check that PYTHONPATH took effect). About 4 s.
"""

from __future__ import annotations

import hashlib
import sys

import fem_pendulum_fmu

# from the modules, not the package's flat API: the tool runs on older trees too
from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.protocol import ModelState
from fem_pendulum_fmu.physics.scene import Scene

RUBBER = {"pendulum.E": 1e6, "pendulum.nu": 0.45, "pendulum.rho": 1000.0, "contact.stiffness": 5e9}
SCENES: dict[str, tuple[dict[str, object], int]] = {  # name -> (scene values, advances of 1 ms)
    "fem_steel": ({"model.fidelity": "fem"}, 500),
    "fem_rubber": ({"model.fidelity": "fem", **RUBBER, "model.order": 3}, 500),
    "reduced_steel": ({"model.fidelity": "reduced"}, 1000),
    "rigid_steel": ({"model.fidelity": "rigid"}, 1500),
    "fem_wall": ({"model.fidelity": "fem", "wall.kind": "deformable"}, 400),
    "rigid_nowall": ({"model.fidelity": "rigid", "wall.kind": "none"}, 300),
    "reduced_nowall": ({"model.fidelity": "reduced", "wall.kind": "none"}, 300),
    "reduced_rubber": ({"model.fidelity": "reduced", **RUBBER}, 800),
    "fem_newmark": ({"model.fidelity": "fem", "solver.scheme": "newmark_gap_rule"}, 400),
}
TORQUE = 0.2  # N.m
RESTORED_ADVANCES = 20


def hash_state(digest: hashlib._Hash, state: ModelState) -> None:
    """Feed a ModelState to `digest` in a form independent of the order its scalars were written in."""
    digest.update(repr((state.fidelity, state.time, sorted(state.scalars.items()))).encode())
    for key in sorted(state.arrays):
        digest.update(key.encode() + state.arrays[key].tobytes())


def output_values(outputs: object) -> bytes:
    """The outputs' values in their fields' order, not their names: a renamed output changes no fingerprint."""
    values = outputs.as_dict().values()  # type: ignore[attr-defined]
    return repr(tuple(values)).encode()


def fingerprint(values: dict[str, object], advances: int, digest: hashlib._Hash) -> None:
    """Run one scene into `digest`: its advances, its state, and the advances after a restore."""
    model = create(Scene().with_values(values))
    for k in range(1, advances + 1):
        digest.update(output_values(model.advance(k * 1e-3, TORQUE)))
    state = model.get_state()
    hash_state(digest, state)
    later = range(advances + 1, advances + RESTORED_ADVANCES + 1)
    for k in later:
        model.advance(k * 1e-3, TORQUE)
    model.set_state(ModelState.from_bytes(state.to_bytes()))
    for k in later:
        digest.update(output_values(model.advance(k * 1e-3, TORQUE)))


def main() -> None:
    print(f"package: {fem_pendulum_fmu.__file__}", file=sys.stderr)
    total = hashlib.sha256()
    for name, (values, advances) in SCENES.items():
        scene = hashlib.sha256()  # each scene's own: a difference shows in its line alone
        fingerprint(values, advances, scene)
        total.update(scene.digest())
        print(f"{name} {scene.hexdigest()[:16]}")
    print(f"all {total.hexdigest()}")


if __name__ == "__main__":
    main()
