"""PNG plots of simulation results (structured numpy arrays with the FMU's output names)."""

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
    steps = impact_steps(result)
    return int(steps.size and 1 + np.count_nonzero(np.diff(steps) > 1))


def plot_results(result: np.ndarray, path: Path, title: str, extra: dict[str, np.ndarray] | None = None) -> Path:
    """Torque, angle, gap with gap_min, contact force with contact_force_max, and the energy balance
    (E_total - E_0 - W_torque) against time; every impact marked, however short."""
    plt = _pyplot()
    t = result["time"]
    names = result.dtype.names or ()
    fig, axes = plt.subplots(5, 1, figsize=(9, 12), sharex=True)
    if "torque" in names:
        axes[0].plot(t, result["torque"], color="tab:purple")
    axes[0].set_ylabel("torque (N.m)")
    axes[1].plot(t, np.degrees(result["theta"]), label="theta")
    for name, values in (extra or {}).items():
        axes[1].plot(t, values, "--", label=name)
    axes[1].set_ylabel("angle (deg)")
    axes[1].legend(loc="upper right")
    _plot_gap(axes[2], result, names)
    _plot_force(axes[3], result, names)
    balance = result["energy.total"] - result["energy.total"][0] - result["energy.torque_work"]
    axes[4].plot(t, balance)
    axes[4].set_ylabel("E - E0 - W_torque (J)")
    axes[4].set_xlabel("time (s)")
    hit = impact_steps(result)
    for ax in axes[:4]:
        for ti in t[hit]:
            ax.axvline(ti, color="tab:red", lw=0.6, alpha=0.35)
    fig.suptitle(f"{title} ({impacts(result)} impacts, red lines)")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _plot_gap(ax: Any, result: np.ndarray, names: tuple[str, ...]) -> None:
    t = result["time"]
    ax.plot(t, result["gap"] * 1e3, label="gap (sampled)")
    if "gap_min" in names:
        ax.plot(t, result["gap_min"] * 1e3, lw=0.8, label="gap_min (over each step)")
        hit = impact_steps(result)
        ax.plot(t[hit], result["gap_min"][hit] * 1e3, "rv", ms=4, label="contact in the step")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylabel("gap (mm)")
    ax.legend(loc="upper right", fontsize="small")


def _plot_force(ax: Any, result: np.ndarray, names: tuple[str, ...]) -> None:
    t = result["time"]
    if "contact_force_max" in names:
        peak = result["contact_force_max"]
        hit = np.flatnonzero(peak > 0.0)
        ax.vlines(t[hit], 0.0, peak[hit], color="tab:red", lw=1.2, label="contact_force_max (over each step)")
        ax.plot(t[hit], peak[hit], "r^", ms=4)
    ax.plot(t, result["contact_force"], lw=0.8, label="contact_force (sampled)")
    ax.set_ylabel("contact force (N)")
    ax.legend(loc="upper right", fontsize="small")
