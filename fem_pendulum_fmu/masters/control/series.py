"""The columns of a loop's table, one row per communication point t_k = k * step (k = 0 .. n).

Row k holds two kinds of values:
- at the point t_k: `time`, `setpoint`, and the pendulum's outputs `theta`, `omega`, `gap`,
  `contact_force`, `energy.total`, `energy.torque_work`;
- over the step that ends at t_k (row 0: the value it starts with, no step yet): `demand` (the
  controller's output), `disturbance` (added at the hinge), `torque` (what the pendulum received:
  the demand limited by the drive, plus the disturbance), and the pendulum's step summaries
  `gap_min`, `contact_force_max`, `contact_impulse` (physics/protocol.py Outputs).
"""

from __future__ import annotations

AT_POINT = ("time", "setpoint", "theta", "omega", "gap", "contact_force", "energy.total", "energy.torque_work")
OVER_STEP = ("demand", "disturbance", "torque", "gap_min", "contact_force_max", "contact_impulse")
COLUMNS = AT_POINT + OVER_STEP
