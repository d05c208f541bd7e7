"""The Dask side of a worker: a plugin that loads the FMU once per worker process, and the task function.

The FMU travels to the workers inside the plugin (its bytes, about 0.65 MB),
so a cluster needs no shared folder; Dask hands a registered plugin to every
worker that joins later too, including one a nanny restarts after a crash.
`setup` extracts the FMU, the first sample instantiates it, `teardown` (the
worker closing) frees it. One sample at a time per worker process: the FMU's
Python runs under the GIL, so extra threads would only queue (start workers
with `--nthreads 1`; a lock keeps other settings correct).
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any, cast

from distributed import WorkerPlugin, get_worker

from .run import LoadedFmu, SampleResult, SampleTask, run_sample


class FmuPlugin(WorkerPlugin):
    """Carries the FMU's bytes to each worker and keeps it loaded there (`loaded`)."""

    idempotent = True  # registering the same FMU again (a resumed sweep on the same cluster) keeps the loaded one

    def __init__(self, data: bytes, digest: str) -> None:
        self.name = plugin_name(digest)
        self.data = data
        self.loaded: LoadedFmu | None = None
        self.lock = threading.Lock()

    def __getstate__(self) -> dict[str, Any]:
        """Only name and bytes travel; the loaded FMU and the lock belong to one process."""
        return {"name": self.name, "data": self.data}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.name, self.data = state["name"], state["data"]
        self.loaded = None
        self.lock = threading.Lock()

    def setup(self, worker: Any) -> None:
        path = Path(worker.local_directory) / f"{self.name}.fmu"
        path.write_bytes(self.data)
        self.loaded = LoadedFmu(path)

    def teardown(self, worker: Any) -> None:
        if self.loaded is not None:
            self.loaded.close()
            self.loaded = None


def plugin_name(digest: str) -> str:
    return f"fem-pendulum-fmu-{digest[:16]}"


def run_on_worker(task: SampleTask, name: str) -> SampleResult:
    """The task a sweep submits: run `task` on the FMU this worker process has loaded."""
    plugin = cast(FmuPlugin, get_worker().plugins[name])
    with plugin.lock:
        if plugin.loaded is None:  # not set up on this worker (cannot happen once registered): say so
            raise RuntimeError(f"worker plugin {name} holds no FMU")
        return run_sample(plugin.loaded, task)
