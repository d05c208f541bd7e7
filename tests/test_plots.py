"""The open-loop plot (fem-pendulum run): torque, angle, gap with gap_min, contact force with
contact_force_max and the energy balance; every impact visible, however short."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

from fem_pendulum_fmu.masters.plots import impact_steps, impacts

ROOT = Path(__file__).resolve().parents[1]


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
