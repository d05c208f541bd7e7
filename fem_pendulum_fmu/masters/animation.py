"""An animation of the deforming pendulum made from the FMU's own field output (output.vtk_folder).

Each frame of the ParaView series (a .pvd index of .vtu files, fmi/vtk_output.py) is drawn as the
deformed triangles coloured by the nodal von Mises stress, with the wall and the time and angle in
the corner. Steel deforms by micrometres, so `deformation_scale` magnifies the elastic part of the
displacement: the points are drawn at R(theta) X + scale (x - R(theta) X), theta the frame's
best-fit rotation about the pivot, so the swing itself is never exaggerated. GIF through Pillow;
MP4 when the path ends in .mp4 and ffmpeg is present.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..physics.fields import best_fit_rotation
from ..physics.scene import WallBlock
from .plots import _pyplot


@dataclass
class Frame:
    """One time of the series: per body (pendulum first), reference points, triangles, displacement, stress."""

    time: float
    bodies: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]


def read_series(pvd: Path) -> list[Frame]:
    """The frames of a .pvd index, in time order (meshio reads the .vtu files)."""
    import meshio  # type: ignore[import-untyped]

    pvd = Path(pvd)
    by_time: dict[float, list[tuple[int, str]]] = {}
    for ds in ET.parse(pvd).getroot().iter("DataSet"):
        by_time.setdefault(float(ds.get("timestep", "0")), []).append((int(ds.get("part", "0")), ds.get("file", "")))
    frames = []
    for t in sorted(by_time):
        bodies = []
        for _, name in sorted(by_time[t]):
            mesh = meshio.read(pvd.parent / name)
            data = mesh.point_data
            bodies.append(
                (
                    mesh.points[:, :2],
                    mesh.cells_dict["triangle"],
                    data["displacement"][:, :2],
                    np.ravel(data["von_mises"]),
                )
            )
        frames.append(Frame(t, bodies))
    return frames


def drawn_points(points: np.ndarray, displacement: np.ndarray, theta: float, scale: float) -> np.ndarray:
    """R(theta) X + scale (X + u - R(theta) X): the elastic part magnified by `scale`."""
    c, s = math.cos(theta), math.sin(theta)
    rigid = np.column_stack([c * points[:, 0] - s * points[:, 1], s * points[:, 0] + c * points[:, 1]])
    return rigid + scale * (points + displacement - rigid)


def _draw_frame(ax: Any, frame: Frame, scale: float, vmax: float, block: WallBlock | None) -> Any:
    ax.clear()
    if block is not None:
        ax.add_patch(_wall_patch(block))
    image = None
    for k, (points, cells, disp, vm) in enumerate(frame.bodies):
        theta = best_fit_rotation(points, cells, disp) if k == 0 else 0.0
        xy = drawn_points(points, disp, theta, scale)
        image = ax.tripcolor(xy[:, 0], xy[:, 1], cells, vm, shading="gouraud", cmap="viridis", vmin=0.0, vmax=vmax)
    theta = best_fit_rotation(*frame.bodies[0][:3])
    label = f"t = {frame.time:.3f} s\ntheta = {math.degrees(theta):.2f} deg"
    if scale != 1.0:
        label += f"\ndeformation x {scale:g}"
    ax.text(0.02, 0.98, label, transform=ax.transAxes, va="top", family="monospace")
    ax.plot([0.0], [0.0], "k^", ms=8)  # the pivot
    ax.set_xlim(-0.2, 0.2)
    ax.set_ylim(-0.37, 0.03)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return image


def _wall_patch(block: WallBlock) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle(
        (block.x_min, block.y_min), block.x_max - block.x_min, block.y_max - block.y_min, fc="0.7", ec="0.3", hatch="//"
    )


def animate(pvd: Path, out: Path, deformation_scale: float = 1.0, fps: int = 20) -> int:
    """Write the animation of a series to `out` (.gif, or .mp4 with ffmpeg); returns the number of frames,
    one per frame of the series, shown at `fps` (20: slow motion at the default 0.01 s interval).

    The rigid wall is drawn as its block (scene.WallBlock); a deformable wall is a body of the series."""
    from matplotlib import animation

    frames = read_series(pvd)
    if not frames:
        raise ValueError(f"{pvd}: the series has no frames")
    plt = _pyplot()
    vmax = max(float(np.max(vm)) for f in frames for (*_, vm) in f.bodies) or 1.0
    block = WallBlock() if len(frames[0].bodies) == 1 else None
    fig, ax = plt.subplots(figsize=(5.2, 4.4))
    image = _draw_frame(ax, frames[0], deformation_scale, vmax, block)
    fig.colorbar(image, ax=ax, label="von Mises stress (Pa)")
    fig.tight_layout()
    anim = animation.FuncAnimation(
        fig, lambda i: _draw_frame(ax, frames[i], deformation_scale, vmax, block), frames=len(frames)
    )
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".mp4":
        writer: Any = animation.FFMpegWriter(fps=fps)
    else:
        writer = animation.PillowWriter(fps=fps)
    anim.save(str(out), writer=writer, dpi=80)
    plt.close(fig)
    return len(frames)
