"""An animation of the deforming pendulum made from the FMU's own field output (output.vtk_folder).

Each frame of the ParaView series (a .pvd index of .vtu files, fmi/vtk_output.py) is drawn as the
deformed triangles coloured by the nodal von Mises stress, with the wall and the pivot; the title
says the time, the angle, the magnification and how much slower than real time the animation runs
(`pace`). Steel deforms by micrometres, so `deformation_scale` magnifies the elastic part of the
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


def pace(times: list[float], fps: float) -> str:
    """How the animation's time compares with the simulated time: each frame is shown for 1/fps s of real
    time and stands for the median interval between the frames' times ("" for fewer than two frames)."""
    if len(times) < 2:
        return ""
    simulated = float(np.median(np.diff(times)))
    factor = (1.0 / fps) / simulated
    if math.isclose(factor, 1.0, rel_tol=0.01):
        return "real time"
    if factor > 1.0:
        return f"{factor:.3g}x slower than real time"
    return f"{1.0 / factor:.3g}x faster than real time"


def _draw_frame(ax: Any, frame: Frame, scale: float, vmax: float, block: WallBlock | None, speed: str) -> Any:
    """One frame; the time, angle, magnification and pace go in the title, above the view, so that they
    hide nothing (the pivot at the top of the view least of all)."""
    ax.clear()
    if block is not None:
        ax.add_patch(_wall_patch(block))
    image = None
    for k, (points, cells, disp, vm) in enumerate(frame.bodies):
        theta = best_fit_rotation(points, cells, disp) if k == 0 else 0.0
        xy = drawn_points(points, disp, theta, scale)
        image = ax.tripcolor(xy[:, 0], xy[:, 1], cells, vm, shading="gouraud", cmap="viridis", vmin=0.0, vmax=vmax)
    theta = best_fit_rotation(*frame.bodies[0][:3])
    first = f"t = {frame.time:.3f} s, theta = {math.degrees(theta):.2f} deg"
    second = ", ".join(text for text in (f"deformation x {scale:g}" if scale != 1.0 else "", speed) if text)
    ax.set_title(f"{first}\n{second}" if second else first, fontsize="medium")
    ax.plot([0.0], [0.0], "k^", ms=8, zorder=5, label="pivot")
    ax.set_xlim(-0.2, 0.2)
    ax.set_ylim(-0.37, 0.04)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return image


def _wall_patch(block: WallBlock) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle(
        (block.x_min, block.y_min), block.x_max - block.x_min, block.y_max - block.y_min, fc="0.7", ec="0.3", hatch="//"
    )


def animation_figure(frames: list[Frame], deformation_scale: float = 1.0, fps: float = 20) -> tuple[Any, Any]:
    """The animation's figure, showing the first frame, and the function that draws frame i into it."""
    plt = _pyplot()
    vmax = max(float(np.max(vm)) for f in frames for (*_, vm) in f.bodies) or 1.0
    block = WallBlock() if len(frames[0].bodies) == 1 else None
    speed = pace([f.time for f in frames], fps)
    fig, ax = plt.subplots(figsize=(5.2, 4.6))

    def draw(i: int) -> Any:
        return _draw_frame(ax, frames[i], deformation_scale, vmax, block, speed)

    fig.colorbar(draw(0), ax=ax, label="von Mises stress (Pa)")
    fig.tight_layout()
    return fig, draw


def animate(pvd: Path, out: Path, deformation_scale: float = 1.0, fps: int = 20) -> int:
    """Write the animation of a series to `out` (.gif, or .mp4 with ffmpeg); returns the number of frames,
    one per frame of the series, shown at `fps` (20: 5x slower than real time at the default 0.01 s
    interval; each frame says so, `pace`).

    The rigid wall is drawn as its block (scene.WallBlock); a deformable wall is a body of the series."""
    from matplotlib import animation

    frames = read_series(pvd)
    if not frames:
        raise ValueError(f"{pvd}: the series has no frames")
    fig, draw = animation_figure(frames, deformation_scale, fps)
    anim = animation.FuncAnimation(fig, draw, frames=len(frames))
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".mp4":
        writer: Any = animation.FFMpegWriter(fps=fps)
    else:
        writer = animation.PillowWriter(fps=fps)
    anim.save(str(out), writer=writer, dpi=80)
    _pyplot().close(fig)
    return len(frames)
