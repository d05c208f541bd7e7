"""Regenerate the README's figure, docs/animation_frame.png, from the README's own command.

    python benchmarks/readme_figures.py [--fmu dist/FemPendulum.fmu] [--work out/readme] [--docs docs] [--quick]

It runs `fem-pendulum run` as README.md's set-up does (README_RUN: the steel pendulum driven by
examples/torque_pulse.csv, --animate with --deformation-scale 1000), with the FMU and the outputs
put where the options say; finds the first impact in the run's CSV (the end of the first
communication step with gap_min < 0) and the first frame of the FMU's field output at or after it;
and saves that frame of the GIF as the PNG. It prints the caption the figure supports, with the
measured time from the impact to the frame.

--quick stops the run at QUICK_STOP_TIME (the frame needs only the first impact; tests/test_animation.py
runs it): the frame is then the same, but its colour scale spans the frames up to there, not all 2 s.
The figure in docs/ is made without --quick.

It lives in benchmarks/ beside speed_vs_error.py, the other script that writes figures into docs/.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# README.md's command, after `fem-pendulum` (tests/test_animation.py checks that the README still says this)
README_RUN = (
    "run --fmu dist/FemPendulum.fmu --torque examples/torque_pulse.csv --out out/run "
    "--animate out/run.gif --deformation-scale 1000"
)
QUICK_STOP_TIME = 0.25  # s: the first impact is at about 0.2 s
FIGURE = "animation_frame.png"


@dataclass(frozen=True)
class AnimationFrame:
    """The figure written, the time of the first impact and of the frame shown (s)."""

    path: Path
    impact_time: float
    frame_time: float

    def caption(self) -> str:
        delay = (self.frame_time - self.impact_time) * 1e3
        return (
            f"A frame of out/run.gif: the steel pendulum {delay:.0f} ms after its first impact, "
            "bending (x 1000), coloured by von Mises stress"
        )


def readme_command(fmu: Path, work: Path, stop_time: float | None = None) -> list[str]:
    """README_RUN as a command: this Python's fem-pendulum, the FMU given, the example torque of this
    repository and the outputs under `work`; a stop time only when given."""
    paths = {
        "dist/FemPendulum.fmu": str(fmu),
        "examples/torque_pulse.csv": str(ROOT / "examples" / "torque_pulse.csv"),
        "out/run": str(work / "run"),
        "out/run.gif": str(work / "run.gif"),
    }
    # the installed command, as the README runs it: `python -m` would put the working folder first on the
    # path, and from a checkout import its sources, not the installed package the FMU was built from
    fem_pendulum = str(Path(sys.executable).parent / "fem-pendulum")
    command = [fem_pendulum, *(paths.get(a, a) for a in README_RUN.split())]
    return command + (["--stop-time", repr(stop_time)] if stop_time is not None else [])


def first_impact(csv: Path) -> float:
    """The end of the first communication step in which the head touched the wall (gap_min < 0), s."""
    data = np.genfromtxt(csv, delimiter=",", names=True)
    touching = np.flatnonzero(data["gap_min"] < 0.0)
    if not len(touching):
        raise RuntimeError(f"{csv}: the pendulum never touched the wall")
    return float(data["time"][touching[0]])


def frame_times(pvd: Path) -> list[float]:
    """The times of the field output's frames, in order (one GIF frame each: masters/animation.py)."""
    return sorted({float(d.get("timestep", "0")) for d in ET.parse(pvd).getroot().iter("DataSet")})


def animation_frame(fmu: Path, work: Path, png: Path, stop_time: float | None = None) -> AnimationFrame:
    """Run the README's command and save the GIF's first frame at or after the first impact as `png`."""
    from PIL import Image

    from fem_pendulum_fmu.fmi.vtk_output import INDEX_NAME

    work.mkdir(parents=True, exist_ok=True)
    run = subprocess.run(readme_command(fmu, work, stop_time), capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"fem-pendulum run failed:\n{run.stderr[-3000:]}")
    impact = first_impact(work / "run.csv")
    times = frame_times(work / "run_fields" / INDEX_NAME)
    index = next(k for k, t in enumerate(times) if t >= impact - 1e-9)
    with Image.open(work / "run.gif") as gif:
        gif.seek(index)
        png.parent.mkdir(parents=True, exist_ok=True)
        gif.convert("RGB").save(png, optimize=True)
    return AnimationFrame(png, impact, times[index])


def coloured_fraction(png: Path, right: float = 0.8) -> float:
    """The share of the pixels in colour (neither white, grey nor black: the stress colours) in the image's
    left `right` of its width: the view, the colour bar at the right left out. The wall is grey, so a frame
    without the pendulum gives 0."""
    from PIL import Image

    with Image.open(png) as image:
        rgb = np.asarray(image.convert("RGB"), dtype=int)
    view = rgb[:, : int(right * rgb.shape[1])]
    return float(np.mean(view.max(axis=2) - view.min(axis=2) > 40))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fmu", type=Path, default=ROOT / "dist" / "FemPendulum.fmu")
    parser.add_argument("--work", type=Path, default=ROOT / "out" / "readme", help="folder of the run's outputs")
    parser.add_argument("--docs", type=Path, default=ROOT / "docs", help="folder the figure goes to")
    parser.add_argument("--quick", action="store_true", help=f"stop the run at {QUICK_STOP_TIME} s")
    args = parser.parse_args(argv)
    frame = animation_frame(args.fmu, args.work, args.docs / FIGURE, QUICK_STOP_TIME if args.quick else None)
    print(
        f"wrote {frame.path}: frame at t = {frame.frame_time:.3f} s, first impact in the step ending at "
        f"{frame.impact_time:.3f} s, {coloured_fraction(frame.path):.1%} of the view in colour"
    )
    print(f"caption: {frame.caption()}")


if __name__ == "__main__":
    main()
