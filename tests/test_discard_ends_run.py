"""A step the FMU cannot complete and no shorter step can avoid (the nonlinear solve failed down to
the smallest internal step) is a Discard that says so in the host's log, also without debug logging,
and answers fmi2Terminated = true until a successful step, fmi2SetFMUstate or fmi2Reset
(fmi/slave.py `cannot_continue`, fmi/shim/fmi2_functions.c): fmpy's command line, which retries a
Discard for as long as fmi2Terminated is false, then stops there instead of retrying for ever.

The failing scene: the soft pendulum on a coarse mesh under -20 N.m, whose hinge elements turn inside
out within the first 0.5 ms (measured: the Discard comes at t = 0, internal time 4.2e-4 s, 1.8 s in
all for fmpy's command line).
"""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import fmi2_raw
import in_child

MODULE = Path(__file__).stem
FAILING = {
    "theta0": 0.2,
    "pendulum.E": 1e6,
    "pendulum.nu": 0.45,
    "pendulum.rho": 1000.0,
    "contact.stiffness": 5e9,
    "model.mesh_size": 0.05,
    "model.order": 2,
}
TORQUE = -20.0  # N.m
TIMEOUT = 300  # s: the run takes 2 s; a master that retried for ever would hit this instead


def test_fmpy_command_line_stops_at_the_discard_and_shows_why(fmus, tmp_path):
    (tmp_path / "torque.csv").write_text(f"time,torque\n0.0,{TORQUE}\n1.0,{TORQUE}\n")
    values = [str(word) for pair in FAILING.items() for word in pair]
    fmpy = Path(sys.executable).parent / "fmpy"
    run = subprocess.run(
        [str(fmpy), "simulate", str(fmus[0]), "--input-file", "torque.csv", "--stop-time", "1"]
        + ["--start-values", *values, "--output-file", "out.csv"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert run.returncode == 0, run.stderr[-2000:]  # fmpy's own choice for a run that ends at a Discard
    assert "[DISCARD]" in run.stdout and "smallest step" in run.stdout and "cannot help" in run.stdout, run.stdout
    with open(tmp_path / "out.csv") as f:
        times = [float(row["time"]) for row in csv.DictReader(f)]
    assert times[-1] < 0.01  # the data end where the FMU stopped, far before the stop time of 1 s


def statuses_around_the_discard(path: str) -> dict:
    """The statuses of one instance: a step, a saved state, the unrecoverable Discard, then after
    fmi2SetFMUstate, after the Discard again and after fmi2Reset."""
    fmu = fmi2_raw.Fmu(path)
    inst = fmi2_raw.Instance(fmu, "inst", logging_on=False)
    seen: dict = {"start": [inst.setup(), inst.enter(), inst.set_named(**FAILING), inst.exit()]}
    seen["first step"] = inst.do_step(0.0, 1e-4)  # at no torque the step is fine
    _, state = inst.get_state()
    terminated = lambda: inst.status("Boolean", fmi2_raw.TERMINATED)  # noqa: E731
    seen["before"] = terminated()
    seen["discard"] = [inst.set_named(torque=TORQUE), inst.do_step(1e-4, 1e-3)]
    seen["after discard"] = terminated()
    seen["logged"] = [m.status for m in inst.messages if "cannot help" in m.text]
    seen["restored"] = [inst.set_state(state), *terminated()]
    seen["again"] = [inst.set_named(torque=TORQUE), inst.do_step(1e-4, 1e-3), *terminated()]
    seen["reset"] = [inst.reset(), inst.setup(), inst.enter(), inst.exit(), *terminated()]
    inst.free()
    return seen


def test_terminated_is_true_after_the_discard_only_until_a_restore_or_reset(fmus):
    run = subprocess.run(
        in_child.command(MODULE, "statuses_around_the_discard", str(fmus[0])),
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    seen = in_child.result(run.stdout)
    assert seen["start"] == [0, 0, 0, 0] and seen["first step"] == 0, seen
    ok, discard, false, true = 0, 2, 0, 1
    assert seen["before"] == [ok, false], seen
    assert seen["discard"] == [ok, discard] and seen["after discard"] == [ok, true], seen
    assert seen["logged"] == [discard], seen  # logged once, with debug logging off
    assert seen["restored"] == [ok, ok, false], seen
    assert seen["again"] == [ok, discard, ok, true], seen
    assert seen["reset"] == [ok, ok, ok, ok, ok, false], seen  # the status is asked for in stepComplete


def test_a_step_discarded_twice_running_ends_fmpys_command_line(fmus, tmp_path):
    """A Discard a shorter step would avoid (more internal steps than solver.max_substeps) leaves
    fmi2Terminated false, so fmpy repeats the same step; the FMU is deterministic, so the repeat is
    discarded too, and then fmi2Terminated is true and fmpy's loop ends (measured: 2 s)."""
    fmpy = Path(sys.executable).parent / "fmpy"
    values = ["model.fidelity", "2", "solver.max_substeps", "1", "theta0", "0.25"]
    run = subprocess.run(
        [str(fmpy), "simulate", str(fmus[0]), "--stop-time", "0.1", "--output-interval", "0.01"]
        + ["--start-values", *values, "--output-file", "out.csv"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    discards = [line for line in run.stdout.splitlines() if line.startswith("[DISCARD]")]
    assert len(discards) == 2, run.stdout  # the step, then its one repeat
    assert "max_substeps" in discards[0] and "the same step was discarded before" in discards[1], discards
