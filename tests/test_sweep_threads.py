"""The threads a local sweep's workers run with: one per library unless the environment asks for more.

Asked inside a worker of the cluster `run_sweep` starts (driver.connect; the controller-loop sweep
uses the same one): the variables the worker process sees, the thread pools its libraries report
(threadpoolctl, once numpy, scipy and ngsolve are loaded as a sample loads them) and the threads
of an NGSolve TaskManager started there without SetNumThreads (NGS_NUM_THREADS; a sample's own
is its model.threads).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

from fem_pendulum_fmu.masters.sweep import driver
from fem_pendulum_fmu.masters.sweep.driver import SweepSettings, connect


def worker_threads() -> dict[str, Any]:
    """In a worker: the ONE_THREAD variables, each loaded library's threads, an NGSolve TaskManager's threads."""
    import ngsolve
    import scipy.linalg  # noqa: F401  (its own OpenBLAS)
    from threadpoolctl import threadpool_info

    import fem_pendulum_fmu.physics.fem.model  # noqa: F401  (what a fem sample loads)

    with ngsolve.TaskManager():
        task_manager = ngsolve.GetNumThreads()
    return {
        "environ": {name: os.environ.get(name) for name in driver.ONE_THREAD},
        "pools": {f"{pool['internal_api']} {pool['filepath']}": pool["num_threads"] for pool in threadpool_info()},
        "task_manager": task_manager,
    }


def on_worker() -> dict[str, Any]:
    with connect(SweepSettings(fmu=Path(), out=Path(), workers=1, progress=False)) as client:
        (found,) = client.run(worker_threads).values()
    return found


@pytest.fixture
def no_thread_settings(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in driver.ONE_THREAD:
        monkeypatch.delenv(name, raising=False)


def test_workers_run_every_library_on_one_thread(no_thread_settings: None) -> None:
    found = on_worker()
    assert found["environ"] == dict.fromkeys(driver.ONE_THREAD, "1")
    assert any(name.startswith("openblas ") for name in found["pools"]), found["pools"]
    assert set(found["pools"].values()) == {1}, found["pools"]
    assert found["task_manager"] == 1
    # this process's environment as it was: Dask's nanny sets the workers' variables here too
    assert [name for name in driver.ONE_THREAD if name in os.environ] == []


def test_a_count_the_environment_sets_is_kept(no_thread_settings: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    monkeypatch.setenv("NGS_NUM_THREADS", "2")
    found = on_worker()
    assert found["environ"] == {
        **dict.fromkeys(driver.ONE_THREAD, "1"),
        "OPENBLAS_NUM_THREADS": "2",
        "NGS_NUM_THREADS": "2",
    }
    openblas = {name: n for name, n in found["pools"].items() if name.startswith("openblas ")}
    assert set(openblas.values()) == {min(2, os.cpu_count() or 1)}, found["pools"]  # OpenBLAS takes at most the cores
    assert found["task_manager"] == 2
    assert os.environ["OPENBLAS_NUM_THREADS"] == "2"
    assert "OMP_NUM_THREADS" not in os.environ
