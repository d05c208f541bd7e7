"""The plots: open loop (fem-pendulum run), the controller loop (fem-pendulum control) and the sweep's
summary; every impact visible, however short (contact_force_max and contact_impulse over each step),
and a unit on every axis."""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fem_pendulum_fmu.masters.control.figure import loop_figure, plot_loop
from fem_pendulum_fmu.masters.control.loop import OUTPUTS, STEP_SUMMARIES, both_halves
from fem_pendulum_fmu.masters.plots import impact_steps, impacts, plot_results, results_figure
from fem_pendulum_fmu.masters.sweep.figures import NEEDED, UNITS, Figures, summarise
from fem_pendulum_fmu.masters.sweep.plot import label, summary_figure
from fem_pendulum_fmu.physics.scene import Scene

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_open_loop_run_records_the_torque_and_marks_every_impact(fmus, tmp_path):
    fmu, _ = fmus
    out = tmp_path / "run"
    command = [str(Path(sys.executable).parent / "fem-pendulum"), "run", "--fmu", str(fmu)]
    command += ["--torque", str(ROOT / "examples" / "torque_pulse.csv"), "--stop-time", "2"]
    run = subprocess.run([*command, "--set", "model.fidelity=rigid", "--out", str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    data = np.genfromtxt(out.with_suffix(".csv"), delimiter=",", names=True)
    assert np.ptp(data["torque"]) == 1.0  # the pulse, recorded for the plot's first panel
    gaps = np.rec.fromarrays([data["gap"], data["gap_min"]], names="gap,gap_min")
    steps = impact_steps(gaps)
    assert impacts(gaps) == 4  # the rigid pendulum's four rebounds in 2 s
    assert "4 impacts" in run.stdout
    # every impact shows in contact_force_max; the 1 ms samples of contact_force miss the first one
    assert np.all(data["contact_force_max"][steps] > 0.0)
    first = steps[: np.argmax(np.diff(steps) > 1) + 1]
    assert np.all(data["contact_force"][first] == 0.0)
    png = out.with_suffix(".png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


def test_impacts_are_runs_of_steps_in_contact():
    gap_min = np.array([1.0, -1.0, -2.0, 1.0, 1.0, -1.0, 1.0, -1.0])
    result = np.rec.fromarrays([np.ones_like(gap_min), gap_min], names="gap,gap_min")
    assert list(impact_steps(result)) == [1, 2, 5, 7] and impacts(result) == 3
    assert impacts(np.rec.fromarrays([np.ones(3), np.ones(3)], names="gap,gap_min")) == 0


def synthetic_run(impacts_at: tuple[int, ...] = (200, 620, 1100)) -> np.ndarray:
    """A 1 ms record of 1.5 s whose impacts (0.3 ms each) all fall between samples: at every sample the
    head is clear of the wall and contact_force is 0; the per-step outputs hold each impact."""
    n = 1501
    t = np.arange(n) * 1e-3
    columns = {name: np.zeros(n) for name in ("contact_force", "contact_force_max", "contact_impulse", "omega")}
    columns["gap"] = np.full(n, 2e-3)
    columns["gap_min"] = np.full(n, 2e-3)
    for k, step in enumerate(impacts_at):
        columns["gap_min"][step] = -5e-5
        columns["contact_force_max"][step] = 4000.0 + 1000.0 * k
        columns["contact_impulse"][step] = 0.8
    columns["theta"] = 0.2 * np.abs(np.cos(2 * np.pi * t))
    columns["energy.total"] = np.full(n, 0.1)
    columns["energy.torque_work"] = np.zeros(n)
    columns["torque"] = np.where((t > 0.1) & (t < 0.3), -1.0, 0.0)
    columns["setpoint"] = 0.3 * np.sin(2 * np.pi * 0.75 * t)
    return np.rec.fromarrays([t, *columns.values()], names=["time", *columns])


def lines(fig, label_start: str) -> list:
    return [line for ax in fig.axes for line in ax.get_lines() if line.get_label().startswith(label_start)]


def peaks(values: np.ndarray) -> list[float]:
    """The largest value of each run of positive values."""
    runs = np.split(values, np.flatnonzero(np.diff(values > 0)) + 1)
    return [float(r.max()) for r in runs if r[0] > 0]


def assert_every_axis_has_a_unit(fig) -> None:
    for ax in fig.axes:
        label = ax.get_ylabel()
        assert re.search(r"\((N\.m|deg|mm|N|N\.s|J|s|m|rad|Pa)\)$", label), label
    assert fig.axes[-1].get_xlabel() == "time (s)"


def assert_every_impact_is_drawn(fig, run: np.ndarray) -> None:
    (force,) = lines(fig, "contact_force_max")
    assert force.get_drawstyle() == "steps-pre"  # the value at t_k is the largest over (t_(k-1), t_k]
    assert peaks(np.asarray(force.get_ydata())) == [4000.0, 5000.0, 6000.0]  # the samples' contact_force: none
    assert "3 impacts" in force.get_label()
    (impulse,) = lines(fig, "contact_impulse")
    assert peaks(np.asarray(impulse.get_ydata())) == [0.8, 0.8, 0.8]
    (sampled,) = lines(fig, "contact_force (sampled)")
    assert not np.any(sampled.get_ydata())


def test_the_open_loop_plot_shows_impacts_between_samples_and_units_on_every_axis(tmp_path):
    run = synthetic_run()
    fig = results_figure(run, "synthetic")
    assert_every_impact_is_drawn(fig, run)
    assert_every_axis_has_a_unit(fig)
    assert "3 impacts" in fig._suptitle.get_text()
    (gap_min,) = lines(fig, "gap_min")
    assert np.min(gap_min.get_ydata()) == -5e-2  # mm
    assert plot_results(run, tmp_path / "run.png", "synthetic").stat().st_size > 20_000


def test_the_control_plot_shows_impacts_between_samples_and_units_on_every_axis(tmp_path):
    run = synthetic_run()
    fig = loop_figure(run)
    assert_every_impact_is_drawn(fig, run)
    assert_every_axis_has_a_unit(fig)
    assert "3 impacts" in fig._suptitle.get_text()
    assert plot_loop(run, tmp_path / "control.png").read_bytes()[:4] == b"\x89PNG"


def test_the_loop_records_what_its_plot_needs():
    assert {"gap_min", "contact_force_max", "contact_impulse"} <= set(OUTPUTS)
    names = [name for name in OUTPUTS if name not in STEP_SUMMARIES] + list(STEP_SUMMARIES)
    assert names == list(OUTPUTS)  # the summaries last, as both_halves reads them
    outputs = [0.1, 0.0, 1e-3, 0.0, 1.0, 0.5, -2e-5, 3000.0, 0.4]
    assert both_halves([-5e-5, 4000.0, 0.3], outputs) == [0.1, 0.0, 1e-3, 0.0, 1.0, 0.5, -5e-5, 4000.0, 0.7]


def test_the_sweep_figures_use_the_largest_force_within_each_step():
    run = synthetic_run()
    figures = summarise(run, Scene())
    assert figures.max_contact_force == 6000.0  # the sampled contact_force is 0 throughout
    assert figures.first_contact_time == 0.2
    assert "contact_force_max" in NEEDED
    assert set(UNITS) == {f.name for f in dataclasses.fields(Figures)}


def test_the_sweep_summary_plot_has_units_on_its_axes():
    table = pd.DataFrame(
        {
            "pendulum.E": [1e9, 1e10, 1e11, 2e11],
            "theta0": [0.1, 0.2, 0.1, 0.2],
            "model.fidelity": ["rigid", "fem", "rigid", "fem"],
            "status": ["ok", "ok", "ok", "error"],
            "max_contact_force": [100.0, 200.0, 300.0, np.nan],
        }
    )
    fig = summary_figure(table, "max_contact_force", "pendulum.E", None)
    assert (fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel()) == ("pendulum.E (Pa)", "max_contact_force (N)")
    fig = summary_figure(table, "max_contact_force", "theta0", "model.fidelity")
    assert (fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel()) == ("theta0 (rad)", "model.fidelity")
    assert fig.axes[1].get_ylabel() == "max_contact_force (N)"  # the colour bar
    assert (
        label("wall_time") == "wall_time (s)" and label("energy_error") == "energy_error (fraction of the swing energy)"
    )
