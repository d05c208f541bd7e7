"""The Dask side of a worker: a plugin that loads the FMUs once per worker process, and the task functions.

The FMUs travel to the workers inside the plugin (their bytes: the pendulum FMU's, about 0.65 MB,
and for a loop sweep the controller FMU's too), so a cluster needs no shared folder; Dask hands a
registered plugin to every worker that joins later too, including one a nanny restarts after a
crash. `setup` writes the FMUs and extracts the pendulum's (open loop: run.LoadedFmu) or prepares
the loop's (loop_run.LoadedLoop), the first sample instantiates them, `teardown` (the worker
closing) frees them. One sample at a time per worker process: the FMUs' Python runs under the GIL,
so extra threads would only queue (start workers with `--nthreads 1`; a lock keeps other settings
correct).
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any, cast

from distributed import WorkerPlugin, get_worker

from .loop_run import LoadedLoop, LoopTask, run_loop_sample
from .run import LoadedFmu, SampleResult, SampleTask, run_sample


class FmuPlugin(WorkerPlugin):
    """Carries the FMUs' bytes to each worker and keeps them loaded there: `loaded` (open loop) or
    `loop` (with a controller FMU). `digest` names the plugin: a hash of both FMUs' contents."""

    idempotent = True  # registering the same FMUs again (a resumed sweep on the same cluster) keeps the loaded ones

    def __init__(self, data: bytes, digest: str, controller: bytes | None = None) -> None:
        self.name = plugin_name(digest)
        self.data = data
        self.controller = controller
        self.loaded: LoadedFmu | None = None
        self.loop: LoadedLoop | None = None
        self.lock = threading.Lock()

    def __getstate__(self) -> dict[str, Any]:
        """Only name and bytes travel; the loaded FMUs and the lock belong to one process."""
        return {"name": self.name, "data": self.data, "controller": self.controller}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.name, self.data, self.controller = state["name"], state["data"], state["controller"]
        self.loaded = self.loop = None
        self.lock = threading.Lock()

    def setup(self, worker: Any) -> None:
        path = Path(worker.local_directory) / f"{self.name}.fmu"
        path.write_bytes(self.data)
        if self.controller is None:
            self.loaded = LoadedFmu(path)
            return
        controller = path.with_name(f"{self.name}-controller.fmu")
        controller.write_bytes(self.controller)
        self.loop = LoadedLoop(path, controller)

    def teardown(self, worker: Any) -> None:
        for held in (self.loaded, self.loop):
            if held is not None:
                held.close()
        self.loaded = self.loop = None


def plugin_name(digest: str) -> str:
    return f"fem-pendulum-fmu-{digest[:16]}"


def _plugin(name: str) -> FmuPlugin:
    return cast(FmuPlugin, get_worker().plugins[name])


def run_on_worker(task: SampleTask, name: str) -> SampleResult:
    """The task an open-loop sweep submits: run `task` on the FMU this worker process has loaded."""
    plugin = _plugin(name)
    with plugin.lock:
        if plugin.loaded is None:  # not set up on this worker (cannot happen once registered): say so
            raise RuntimeError(f"worker plugin {name} holds no FMU")
        return run_sample(plugin.loaded, task)


def run_loop_on_worker(task: LoopTask, name: str) -> SampleResult:
    """The task a loop sweep submits: run the loop sample `task` on this worker's two FMUs."""
    plugin = _plugin(name)
    with plugin.lock:
        if plugin.loop is None:
            raise RuntimeError(f"worker plugin {name} holds no controller FMU")
        return run_loop_sample(plugin.loop, task)
