"""Field output: output.vtk_folder makes the FMU write a ParaView time series.

A 0.3 s steel fem run through fmpy (1 ms steps): one frame per output.vtk_interval = 0.01 s (t = 0
to 0.3 s, through the first impact at 0.24 s), .vtu files meshio opens, and at each frame the
best-fit rotation of the points' displacement equals the theta output within 1e-6 rad. theta is
the FE model's mass-weighted best-fit rotation of the continuum; the files hold the vertex values,
so the check fits them with area weights (uniform density): the two fits differ only through the
elastic part of the displacement, measured 1.9e-7 rad at most in this run.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest
from fmu_runner import col, run_schedule

from fem_pendulum_fmu.fmi.vtk_output import INDEX_NAME
from fem_pendulum_fmu.physics.fields import best_fit_rotation

DT = 1e-3
STEPS = 300


def series(folder):
    """[(time, file name, part)] of the .pvd index."""
    root = ET.parse(folder / INDEX_NAME).getroot()
    return [(float(d.get("timestep")), d.get("file"), int(d.get("part"))) for d in root.iter("DataSet")]


@pytest.mark.parametrize("fidelity", ["fem", "rigid"])
def test_the_fmu_writes_a_paraview_series_whose_rotation_is_theta(fmus, tmp_path, fidelity):
    fmu, _ = fmus
    folder = tmp_path / "fields"
    params = {"model.fidelity": fidelity, "output.vtk_folder": str(folder)}
    run = run_schedule(str(fmu), params, [(DT, 0.0)] * STEPS)[0]
    frames = series(folder)
    times = np.array([t for t, _, _ in frames])
    assert times == pytest.approx(np.arange(31) * 0.01, abs=1e-9)  # t = 0, 0.01, ..., 0.3 s
    assert {part for _, _, part in frames} == {0}  # the pendulum only: the rigid wall has no mesh
    assert col(run, "gap_min").min() < 0.0  # the series spans an impact
    theta = col(run, "theta")
    errors = []
    for t, name, _ in frames:
        mesh = meshio.read(folder / name)
        cells = mesh.cells_dict["triangle"]
        data = mesh.point_data
        assert set(data) == {"displacement", "velocity", "von_mises"}
        rotation = best_fit_rotation(mesh.points[:, :2], cells, data["displacement"][:, :2])
        errors.append(abs(rotation - theta[round(t / DT)]))
    assert max(errors) < 1e-6
    last = meshio.read(folder / frames[-1][1]).point_data["von_mises"]
    assert (last.max() > 1e5) if fidelity == "fem" else (last.max() == 0.0)  # a rigid body has no stress
