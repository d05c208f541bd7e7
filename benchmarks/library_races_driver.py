"""One run of benchmarks/library_races.py: THREADS threads make the same netgen or NGSolve object at once, with or
without fem_pendulum_fmu/physics/shared_state.py's lock, and each result is compared with one made alone.

    python library_races_driver.py CASE locked|unlocked THREADS

CASE is one of:
    mesh       the pendulum's OCC geometry (netgen.occ shapes named and combined), meshed, loaded and curved
    set        GridFunction.Set of the initial rotation on a space of each thread's own (mesh made beforehand)
    build      a fem model (FemModel itself, or fidelity.create under the lock), then 20 steps of 1 ms: its
               theta, omega and gap

Prints "same" or "DIFFERENT <detail>"; a crash shows in the exit status (the caller counts it).
"""

from __future__ import annotations

import sys
import tempfile
import threading
from contextlib import nullcontext

import numpy as np
from ngsolve import CF, GridFunction, VectorH1, x, y

from fem_pendulum_fmu.physics import geometry
from fem_pendulum_fmu.physics.scene import steel, validate
from fem_pendulum_fmu.physics.shared_state import SHARED_STATE

SCENE = validate(steel(**{"model.fidelity": "fem"}))
ROTATION = CF(((np.cos(0.2) - 1) * x - np.sin(0.2) * y, np.sin(0.2) * x + (np.cos(0.2) - 1) * y))


def mesh_fingerprint(lock: object) -> tuple:
    """What geometry.make_mesh does, afresh (no cached geometry, no disk cache): the OCC geometry, its mesh
    generated, saved, loaded and curved; the curved mesh's points and area."""
    from netgen.meshing import Mesh as NetgenMesh
    from ngsolve import Integrate, Mesh

    with lock, tempfile.TemporaryDirectory() as folder:  # type: ignore[attr-defined]
        occ = geometry.make_geometry.__wrapped__(SCENE.geometry)
        occ.GenerateMesh(maxh=SCENE.model.mesh_size).Save(f"{folder}/mesh.vol")
        ngmesh = NetgenMesh(dim=2)
        ngmesh.Load(f"{folder}/mesh.vol")
        ngmesh.SetGeometry(occ)
        mesh = Mesh(ngmesh)
        mesh.Curve(SCENE.model.order)
    return (*np.array(ngmesh.Coordinates()).ravel(), Integrate(x * x + y * y, mesh))


def set_fingerprint(lock: object, space: VectorH1) -> tuple:
    field = GridFunction(space)
    for _ in range(20):
        with lock:  # type: ignore[attr-defined]
            field.Set(ROTATION, definedon=space.mesh.Materials("pendulum"))
    return tuple(field.vec.FV().NumPy())


def build_fingerprint(locked: bool) -> tuple:
    from fem_pendulum_fmu.physics.fem.model import FemModel
    from fem_pendulum_fmu.physics.fidelity import create

    model = create(SCENE) if locked else FemModel(SCENE)
    outputs = []
    for k in range(1, 21):
        model.advance(k * 1e-3, torque=0.0)
        out = model.outputs()
        outputs += [out.theta, out.omega, out.gap]
    return tuple(outputs)


def main(case: str, locked: bool, threads: int) -> int:
    lock = SHARED_STATE if locked else nullcontext()
    if case == "mesh":
        make = [lambda: mesh_fingerprint(lock)] * threads
    elif case == "build":
        geometry.make_mesh(SCENE.geometry, SCENE.model.mesh_size, SCENE.model.order)  # the geometry made already
        make = [lambda: build_fingerprint(locked)] * threads
    else:
        mesh_size, order = SCENE.model.mesh_size, SCENE.model.order
        spaces = [VectorH1(geometry.make_mesh(SCENE.geometry, mesh_size, order), order=order) for _ in range(threads)]
        make = [lambda space=space: set_fingerprint(lock, space) for space in spaces]
    results: list[object] = [None] * threads
    start_line = threading.Barrier(threads)

    def run(i: int) -> None:
        start_line.wait()
        try:
            results[i] = make[i]()
        except Exception as exc:  # an exception is a result that differs from the one made alone
            results[i] = f"{type(exc).__name__}: {exc}"

    workers = [threading.Thread(target=run, args=(i,)) for i in range(threads)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    alone = make[0]()
    differing = [i for i, result in enumerate(results) if result != alone]
    print("same" if not differing else f"DIFFERENT: threads {differing}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2] == "locked", int(sys.argv[3])))
