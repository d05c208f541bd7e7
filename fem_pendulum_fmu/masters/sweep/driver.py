"""The sweep on Dask's distributed scheduler: a local cluster of worker processes, or a running one.

`run_sweep` is the Python function behind `fem-pendulum sweep`. It reads what
the output folder already holds, submits only the missing samples, keeps each
result as it arrives (store.write_part) and merges them into the tables at
the end. The FMU goes to the workers once, in a worker plugin (worker.py).

A worker process that dies mid-sample (killed, out of memory, a crash in
native code) makes Dask raise KilledWorker for the sample's task; the sample
is then submitted once more, and if that dies too it gets status error with
the reason. The local cluster's scheduler is told not to retry on its own
(distributed.scheduler.allowed-failures = 0), so "once" is exact there; a
running scheduler applies its own allowed-failures first (default 3).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import dask
import pandas as pd
from distributed import Client, KilledWorker, LocalCluster, as_completed

from ..open_loop import read_torque_csv
from . import store
from .progress import Progress
from .run import ERROR, OK, SampleResult, SampleTask
from .samples import Sample
from .worker import FmuPlugin, run_on_worker

ATTEMPTS = 2  # a sample whose worker dies is run once more, then marked


@dataclass(frozen=True)
class SweepSettings:
    """What every sample of a sweep shares, and where and how it runs.

    outputs: the outputs kept in the time series (() = every output of the FMU); the summary figures read
        theta, omega, gap, gap_min, contact_force_max and the energies whatever is kept.
    workers: processes of a local cluster (None = the machine's cores); ignored with `scheduler`.
    scheduler: address of a running Dask scheduler (tcp://host:8786) to use instead of a local cluster.
    retry_failed: run again the samples the folder holds with status error.
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


def _all_outputs(fmu: Path) -> tuple[str, ...]:
    from fmpy import read_model_description

    return tuple(v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "output")


@contextlib.contextmanager
def connect(settings: SweepSettings) -> Iterator[Client]:
    """A client of the running scheduler, or of a local cluster on 127.0.0.1 that is closed afterwards."""
    if settings.scheduler:
        with Client(settings.scheduler) as client:
            yield client
        return
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = LocalCluster(
            n_workers=settings.workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
        )
    with cluster, Client(cluster) as client:
        yield client


def _row(sample: Sample, result: SampleResult) -> dict[str, Any]:
    return {
        "sample_id": sample.sample_id,
        **sample.values,
        "torque": sample.torque,
        "status": result.status,
        "message": result.message,
        "wall_time": result.wall_time,
        **asdict(result.figures),
    }


def _tasks(samples: list[Sample], settings: SweepSettings, outputs: tuple[str, ...]) -> list[SampleTask]:
    torques = {path: read_torque_csv(Path(path)) for path in {s.torque for s in samples} if path}
    return [
        SampleTask(s.sample_id, s.values, torques.get(s.torque), settings.stop_time, settings.step, outputs)
        for s in samples
    ]


def _collect(client: Client, tasks: list[SampleTask], plugin: str) -> Iterator[SampleResult]:
    """Results as they finish; a task whose worker died is submitted again (ATTEMPTS in all)."""
    attempt: dict[Any, tuple[SampleTask, int]] = {}

    def submit(task: SampleTask, number: int) -> Any:
        future = client.submit(run_on_worker, task, plugin, key=f"sample-{task.sample_id}-{number}", pure=False)
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


def _run(samples: list[Sample], settings: SweepSettings, outputs: tuple[str, ...], digest: str) -> None:
    by_id = {s.sample_id: s for s in samples}
    progress = Progress(len(samples), settings.progress)
    try:
        with connect(settings) as client:
            plugin = FmuPlugin(settings.fmu.read_bytes(), digest)
            client.register_plugin(plugin)
            for result in _collect(client, _tasks(samples, settings, outputs), plugin.name):
                store.write_part(settings.out, _row(by_id[result.sample_id], result), result.series)
                progress.finished(result.status == OK)
    finally:
        progress.close()


def run_sweep(samples: list[Sample], settings: SweepSettings) -> pd.DataFrame:
    """Run the samples the output folder does not hold yet; the results table of all `samples`, in order.

    Parameters
    ----------
    samples : from samples.samples (a grid or a table).
    settings : shared settings; settings.out is created, or resumed when it holds a sweep with the same ones.

    Returns
    -------
    One row a sample: sample_id, its parameter values, torque, status (ok or error), message, wall_time (s,
    the run on its worker) and the summary figures (figures.Figures). The files in settings.out hold the same
    rows and, in series.parquet, each sample's time series (store.read_series).
    """
    available = _all_outputs(settings.fmu)
    unknown = [name for name in settings.outputs if name not in available]
    if unknown:
        raise ValueError(f"outputs {', '.join(unknown)} are not outputs of the FMU: choose from {', '.join(available)}")
    outputs = settings.outputs or available
    digest = hashlib.sha256(settings.fmu.read_bytes()).hexdigest()
    store.check_settings(
        settings.out,
        {"stop_time": settings.stop_time, "step": settings.step, "outputs": list(outputs), "fmu_sha256": digest},
    )
    done = store.done_ids(settings.out, settings.retry_failed)
    missing = [s for s in samples if s.sample_id not in done]
    if missing:
        _run(missing, settings, outputs, digest)
    table = store.consolidate(settings.out, settings.csv)
    return table.set_index("sample_id").loc[[s.sample_id for s in samples]].reset_index()
