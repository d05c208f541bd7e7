"""The lock under which models are built: netgen and NGSolve keep state for the whole process that building a
model touches and that they do not guard themselves.

Models are built on whatever thread asks (an FMU host may initialise several instances at once, each on a
thread of its own). netgen and NGSolve release Python's GIL inside many calls, and what they share across the
process is not all guarded:

* netgen.occ keeps every shape's names and local mesh sizes in tables shared by all shapes of the process
  (OCCGeometry's shape property tables), written while shapes are built, named and combined (its boolean
  operations release the GIL): two geometries built at once corrupt the heap.
* netgen's mesher and mesh file reader go through process-wide variables (the current mesh, the current
  geometry, the meshing parameters) with the GIL released.
* NGSolve's GridFunction.Set takes its scratch memory from the one heap the Python bindings keep for the whole
  process, with the GIL released: two Sets at once are handed the same memory, and the initial rotation by
  theta0 comes out wrong with no error.
* With those three taken in turn, four fem models built at once still, now and then, assembled the hinge
  torque's matrix with half its entries and the sign of the rest turned (no error); the shared state behind it
  is not found, and building is therefore taken in turn as a whole.

So `fidelity.create` builds every model under `SHARED_STATE`, and geometry.make_mesh, which other callers use
directly, takes it too (it is re-entrant). Stepping, outputs and states run on several threads at once: they
read each instance's own arrays and assembled objects. benchmarks/library_races.py reproduces each race with
the lock taken away; tests/test_concurrent_instances.py builds and steps instances on several threads at once
through both FMUs and compares every result with the same instance run alone.

NGSolve's TaskManager (model.threads > 1) keeps its thread count for the whole process: an advance on it sets
the count and runs under `TASK_MANAGER`, one such advance at a time.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext

SHARED_STATE = threading.RLock()
TASK_MANAGER = threading.Lock()


@contextmanager
def _task_manager(threads: int) -> Iterator[None]:
    import ngsolve as ngs  # here, not at the top: geometry.py imports this module, a rigid model no NGSolve

    with TASK_MANAGER:
        ngs.SetNumThreads(threads)
        with ngs.TaskManager():
            yield


def task_manager(threads: int) -> AbstractContextManager[None]:
    """NGSolve's TaskManager with `threads` threads, one advance at a time; nothing for threads = 1
    (NGSolve's loops then run on the caller's thread alone, whatever another thread has entered)."""
    return _task_manager(threads) if threads > 1 else nullcontext()
