"""Summary figures of one sample's time series: one row of numbers that a sweep's table and plot compare.

Contact and rebounds are read as everywhere else in the package
(physics.swing): a stiff impact lasts about 0.3 ms and falls between 1 ms
samples, so the figures use what the FMU outputs of each doStep: gap_min
(the smallest gap at its internal steps) for contact and contact_force_max
(the largest force at them) for the force, and the turn of omega near the
wall for a rebound; never the sampled gap or contact force alone. Energy errors are measured against the
swing energy m g d (1 - cos theta0) (physics.mass_properties).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...physics import swing
from ...physics.mass_properties import swing_energy
from ...physics.scene import Scene

# what the figures read; a sweep records these whatever outputs the user keeps
NEEDED = ("theta", "omega", "gap", "gap_min", "contact_force_max", "energy.total", "energy.torque_work")


@dataclass(frozen=True)
class Figures:
    """NaN where a figure does not exist (no contact, no rebound, a failed sample).

    first_contact_time: end of the first communication step in which the head touched the wall (gap_min < 0), s.
    largest_penetration: -min(gap_min) when the head touched the wall, else 0 (m).
    first_rebound_peak: theta at its first local maximum after the first rebound (rad).
    max_contact_force: largest contact_force_max, the largest force within any doStep (N).
    energy_error: max |E(t) - E(0) - W(t)| over the swing energy, E the total energy and W the torque's work.
    rebounds: how many rebounds (swing.rebounds with its defaults).
    """

    first_contact_time: float = math.nan
    largest_penetration: float = math.nan
    first_rebound_peak: float = math.nan
    max_contact_force: float = math.nan
    energy_error: float = math.nan
    rebounds: float = math.nan  # a count; float so that a failed sample's NaN fits the column


# the unit of each figure (the definitions above), for the axes of the summary plot
UNITS = {
    "first_contact_time": "s",
    "largest_penetration": "m",
    "first_rebound_peak": "rad",
    "max_contact_force": "N",
    "energy_error": "fraction of the swing energy",
    "rebounds": "count",
}


def _first_rebound_peak(series: np.ndarray) -> tuple[float, int]:
    hits = swing.rebounds(series["omega"], series["gap"])
    if len(hits) == 0:
        return math.nan, 0
    peaks = swing.peaks_after_first_contact(series["theta"], series["gap_min"])
    later = peaks[peaks > hits[0]]
    return (float(series["theta"][later[0]]) if len(later) else math.nan), len(hits)


def summarise(series: np.ndarray, scene: Scene) -> Figures:
    """The figures of a recorded run (fmpy's structured result array, with the NEEDED columns).

    Parameters
    ----------
    series : the run, one row a communication point, from t = 0.
    scene : the scene the run's parameters describe (for the swing energy).
    """
    touching = np.nonzero(series["gap_min"] < 0)[0]
    peak, count = _first_rebound_peak(series)
    drift = series["energy.total"] - series["energy.total"][0] - series["energy.torque_work"]
    scale = swing_energy(scene)
    return Figures(
        first_contact_time=float(series["time"][touching[0]]) if len(touching) else math.nan,
        largest_penetration=max(0.0, -float(np.min(series["gap_min"]))),
        first_rebound_peak=peak,
        max_contact_force=float(np.max(series["contact_force_max"])),
        energy_error=float(np.max(np.abs(drift))) / scale if scale > 0 else math.nan,
        rebounds=float(count),
    )
