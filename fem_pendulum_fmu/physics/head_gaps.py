"""The gap at points of the head's outer boundary: a profile of where the head is near the wall.

`head_boundary_gaps(model)`: the points of the head's outer circle (radius head_radius about the head
centre) every 360 / PER_TURN degrees, counter-clockwise from the point that faces the wall in the
hanging position (the one closest to it, where contact begins), leaving out those in the rod's joint
(15 points for the seed's geometry), each moved as the body moves it, and their signed distances to the
wall block (negative inside). A point's motion is the rigid rotation by the model's theta about the pivot plus the
elastic rest of the displacement field, interpolated along the arc between the mesh's boundary
vertices (linear in the angle): exact for the rigid fidelity, whose displacement is the rotation alone,
and for the elastic rest, of micrometres in steel, a second-order interpolation of it. The block is
the undeformed one (the deformable wall's surface moves by micrometres). The scalar `gap` output is the
minimum over the whole boundary, so the profile's minimum is never below it by more than the
interpolation and the FE boundary's own distance from the circle, and equals it where the closest point
is one of the points: at contact, the first one.
"""

from __future__ import annotations

import math

import numpy as np

from .box import box_signed_distance
from .fields import rigid_motion
from .protocol import PendulumModel
from .scene import PendulumGeometry

ON_CIRCLE = 1e-9  # m: a mesh vertex this close to the head's outer circle is one of its boundary vertices
PER_TURN = 16


def profile_angles(geo: PendulumGeometry) -> np.ndarray:
    """The reference angles (about the head centre, from +x, counter-clockwise) of the profile's points."""
    half_gap = math.asin(geo.rod_half_width / geo.head_radius)  # the rod's joint, seen from the head centre
    angles = math.pi + 2.0 * math.pi * np.arange(PER_TURN) / PER_TURN
    in_joint = np.abs(np.remainder(angles - 0.5 * math.pi + math.pi, 2.0 * math.pi) - math.pi) <= half_gap
    return angles[~in_joint]


def head_boundary_gaps(model: PendulumModel) -> np.ndarray:
    """The signed distances (m) to the wall block of the profile's points (module doc)."""
    geo = model.scene.geometry
    centre = np.array([0.0, -geo.head_centre_depth])
    angles = profile_angles(geo)
    reference = centre + geo.head_radius * np.column_stack([np.cos(angles), np.sin(angles)])
    theta = model.outputs().theta
    moved = reference + rigid_motion(reference, theta, 0.0)[0] + _elastic_rest(model, theta, angles)
    return box_signed_distance(moved[:, 0], moved[:, 1], model.scene.block)[0]


def _elastic_rest(model: PendulumModel, theta: float, angles: np.ndarray) -> np.ndarray:
    """The displacement beyond the rotation by theta at the reference angles, interpolated along the arc
    between the pendulum's boundary vertices; zeros for a body without an elastic rest (rigid)."""
    if model.fidelity == "rigid":
        return np.zeros((len(angles), 2))
    geo = model.scene.geometry
    pendulum = next(f for f in model.fields() if f.name == "pendulum")
    relative = pendulum.points - np.array([0.0, -geo.head_centre_depth])
    on = np.abs(np.hypot(relative[:, 0], relative[:, 1]) - geo.head_radius) < ON_CIRCLE
    points, displacement = pendulum.points[on], pendulum.displacement[on]
    rest = displacement - rigid_motion(points, theta, 0.0)[0]
    at = np.arctan2(relative[on, 1], relative[on, 0])
    order = np.argsort(at)
    return np.column_stack([np.interp(angles, at[order], rest[order, k], period=2.0 * math.pi) for k in range(2)])
