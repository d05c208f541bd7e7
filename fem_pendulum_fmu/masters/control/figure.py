"""The controller loop's figure: set-point and angle, demand and torque, gap, contact force and
impulse, every impact marked (masters/plots.py draws the per-step summaries)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ...physics.swing import rebounds


def wall_impacts(table: Any, band: float = 1e-3) -> np.ndarray:
    """Times of the communication steps in which the pendulum rebounded from the wall (physics/swing.py
    rebounds: omega turns from towards the wall to away from it within the step, the gap below `band`)."""
    return np.asarray(table["time"])[:-1][rebounds(np.asarray(table["omega"]), np.asarray(table["gap"]), band)]


def loop_figure(table: Any, title: str = "controller in the loop with the FE pendulum") -> Any:
    """The figure of a loop's table (masters/control/series.py); red lines at the steps in contact."""
    from ..plots import _pyplot, impact_steps, impacts, plot_contact_force, plot_contact_impulse, plot_gap

    plt = _pyplot()
    t = np.asarray(table["time"])
    names = table.dtype.names if hasattr(table, "dtype") and table.dtype.names else tuple(table)
    fig, ax = plt.subplots(5, 1, figsize=(9, 12), sharex=True)
    ax[0].plot(t, np.degrees(table["setpoint"]), "--", label="set-point")
    ax[0].plot(t, np.degrees(table["theta"]), label="theta")
    ax[0].set_ylabel("angle (deg)")
    ax[0].legend(loc="upper right")
    if "demand" in names:
        ax[1].plot(t, table["demand"], drawstyle="steps-pre", lw=0.8, color="tab:gray", label="controller demand")
    ax[1].plot(t, table["torque"], drawstyle="steps-pre", label="torque at the hinge")
    ax[1].set_ylabel("torque (N.m)")
    ax[1].legend(loc="upper right", fontsize="small")
    plot_gap(ax[2], table)
    rebound = wall_impacts(table)
    ax[2].plot(rebound, np.zeros_like(rebound), "k^", ms=5, label=f"rebound from the wall ({len(rebound)})")
    ax[2].legend(loc="upper right", fontsize="small")
    plot_contact_force(ax[3], table)
    plot_contact_impulse(ax[4], table)
    ax[4].set_xlabel("time (s)")
    records = table.to_records(index=False) if hasattr(table, "to_records") else table
    for ti in t[impact_steps(records)]:
        for a in ax[:2]:
            a.axvline(ti, color="tab:red", lw=0.6, alpha=0.35)
    fig.suptitle(f"{title} ({impacts(records)} impacts, red lines)")
    fig.tight_layout()
    return fig


def plot_loop(table: Any, path: Path, title: str = "controller in the loop with the FE pendulum") -> Path:
    """Write loop_figure to the PNG `path`."""
    from ..plots import save_figure

    return save_figure(loop_figure(table, title), path)
