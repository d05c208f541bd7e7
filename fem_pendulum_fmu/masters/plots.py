"""PNG plots of simulation results (structured numpy arrays with the FMU's output names)."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import numpy as np


def _pyplot() -> ModuleType:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_results(result: np.ndarray, path: Path, title: str, extra: dict[str, np.ndarray] | None = None) -> Path:
    """Angle, gap, contact force and energy balance (E_total - E_0 - W_torque) against time."""
    plt = _pyplot()
    t = result["time"]
    fig, axes = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    axes[0].plot(t, np.degrees(result["theta"]), label="theta")
    for name, values in (extra or {}).items():
        axes[0].plot(t, values, "--", label=name)
    axes[0].set_ylabel("angle (deg)")
    axes[0].legend(loc="upper right")
    axes[1].plot(t, result["gap"] * 1e3)
    axes[1].axhline(0.0, color="k", lw=0.5)
    axes[1].set_ylabel("gap (mm)")
    axes[2].plot(t, result["contact_force"])
    axes[2].set_ylabel("contact force (N)")
    balance = result["energy.total"] - result["energy.total"][0] - result["energy.torque_work"]
    axes[3].plot(t, balance)
    axes[3].set_ylabel("E - E0 - W_torque (J)")
    axes[3].set_xlabel("time (s)")
    fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
