"""The work-precision benchmark's quick mode: every fidelity's default settings, through the FMU,
against the stored references (benchmarks/references/), on the scenes it is meant for.

It asserts accuracy only (the bounds are in benchmarks/speed_vs_error.py and
docs/notes/speed_vs_error.md), never time: wall times depend on the machine.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import speed_vs_error as bench  # noqa: E402


def test_stored_references_are_small_and_converged():
    total = 0
    for case in bench.SCENES:
        path = bench.REFERENCES / f"{case.name}.npz"
        total += path.stat().st_size
        ref = bench.load_reference(case.name)
        assert ref["time"][-1] == np.float64(round(case.t_end / bench.COMM_STEP) * bench.COMM_STEP)
        assert len(ref["time"]) == round(case.t_end / bench.COMM_STEP) + 1
        finest = ref["meta"]["convergence"][-1]  # the last refinement changes the answer less than the bound
        assert finest["fine"] == ref["meta"]["level"]
        # before the second impact (a check stored without that window compared every sample: stricter)
        assert finest.get("theta_max_early", finest["theta_max"]) <= bench.REFERENCE_AGREEMENT[case.name], case.name
        swing = ref["meta"]["swing_energy"]
        # every reference balances its energy during contact as after it (the deformable wall's, recorded
        # again once its outputs counted the contact as the step form does: 3.7e-6 of the swing)
        assert bench.energy_error(ref, swing) < 1e-4, case.name
        balance = ref["energy.total"][-1] - ref["energy.total"][0] - ref["energy.torque_work"][-1]
        assert abs(balance) < 1e-4 * swing, case.name  # after the impacts every reference balances
    assert total < 1_000_000


@pytest.mark.slow
def test_quick_mode_defaults_are_within_their_bounds(fmus, tmp_path, monkeypatch):
    monkeypatch.setattr(bench, "RUNS", tmp_path)  # the runs' samples: not into the benchmark's folder
    rows = bench.quick_rows(fmus)
    # every fidelity the auto rule gives one of the scenes is checked there; rigid is given none of
    # them (each has a wall, and the steel plate's vibration needs the reduced model), which its own
    # acceptance tests (tests/test_rigid.py) cover instead
    meant = {f for f in bench.available_fidelities() if any(bench.meant_for(f, c) for c in bench.SCENES)}
    assert meant == {"fem", "reduced"}
    assert {r["curve"] for r in rows} == meant
    assert {r["scene"] for r in rows if r["curve"] == "fem"} == {c.name for c in bench.SCENES}
    problems = bench.check_quick(rows)
    assert not problems, problems
