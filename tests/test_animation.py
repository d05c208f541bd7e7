"""fem-pendulum run --animate: an animation made from the FMU's own field output, one
frame per output interval, the deformed pendulum coloured by von Mises stress."""

from __future__ import annotations

import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from fem_pendulum_fmu.fmi.vtk_output import INDEX_NAME
from fem_pendulum_fmu.masters.animation import Frame, animation_figure, drawn_points, pace

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import readme_figures as figures  # noqa: E402


@pytest.mark.slow
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


def synthetic_frames(interval: float = 0.01, count: int = 3) -> list[Frame]:
    """A rectangle hanging from the pivot, two triangles, at rest: frames `interval` apart."""
    points = np.array([[-0.01, 0.0], [0.01, 0.0], [0.01, -0.25], [-0.01, -0.25]])
    cells = np.array([[0, 1, 2], [0, 2, 3]])
    body = (points, cells, np.zeros_like(points), np.array([1e6, 1e6, 2e7, 2e7]))
    return [Frame(k * interval, [body]) for k in range(count)]


def test_the_pace_is_computed_from_the_frame_rate_and_the_simulated_time_per_frame():
    assert pace([0.0, 0.01, 0.02], 20) == "5x slower than real time"  # 1/20 s shown per 0.01 s simulated
    assert pace([0.0, 0.002, 0.004], 20) == "25x slower than real time"
    assert pace([0.0, 0.1, 0.2], 20) == "2x faster than real time"
    assert pace([0.0, 0.05], 20) == "real time" and pace([0.0], 20) == ""


def test_each_frame_states_its_pace_and_the_pivot_stays_visible():
    fig, draw = animation_figure(synthetic_frames(), deformation_scale=1000.0, fps=20)
    draw(1)
    ax = fig.axes[0]
    assert ax.get_title() == "t = 0.010 s, theta = 0.00 deg\ndeformation x 1000, 5x slower than real time"
    fig.canvas.draw()
    pivot = ax.transData.transform((0.0, 0.0))
    box = ax.get_window_extent()
    assert box.x0 < pivot[0] < box.x1 and box.y0 + 10 < pivot[1] < box.y1 - 10  # inside the view, not at its edge
    for text in [*ax.texts, ax.title]:  # no text over the pivot
        assert not text.get_window_extent().expanded(1.0, 1.0).padded(6).contains(*pivot), text.get_text()
    rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3]
    x, y = int(round(pivot[0])), int(round(rgb.shape[0] - pivot[1]))
    assert rgb[y - 2 : y + 3, x - 2 : x + 3].max() < 60  # the black marker is drawn there, on top


@pytest.mark.slow
def test_the_readme_figure_is_a_frame_4_ms_after_the_first_impact(fmus, tmp_path):
    readme = (ROOT / "README.md").read_text()
    assert figures.README_RUN in readme  # the script runs the README's command
    (caption,) = re.findall(r"!\[(A frame of out/run\.gif[^\]]*)\]\(docs/animation_frame\.png\)", readme)
    frame = figures.animation_frame(fmus[0], tmp_path, tmp_path / "frame.png", figures.QUICK_STOP_TIME)
    assert frame.caption() == caption  # the steel pendulum 4 ms after its first impact, bending (x 1000)
    with Image.open(tmp_path / "run.gif") as gif, Image.open(frame.path) as png:
        assert png.size == gif.size == (416, 368)
    with Image.open(ROOT / "docs" / "animation_frame.png") as stored:
        assert stored.size == (416, 368)  # the figure in docs/ is one of these frames too
    for path in (frame.path, ROOT / "docs" / "animation_frame.png"):
        assert 0.03 < figures.coloured_fraction(path) < 0.2  # the stressed pendulum: about 5 % of the view
