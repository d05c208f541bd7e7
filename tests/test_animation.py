"""fem-pendulum run --animate: an animation made from the FMU's own field output, one
frame per output interval, the deformed pendulum coloured by von Mises stress."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from PIL import Image

from fem_pendulum_fmu.fmi.vtk_output import INDEX_NAME
from fem_pendulum_fmu.masters.animation import drawn_points


def test_run_animate_writes_a_gif_with_one_frame_per_output_interval(fmus, tmp_path):
    fmu, _ = fmus
    out, gif = tmp_path / "run", tmp_path / "run.gif"
    command = [str(Path(sys.executable).parent / "fem-pendulum"), "run", "--fmu", str(fmu), "--stop-time", "0.3"]
    command += ["--set", "model.fidelity=reduced", "--out", str(out), "--animate", str(gif)]
    run = subprocess.run([*command, "--deformation-scale", "1000"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    index = ET.parse(tmp_path / "run_fields" / INDEX_NAME).getroot()  # the FMU's field output, next to --out
    times = [float(d.get("timestep")) for d in index.iter("DataSet")]
    assert len(times) == 31 and np.allclose(np.diff(times), 0.01)  # 0 to 0.3 s every output.vtk_interval
    with Image.open(gif) as image:
        assert image.n_frames == len(times)
    assert f"{len(times)} frames" in run.stdout


def test_the_deformation_scale_magnifies_the_elastic_part_only():
    points = np.array([[0.0, -0.2], [0.01, -0.25]])
    theta = 0.3
    c, s = np.cos(theta), np.sin(theta)
    rotated = points @ np.array([[c, s], [-s, c]])  # R(theta) X
    elastic = np.array([[1e-6, 0.0], [0.0, -2e-6]])
    drawn = drawn_points(points, rotated + elastic - points, theta, 1000.0)
    assert np.allclose(drawn, rotated + 1000.0 * elastic, atol=1e-15)
