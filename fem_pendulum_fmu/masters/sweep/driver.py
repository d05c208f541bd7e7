"""The sweep on Dask's distributed scheduler: a local cluster of worker processes, or a running one.

`run_sweep` is the Python function behind `fem-pendulum sweep`. It reads what
the output folder already holds, submits only the missing samples, keeps each
result as it arrives (store.write_part) and merges them into the tables at
the end. The FMU goes to the workers once, in a worker plugin (worker.py), and
with `SweepSettings.loop` the controller FMU with it: each sample is then a run
of the controller loop (loop_samples.py, loop_run.py) and its figures are the
loop's metrics.

A worker process that dies mid-sample (killed, out of memory, a crash in
native code) makes Dask raise KilledWorker for the sample's task; the sample
is then submitted once more, and if that dies too it gets status error with
the reason. The local cluster's scheduler is told not to retry on its own
(distributed.scheduler.allowed-failures = 0), so "once" is exact there; a
running scheduler applies its own allowed-failures first (default 3).

The local cluster's worker processes start with one thread for every library that starts a pool
of its own (ONE_THREAD, set before each process starts, so before the libraries load): a sample
runs on one core, and N workers on N cores do not compete for them. A variable the environment
already sets is kept (the user's own count). NGSolve's TaskManager is the sample's model.threads
(default 1); NGS_NUM_THREADS is its default wherever else one starts.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import dask
import pandas as pd
from distributed import Client, KilledWorker, LocalCluster, as_completed

from ..control.connections import Wiring
from ..control.metrics import METRIC_NAMES
from ..control.series import COLUMNS
from ..open_loop import read_torque_csv
from . import store
from .figures import Figures
from .loop_run import LoopTask, loop_task
from .loop_samples import LoopSweep
from .progress import Progress
from .run import ERROR, OK, SampleResult, SampleTask
from .samples import Sample
from .worker import FmuPlugin, run_loop_on_worker, run_on_worker

ATTEMPTS = 2  # a sample whose worker dies is run once more, then marked
# the thread counts a local cluster's workers start with (1 unless the environment sets one): OpenMP, OpenBLAS,
# MKL, Apple's Accelerate, numexpr, NGSolve's TaskManager
ONE_THREAD = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "NGS_NUM_THREADS",
)


@dataclass(frozen=True)
class SweepSettings:
    """What every sample of a sweep shares, and where and how it runs.

    outputs: the outputs kept in the time series (() = every output of the FMU); the summary figures read
        theta, omega, gap, gap_min, contact_force_max and the energies whatever is kept. With `loop`: the
        columns of the loop's table kept (() = all, masters/control/series.py); the metrics read them all.
    workers: processes of a local cluster (None = the machine's cores); ignored with `scheduler`.
    scheduler: address of a running Dask scheduler (tcp://host:8786) to use instead of a local cluster.
    retry_failed: run again the samples the folder holds with status error.
    loop: run each sample as the controller loop with this controller (samples from loop_samples.loop_samples).
    """

    fmu: Path
    out: Path
    stop_time: float = 2.0
    step: float = 1e-3
    outputs: tuple[str, ...] = ()
    workers: int | None = None
    scheduler: str | None = None
    csv: bool = False
    progress: bool = True
    retry_failed: bool = False
    loop: LoopSweep | None = None


def _all_outputs(fmu: Path) -> tuple[str, ...]:
    from fmpy import read_model_description

    return tuple(v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "output")


def worker_environment() -> dict[str, str]:
    """The variables a local cluster's worker processes start with: Dask's own (distributed.nanny.pre-spawn-environ)
    and ONE_THREAD at 1, each as the environment sets it if it does."""
    spawn = dask.config.get("distributed.nanny.pre-spawn-environ") or {}
    own = {name: str(value) for name, value in spawn.items() if value is not None}
    return {**own, **{name: os.environ.get(name, "1") for name in ONE_THREAD}}


@contextlib.contextmanager
def _environment_kept(names: list[str]) -> Iterator[None]:
    """os.environ's `names` as they were, afterwards: Dask's nanny sets the workers' variables in this process
    too, before it starts each worker."""
    before = {name: os.environ.get(name) for name in names}
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


@contextlib.contextmanager
def connect(settings: SweepSettings) -> Iterator[Client]:
    """A client of the running scheduler, or of a local cluster on 127.0.0.1 that is closed afterwards (its
    workers with worker_environment(); this process's environment as it was once it closed)."""
    if settings.scheduler:
        with Client(settings.scheduler) as client:
            yield client
        return
    environment = worker_environment()
    config = {"distributed.scheduler.allowed-failures": 0, "distributed.nanny.pre-spawn-environ": environment}
    with _environment_kept([*environment, "PYTHONHASHSEED"]):
        with dask.config.set(config):
            cluster = LocalCluster(
                n_workers=settings.workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
            )
        with cluster, Client(cluster) as client:
            yield client


FIGURE_NAMES = tuple(asdict(Figures()))  # an open-loop sample's figure columns; a loop sample's: METRIC_NAMES
Task = SampleTask | LoopTask


def _row(sample: Sample, result: SampleResult, loop: bool) -> dict[str, Any]:
    """The results table's row of a sample: its values, status and figures (NaN for a failed sample)."""
    figures = asdict(result.figures) if isinstance(result.figures, Figures) else result.figures
    return {
        "sample_id": sample.sample_id,
        **sample.values,
        **({} if loop else {"torque": sample.torque}),
        "status": result.status,
        "message": result.message,
        "wall_time": result.wall_time,
        **{name: figures.get(name, math.nan) for name in (METRIC_NAMES if loop else FIGURE_NAMES)},
    }


def _tasks(
    samples: list[Sample], settings: SweepSettings, outputs: tuple[str, ...], wiring: Wiring | None
) -> list[Task]:
    if settings.loop is not None and wiring is not None:
        loop = settings.loop
        shared = (wiring, settings.stop_time, settings.step, loop.drive_limit, outputs, loop.hold)
        return [loop_task(s, *shared) for s in samples]
    torques = {path: read_torque_csv(Path(path)) for path in {s.torque for s in samples} if path}
    return [
        SampleTask(s.sample_id, s.values, torques.get(s.torque), settings.stop_time, settings.step, outputs)
        for s in samples
    ]


def _collect(client: Client, tasks: list[Task], plugin: str) -> Iterator[SampleResult]:
    """Results as they finish; a task whose worker died is submitted again (ATTEMPTS in all)."""
    attempt: dict[Any, tuple[Task, int]] = {}

    def submit(task: Task, number: int) -> Any:
        function = run_loop_on_worker if isinstance(task, LoopTask) else run_on_worker
        future = client.submit(function, task, plugin, key=f"sample-{task.sample_id}-{number}", pure=False)
        attempt[future] = (task, number)
        return future

    pending = as_completed([submit(task, 1) for task in tasks])
    for future in pending:
        task, number = attempt.pop(future)
        try:
            yield future.result()
        except KilledWorker as exc:
            if number < ATTEMPTS:
                pending.add(submit(task, number + 1))
                continue
            yield SampleResult(task.sample_id, ERROR, f"its worker process died in each of {number} attempts ({exc})")
        except Exception as exc:  # e.g. a task Dask could not run or deliver: the sample fails, the sweep goes on
            yield SampleResult(task.sample_id, ERROR, f"{type(exc).__name__}: {exc}")
        finally:
            future.release()


def _run(
    samples: list[Sample], settings: SweepSettings, outputs: tuple[str, ...], digest: str, wiring: Wiring | None
) -> None:
    by_id = {s.sample_id: s for s in samples}
    progress = Progress(len(samples), settings.progress)
    tasks = _tasks(samples, settings, outputs, wiring)
    controller = settings.loop.controller.read_bytes() if settings.loop is not None else None
    try:
        with connect(settings) as client:
            plugin = FmuPlugin(settings.fmu.read_bytes(), digest, controller)
            client.register_plugin(plugin)
            for result in _collect(client, tasks, plugin.name):
                row = _row(by_id[result.sample_id], result, settings.loop is not None)
                store.write_part(settings.out, row, result.series)
                progress.finished(result.status == OK)
    finally:
        progress.close()


def kept_outputs(settings: SweepSettings) -> tuple[str, ...]:
    """The outputs (columns of the loop's table, with `loop`) the series keep; ValueError naming unknown ones."""
    available = COLUMNS[1:] if settings.loop is not None else _all_outputs(settings.fmu)
    unknown = [name for name in settings.outputs if name not in available]
    if unknown:
        what = "columns of the loop's table" if settings.loop is not None else "outputs of the FMU"
        raise ValueError(f"outputs {', '.join(unknown)} are not {what}: choose from {', '.join(available)}")
    return settings.outputs or available


def _record(settings: SweepSettings, outputs: tuple[str, ...], digest: str) -> tuple[dict[str, Any], Wiring | None]:
    """The settings every sample shares, as the folder records them (store.check_settings), and the loop's
    wiring (checked: UsageError, a ValueError)."""
    record: dict[str, Any] = {
        "stop_time": settings.stop_time,
        "step": settings.step,
        "outputs": list(outputs),
        "fmu_sha256": digest,
    }
    if settings.loop is None:
        return record, None
    wiring = settings.loop.spec().wiring
    wires = [f"{c.source}={c.target}" for c in wiring.inputs] + [f"controller.{wiring.torque_from}=pendulum.torque"]
    record["controller_sha256"] = hashlib.sha256(settings.loop.controller.read_bytes()).hexdigest()
    record["connect"] = wires
    record["drive_limit"] = settings.loop.drive_limit
    record["hold"] = settings.loop.hold
    return record, wiring


def run_sweep(samples: list[Sample], settings: SweepSettings) -> pd.DataFrame:
    """Run the samples the output folder does not hold yet; the results table of all `samples`, in order.

    Parameters
    ----------
    samples : from samples.samples (a grid or a table), or with settings.loop from loop_samples.loop_samples.
    settings : shared settings; settings.out is created, or resumed when it holds a sweep with the same ones.

    Returns
    -------
    One row a sample: sample_id, its parameter values, torque, status (ok or error), message, wall_time (s,
    the run on its worker) and the summary figures (figures.Figures). With settings.loop: its values
    (pendulum, controller.NAME, setpoint, disturbance), no torque, and the loop's metrics
    (masters/control/metrics.py METRIC_NAMES) as the figures. The files in settings.out hold the same
    rows and, in series.parquet, each sample's time series (store.read_series).
    """
    outputs = kept_outputs(settings)
    digest = hashlib.sha256(settings.fmu.read_bytes()).hexdigest()
    record, wiring = _record(settings, outputs, digest)
    store.check_settings(settings.out, record)
    done = store.done_ids(settings.out, settings.retry_failed)
    missing = [s for s in samples if s.sample_id not in done]
    if missing:
        both = hashlib.sha256((digest + record.get("controller_sha256", "")).encode()).hexdigest()
        _run(missing, settings, outputs, digest if settings.loop is None else both, wiring)
    table = store.consolidate(settings.out, settings.csv)
    return table.set_index("sample_id").loc[[s.sample_id for s in samples]].reset_index()
