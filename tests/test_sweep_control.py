"""`fem-pendulum sweep --control`: each sample the controller loop of `closed_loop`, its metrics the figures.

Short by design: rigid fidelity, 0.3 s, one local worker; the commands run in this process
(fem_pendulum_fmu.cli.main, as the console script calls it).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from fem_pendulum_fmu.cli import main
from fem_pendulum_fmu.masters.control.metrics import METRIC_NAMES
from fem_pendulum_fmu.masters.sweep import driver, store
from fem_pendulum_fmu.masters.sweep.loop_run import LoadedLoop, loop_task, run_loop_sample
from fem_pendulum_fmu.masters.sweep.loop_samples import LoopSweep, loop_samples
from fem_pendulum_fmu.testing import closed_loop

STOP = 0.3
KP = (5.0, 10.0, 20.0)
SETPOINTS = ("step:10deg", "step:0.2,0.1")  # the second steps at t = 0.1 s
COMMON = ("--set", "model.fidelity=rigid", "--stop-time", str(STOP), "--workers", "1", "--no-progress")
# a set-point into the wall from rest against it, one internal step allowed: the first doStep is discarded
STOPS_AT_ONCE = {"setpoint": "step:-10deg", "solver.max_substeps": "1"}


def sweep(*args: str) -> int:
    """`fem-pendulum sweep ARGS` in this process: its exit code."""
    try:
        main(["sweep", *args])
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


def reference(fmus, kp: float = 10.0, setpoint: object = "step:10deg", **pendulum):
    """The same loop through the Python API that a test suite calls."""
    return closed_loop(
        "pid",
        controller_parameters={"Kp": kp},
        setpoint=setpoint,
        stop_time=STOP,
        fidelity="rigid",
        pendulum=pendulum or None,
        fmu=fmus[0],
    )


def assert_same_metrics(row: pd.Series, metrics) -> None:
    """Every metric column equals closed_loop's figure (NaN where it measured none); 1e-12 allows for
    nothing but a different order of summation, and measured here: equal, bit for bit."""
    for name in METRIC_NAMES:
        got, want = float(row[name]), metrics.values.get(name, math.nan)
        assert (math.isnan(got) and math.isnan(want)) or got == want or abs(got - want) <= 1e-12, (name, got, want)


@pytest.fixture(scope="module")
def tuned(fmus, tmp_path_factory):
    """Kp x set-point, 3 x 2 samples, through the command line: (folder, results table, exit code)."""
    out = tmp_path_factory.mktemp("tuning") / "out"
    code = sweep(
        "--control", "--fmu", str(fmus[0]), "--param", "controller.Kp=" + ",".join(map(str, KP)),
        "--param", "setpoint=" + ";".join(SETPOINTS), *COMMON, "--out", str(out),
    )  # fmt: skip
    return out, pd.read_parquet(out / store.RESULTS), code


def test_a_kp_sweep_has_the_metrics_and_the_table_of_closed_loop(tuned, fmus):
    out, table, code = tuned
    assert code == 0 and list(table["status"]) == ["ok"] * 6, list(table["message"])
    assert sorted(table.columns) == sorted(
        ["sample_id", "controller.Kp", "setpoint", "model.fidelity", "disturbance", "status", "message", "wall_time"]
        + list(METRIC_NAMES)
    )
    for _, row in table.iterrows():
        result = reference(fmus, row["controller.Kp"], row["setpoint"])
        assert_same_metrics(row, result.metrics)
        series = store.read_series(out, row["sample_id"])
        assert list(series.columns) == list(result.series.columns)
        assert np.array_equal(series.to_numpy(), result.series.to_numpy())  # the same loop, bit for bit
    steps = table[table["setpoint"] == "step:10deg"].set_index("controller.Kp")
    # not vacuous: the gains change the response (overshoot 0.025, 0.571, 4.01 measured) ...
    assert steps.loc[5.0, "overshoot"] < 0.1 < steps.loc[10.0, "overshoot"] < 1.0 < steps.loc[20.0, "overshoot"]
    # ... and a response still outside its band at 0.3 s keeps settling_time = inf in the parquet table
    assert np.isposinf(steps["settling_time"]).all()
    assert (out / "summary.png").stat().st_size > 10_000


def test_a_setpoint_axis_sets_each_samples_setpoint(tuned):
    out, table, _ = tuned
    later = table[table["setpoint"] == "step:0.2,0.1"]
    assert len(later) == 3 and (table["disturbance"] == "0").all()
    for sample_id in later["sample_id"]:
        series = store.read_series(out, sample_id)
        before = series["time"] < 0.1 - 1e-9
        assert (series.loc[before, "setpoint"] == 0.0).all() and (series.loc[~before, "setpoint"] == 0.2).all()
        assert (series["disturbance"] == 0.0).all()


def test_a_table_of_the_same_samples_finds_them_done(tuned, fmus, tmp_path, monkeypatch):
    """The same six samples as a table, 10 deg written in rad and Kp as text: the same ids, so the
    folder already holds them and no cluster starts."""
    out, table, _ = tuned
    rows = [f'{kp:g},"{sp.replace("10deg", repr(math.radians(10)))}"' for kp in KP for sp in SETPOINTS]
    (tmp_path / "samples.csv").write_text("controller.Kp,setpoint\n" + "\n".join(rows) + "\n")

    def refuse(*args):
        raise AssertionError("a sweep whose samples are all done must not start a cluster")

    monkeypatch.setattr(driver, "connect", refuse)
    code = sweep(
        "--control", "--fmu", str(fmus[0]), "--table", str(tmp_path / "samples.csv"), *COMMON, "--out", str(out)
    )
    assert code == 0
    pd.testing.assert_frame_equal(pd.read_parquet(out / store.RESULTS), table, check_exact=True)


@pytest.mark.slow
def test_failed_loop_samples_are_error_rows_and_the_rest_run(fmus, tmp_path, capsys):
    """A table: a loop the pendulum stops at once, an invalid modulus, a set-point from a CSV file
    beside the table (a ramp to 0.1 rad at 0.2 s, held)."""
    (tmp_path / "setpoint.csv").write_text("time,value\n0,0\n0.2,0.1\n")
    (tmp_path / "samples.csv").write_text(
        "setpoint,solver.max_substeps,pendulum.E\n"
        f"{STOPS_AT_ONCE['setpoint']},{STOPS_AT_ONCE['solver.max_substeps']},\n,,-1\nsetpoint.csv,,\n"
    )
    out = tmp_path / "out"
    code = sweep(
        "--control", "--fmu", str(fmus[0]), "--table", str(tmp_path / "samples.csv"), *COMMON, "--out", str(out)
    )
    assert code == 1 and "3 samples: 1 ok, 2 error" in capsys.readouterr().out
    table = pd.read_parquet(out / store.RESULTS)
    by_setpoint = {row["setpoint"]: row for _, row in table.iterrows()}
    csv = str((tmp_path / "setpoint.csv").resolve())
    assert sorted(by_setpoint) == sorted(["step:-10deg", "sine:20deg,0.75", csv])  # no set-point: control's default
    stopped, invalid, ok = by_setpoint["step:-10deg"], by_setpoint["sine:20deg,0.75"], by_setpoint[csv]
    assert stopped["message"].startswith("the pendulum FMU stopped at t = 0 s of 0.3 s: doStep discarded")
    assert "solver.max_substeps = 1" in stopped["message"]
    assert len(store.read_series(out, stopped["sample_id"])) == 1  # the table up to where it stopped: t = 0
    assert invalid["message"] == (
        "invalid parameters: parameter pendulum.E = -1.0 is not allowed: it must be a finite number in (0, inf)"
    )
    assert stopped[list(METRIC_NAMES)].isna().all() and invalid[list(METRIC_NAMES)].isna().all()
    assert ok["status"] == "ok"
    assert_same_metrics(ok, reference(fmus, setpoint=tmp_path / "setpoint.csv").metrics)


def test_reused_instances_compute_what_fresh_ones_do(fmus):
    """What a worker does between samples: after a loop the pendulum stopped (a discarded doStep) and
    one with an invalid value, the kept instances are reset and give closed_loop's table bit for bit, twice."""
    loop = LoopSweep(fmus[1])
    wiring = loop.spec().wiring
    pendulum = {"model.fidelity": "rigid"}
    rows = [{**pendulum, **STOPS_AT_ONCE}, {**pendulum, "pendulum.E": "-1"}]
    rows += [{**pendulum, "controller.Kp": "20", "setpoint": "step:10deg"}]
    chosen = loop_samples(rows, loop)
    loaded = LoadedLoop(fmus[0], fmus[1])
    try:
        results = [
            run_loop_sample(loaded, loop_task(sample, wiring, STOP, 1e-3, loop.drive_limit, ("theta", "torque")))
            for sample in (*chosen, chosen[-1])
        ]
    finally:
        loaded.close()
    assert [r.status for r in results] == ["error", "error", "ok", "ok"], [r.message for r in results]
    assert "stopped at t = 0 s" in results[0].message
    assert results[1].message.startswith("invalid parameters: parameter pendulum.E = -1.0"), results[1].message
    want = reference(fmus, 20.0).series
    for result in results[2:]:
        assert result.series is not None
        for name in ("time", "theta", "torque"):
            assert np.array_equal(result.series[name], want[name].to_numpy()), name


