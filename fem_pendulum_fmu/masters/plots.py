"""PNG plots of simulation results (structured numpy arrays with the FMU's output names).

An impact of the steel head lasts about 0.3 ms and falls between 1 ms communication points, so
the sampled outputs (gap, contact_force) miss most of it. The FMU also outputs what happened within
each doStep: gap_min (smallest gap), contact_force_max (largest force) and contact_impulse (the
impulse). The plots draw those as steps over the communication step they describe (the value at
t_k covers t_(k-1) to t_k), so every impact shows, however short, and the sampled values beside them.
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np


def _pyplot() -> ModuleType:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def impact_steps(result: np.ndarray) -> np.ndarray:
    """Indices of the samples whose communication step saw the head in contact with the wall: gap_min < 0
    (an impact lasts ~0.3 ms for steel and falls between 1 ms samples), else the sampled gap < 0."""
    names = result.dtype.names or ()
    gap = result["gap_min"] if "gap_min" in names else result["gap"]
    return np.flatnonzero(gap < 0.0)


def impacts(result: np.ndarray) -> int:
    """Number of impacts: runs of consecutive samples in contact."""
    contact = np.zeros(len(result), dtype=bool)
    contact[impact_steps(result)] = True
    return runs(contact)


def results_figure(result: np.ndarray, title: str, extra: dict[str, np.ndarray] | None = None) -> Any:
    """The open-loop figure: torque, angle, gap with gap_min, contact force with contact_force_max,
    contact_impulse and the energy balance (E_total - E_0 - W_torque) against time; every impact
    marked, however short."""
    plt = _pyplot()
    t = result["time"]
    names = result.dtype.names or ()
    fig, axes = plt.subplots(6, 1, figsize=(9, 13.5), sharex=True)
    if "torque" in names:
        axes[0].plot(t, result["torque"], color="tab:purple")
    axes[0].set_ylabel("torque (N.m)")
    axes[1].plot(t, np.degrees(result["theta"]), label="theta")
    for name, values in (extra or {}).items():
        axes[1].plot(t, values, "--", label=name)
    axes[1].set_ylabel("angle (deg)")
    axes[1].legend(loc="upper right")
    plot_gap(axes[2], result)
    plot_contact_force(axes[3], result)
    plot_contact_impulse(axes[4], result)
    balance = result["energy.total"] - result["energy.total"][0] - result["energy.torque_work"]
    axes[5].plot(t, balance)
    axes[5].set_ylabel("E - E0 - W_torque (J)")
    axes[5].set_xlabel("time (s)")
    hit = impact_steps(result)
    for ax in axes[:2]:
        for ti in t[hit]:
            ax.axvline(ti, color="tab:red", lw=0.6, alpha=0.35)
    fig.suptitle(f"{title} ({impacts(result)} impacts, red lines)")
    fig.tight_layout()
    return fig


def plot_results(result: np.ndarray, path: Path, title: str, extra: dict[str, np.ndarray] | None = None) -> Path:
    """Write results_figure to the PNG `path`."""
    return save_figure(results_figure(result, title, extra), path)


def save_figure(fig: Any, path: Path) -> Path:
    """Save a figure as a PNG (its folder made if missing) and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    _pyplot().close(fig)
    return path


def _per_step(ax: Any, t: np.ndarray, values: np.ndarray, **style: Any) -> Any:
    """A value that describes each communication step, drawn over that step (steps-pre)."""
    return ax.plot(t, values, drawstyle="steps-pre", **style)[0]


def plot_gap(ax: Any, result: np.ndarray) -> None:
    """The sampled gap, and gap_min over each step with its contacts marked, in mm."""
    t = result["time"]
    names = result.dtype.names or ()
    ax.plot(t, result["gap"] * 1e3, label="gap (sampled)")
    if "gap_min" in names:
        _per_step(ax, t, result["gap_min"] * 1e3, lw=0.8, label="gap_min (smallest in each step)")
        hit = impact_steps(result)
        ax.plot(t[hit], result["gap_min"][hit] * 1e3, "rv", ms=4, label="contact in the step")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylabel("gap (mm)")
    ax.legend(loc="upper right", fontsize="small")


def plot_contact_force(ax: Any, result: np.ndarray) -> None:
    """contact_force_max over each step (every impact) and the sampled contact_force, in N."""
    t = result["time"]
    if "contact_force_max" in (result.dtype.names or ()):
        peak = result["contact_force_max"]
        label = f"contact_force_max (largest in each step): {runs(peak > 0.0)} impacts"
        _per_step(ax, t, peak, color="tab:red", lw=1.0, label=label)
    ax.plot(t, result["contact_force"], ":", color="tab:blue", lw=1.0, label="contact_force (sampled)")
    ax.set_ylabel("contact force (N)")
    ax.legend(loc="upper right", fontsize="small")


def plot_contact_impulse(ax: Any, result: np.ndarray) -> None:
    """contact_impulse over each step, in N.s (the panel says so when the result does not hold it)."""
    ax.set_ylabel("contact impulse\nin each step (N.s)")
    if "contact_impulse" not in (result.dtype.names or ()):
        ax.text(0.5, 0.5, "contact_impulse not recorded", transform=ax.transAxes, ha="center", va="center")
        return
    impulse = result["contact_impulse"]
    label = f"contact_impulse: {impulse.sum():.3g} N.s in all"
    _per_step(ax, result["time"], impulse, color="tab:green", lw=1.0, label=label)
    ax.legend(loc="upper right", fontsize="small")


def runs(mask: np.ndarray) -> int:
    """Number of runs of consecutive True values."""
    steps = np.flatnonzero(mask)
    return int(steps.size and 1 + np.count_nonzero(np.diff(steps) > 1))
