"""Sweeps on Dask: error rows, resume, bit-identical series, a scheduler with two workers.

Short by design: rigid fidelity, a 3 x 2 grid, 0.3 s of simulated time with a
torque pulse (so the torque input's interpolation is part of what must match).
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from distributed import Client
from fmpy import simulate_fmu

from fem_pendulum_fmu.masters.open_loop import read_torque_csv
from fem_pendulum_fmu.masters.sweep import driver, store
from fem_pendulum_fmu.masters.sweep.driver import SweepSettings, run_sweep
from fem_pendulum_fmu.masters.sweep.figures import Figures
from fem_pendulum_fmu.masters.sweep.run import LoadedFmu, SampleTask, run_sample
from fem_pendulum_fmu.masters.sweep.samples import grid, samples, start_values

ROOT = Path(__file__).resolve().parents[1]
TORQUE = ROOT / "examples" / "torque_pulse.csv"
STOP = 0.3
AXES = [("pendulum.E", [-1.0, 1e6, 2.1e11]), ("theta0", [0.2, 0.35]), ("model.fidelity", ["rigid"])]
FIGURES = [f.name for f in dataclasses.fields(Figures)]


def settings(fmu: Path, out: Path, **kw) -> SweepSettings:
    return SweepSettings(fmu=fmu, out=out, stop_time=STOP, progress=False, **kw)


@pytest.fixture(scope="module")
def swept(fmus, tmp_path_factory):
    """The grid swept in two goes into one folder, as a sweep stopped half-way and started again (first
    3 samples, then all 6), on a local cluster of 2 workers. (fmu, samples, folder, table, ids each go ran)."""
    fmu = fmus[0]
    chosen = samples(grid(AXES), TORQUE)
    out = tmp_path_factory.mktemp("sweep")
    ran: list[list[str]] = []
    real_run = driver._run

    def recording_run(todo, *args):
        ran.append([s.sample_id for s in todo])
        return real_run(todo, *args)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(driver, "_run", recording_run)
        run_sweep(chosen[:3], settings(fmu, out, workers=2))
        table = run_sweep(chosen, settings(fmu, out, workers=2))
    return fmu, chosen, out, table, ran


@pytest.mark.slow
def test_invalid_value_gives_error_rows_naming_it_and_the_rest_run(swept):
    _, chosen, _, table, ran = swept
    assert list(table["sample_id"]) == [s.sample_id for s in chosen]
    assert (table["status"] == "ok").sum() == 4 and (table["status"] == "error").sum() == 2
    errors = table[table["status"] == "error"]
    assert (errors["pendulum.E"] == -1.0).all()
    assert errors["message"].str.contains("parameter pendulum.E = -1.0 is not allowed").all()
    ok = table[table["status"] == "ok"]
    assert (ok["message"] == "").all() and ok["first_contact_time"].notna().all()
    # the rigid fidelity ignores E, so rows that share theta0 agree bit for bit; the release angle changes
    # when the head reaches the wall (0.182 s from 0.2 rad, 0.196 s from 0.35 rad, measured)
    for _, same in ok.groupby("theta0"):
        assert len(same) == 2 and same[FIGURES].nunique(dropna=False).max() == 1
    assert ok.groupby("theta0")["first_contact_time"].first().diff().iloc[-1] > 0.005
    # the second go ran exactly the 3 samples the first had not
    assert ran == [[s.sample_id for s in chosen[:3]], [s.sample_id for s in chosen[3:]]]


@pytest.mark.slow
def test_resumed_sweep_runs_nothing_new(swept, monkeypatch):
    fmu, chosen, out, table, _ = swept

    def refuse(*args):
        raise AssertionError("a sweep whose samples are all done must not start a cluster")

    monkeypatch.setattr(driver, "connect", refuse)
    again = run_sweep(chosen, settings(fmu, out, workers=2))
    pd.testing.assert_frame_equal(again, table, check_exact=True)  # wall_time too: no row was run again
    assert not (out / store.PARTS).exists()


def direct(fmu: Path, values: dict) -> np.ndarray:
    """The sample as a user runs it alone: fmpy's simulate_fmu on the FMU file."""
    return simulate_fmu(
        str(fmu), stop_time=STOP, output_interval=1e-3, start_values=start_values(values), input=read_torque_csv(TORQUE)
    )


def assert_same_series(frame: pd.DataFrame, reference: np.ndarray) -> None:
    assert sorted(frame.columns) == sorted(reference.dtype.names)
    for name in frame.columns:
        assert np.array_equal(frame[name].to_numpy(), reference[name]), name


@pytest.mark.slow
def test_series_equals_a_direct_fmpy_run_bit_for_bit(swept):
    fmu, chosen, out, table, _ = swept
    ok = [s for s in chosen if table.set_index("sample_id").loc[s.sample_id, "status"] == "ok"]
    for sample in ok:
        assert_same_series(store.read_series(out, sample.sample_id), direct(fmu, sample.values))
    # what a worker does between samples: one instance reused (fmi2Reset) after a refused initialisation;
    # a negative control too: the two theta0 values differ, so equality above is not vacuous
    loaded = LoadedFmu(fmu)
    try:
        bad, good = chosen[0], ok[0]
        outputs = tuple(store.read_series(out, good.sample_id).columns[1:])
        for sample in (bad, good, good):
            task = SampleTask(sample.sample_id, sample.values, read_torque_csv(TORQUE), STOP, 1e-3, outputs)
            result = run_sample(loaded, task)
        assert result.status == "ok"
        assert_same_series(pd.DataFrame(result.series), direct(fmu, good.values))
        assert not np.array_equal(result.series["theta"], direct(fmu, ok[-1].values)["theta"])
    finally:
        loaded.close()


def _dask(*args: str, log: Path) -> subprocess.Popen:
    with open(log, "w") as handle:
        return subprocess.Popen([str(Path(sys.executable).parent / "dask"), *args], stdout=handle, stderr=handle)


@pytest.mark.slow
def test_same_table_through_a_scheduler_and_two_workers(swept, tmp_path):
    fmu, chosen, _, table, _ = swept
    file = tmp_path / "scheduler.json"
    procs = [
        _dask(
            "scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            "0",
            "--no-dashboard",
            "--scheduler-file",
            str(file),
            log=tmp_path / "scheduler.log",
        )
    ]
    try:
        deadline = time.monotonic() + 60
        while not file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        procs += [
            _dask(
                "worker",
                "--scheduler-file",
                str(file),
                "--host",
                "127.0.0.1",
                "--nthreads",
                "1",
                "--no-dashboard",
                "--local-directory",
                str(tmp_path / f"w{i}"),
                log=tmp_path / f"w{i}.log",
            )
            for i in range(2)
        ]
        with Client(scheduler_file=str(file)) as client:
            client.wait_for_workers(2, timeout=60)
            assert all(info["host"] == "127.0.0.1" for info in client.scheduler_info()["workers"].values())
            on_cluster = run_sweep(chosen, settings(fmu, tmp_path / "out", scheduler=client.scheduler.address))
            client.shutdown()  # scheduler and workers close themselves
        codes = [proc.wait(timeout=60) for proc in procs]
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.terminate()
                proc.wait(timeout=30)
    pd.testing.assert_frame_equal(
        on_cluster.drop(columns="wall_time"), table.drop(columns="wall_time"), check_exact=True
    )
    assert codes == [0, 0, 0], [(tmp_path / n).read_text()[-2000:] for n in ("scheduler.log", "w0.log", "w1.log")]