@pytest.mark.parametrize(
    "args, words",
    [
        (
            ["--param", "controller.Kpp=1,2"],
            ["controller.Kpp", "not a parameter of the controller", "Kd, Ki, Kp, u_max"],
        ),
        (["--param", "controller.Kp=5,abc"], ["controller.Kp=abc", "'abc'", "finite number"]),
        (["--param", "setpoint=step:10deg;sine:10deg"], ["setpoint 'sine:10deg'", "sine:A,F takes 2 numbers"]),
        (["--param", "setpoint=step:10deg,step:20deg"], ["step time 'step:20deg'"]),  # ',' is not the separator
        (["--param", "disturbance=0;push:2"], ["disturbance 'push:2'", "unknown form"]),
        (["--param", "controller.Kp=5,10", "--controller-set", "Kp=20"], ["controller.Kp", "both --param axes"]),
        (["--param", "theta0=0.1,0.2", "--torque", "torque.csv"], ["--torque", "comes from the controller"]),
        (["--param", "theta0=0.1,0.2", "--controller", "none.fmu"], ["--controller 'none.fmu'", "not an FMU file"]),
        (["--param", "theta0=0.1,0.2", "--plot", "rebounds"], ["--plot 'rebounds'", "rms_error"]),
    ],
)
def test_bad_loop_sweep_input_is_one_line_and_exit_2(fmus, tmp_path, monkeypatch, capsys, args, words):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "torque.csv").write_text("time,torque\n0,1\n1,1\n")
    assert sweep("--control", "--fmu", str(fmus[0]), *args, "--out", "out") == 2
    error = capsys.readouterr().err
    assert error.startswith("fem-pendulum sweep: error: ") and error.count("\n") == 1, error
    assert all(word in error for word in words), error
    assert not (tmp_path / "out").exists(), "nothing is written before the input is checked"


def test_loop_options_need_control(fmus, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert sweep("--fmu", str(fmus[0]), "--param", "theta0=0.1,0.2", "--setpoint", "step:1", "--out", "o") == 2
    assert "--setpoint: only with --control" in capsys.readouterr().err
