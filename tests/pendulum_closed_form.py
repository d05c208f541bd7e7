"""Closed forms of the rigid pendulum: its mass properties, its release and its first impact on the wall.

These are the reference figures of the impact tests; each is derived here from the scene's parameters, not taken
from a run of the models under test.

Mass properties. The face is the ring (outer radius R, hole radius r, centre at depth D below the pivot) and the
part of the rod (half-width w, from the pivot down to the head centre) outside the ring's outer disc, which is
|x| < w, -D + sqrt(R^2 - x^2) < y < 0. Its area, first moment and polar moment about the pivot are the ring's
(pi (R^2 - r^2), -D times that, pi (R^4 - r^4) / 2 + D^2 times the area) plus the rod's, integrals over x of
closed-form integrals over y (scipy's quad, to about 1e-13). Times rho h they are m, -m d and I. The stiff scene:
m = 1.0912 kg, d = 0.18165 m, I = 0.044510 kg m^2.

The release. The wall face is x = -R and reaches from y = -0.115 to -0.365 m; the head's outer circle, centred at
(D sin theta, -D cos theta), is nearest to it at its leftmost point, at the head centre's height, inside that reach:
the gap is D sin theta, zero when the pendulum hangs. Released at rest from theta0 without torque, the pendulum
reaches the wall after a quarter of its period, t1 = sqrt(I / (m g d)) K(sin^2(theta0 / 2)) (K the complete elliptic
integral of the first kind, of the parameter m = k^2), with omega1 = sqrt(2 m g d (1 - cos theta0) / I).
The stiff scene: t1 = 239.47 ms, and the head centre arrives at D omega1 = 0.5509 m/s.

The impact. A circle of radius R pressed delta into a straight face is inside it where its angle phi from the
deepest point has R (1 - cos phi) < delta, with the penetration delta - R phi^2 / 2 to first order in delta / R;
the penalty energy h k / 2 times the integral of the penetration squared over the arc (ds = R dphi) is then
E_c = c delta^(5/2), c = (8 / 15) h k sqrt(2 R): a Hertz-like law. With delta = -D sin theta ~ -D theta and
gravity's moment m g d sin theta negligible while in contact (|theta| < 3e-4 rad), the impact is the mass I / D^2
at speed v = D omega1 on that law: the deepest penetration has c delta_max^(5/2) = m g d (1 - cos theta0), and the
contact lasts t_c = 2 (delta_max / v) J, J = integral from 0 to 1 of du / sqrt(1 - u^(5/2))
= Gamma(2/5) Gamma(1/2) / (5/2 Gamma(9/10)) = 1.4716. The stiff scene: delta_max = 63.19 um, t_c = 0.3376 ms.
The neglected terms are of the relative order delta / R = 1e-3. The contact is elastic and the models' schemes
conserve energy: the pendulum rebounds to theta0 and returns to the wall every 2 t1 + t_c.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from scipy.integrate import quad
from scipy.special import ellipk

if TYPE_CHECKING:  # only: tests that run an FMU in a child import this module before the FMU imports the package
    from fem_pendulum_fmu.physics.scene import Scene

# J = integral_0^1 du / sqrt(1 - u^n) = B(1/n, 1/2) / n for the exponent n = 5/2 of the penalty's energy law
HERTZ_DURATION_FACTOR = math.gamma(0.4) * math.sqrt(math.pi) / (2.5 * math.gamma(0.9))


@dataclass(frozen=True)
class Body:
    mass: float  # kg
    com_depth: float  # m, below the pivot
    inertia: float  # kg m^2, about the pivot

    def gravity_moment(self, gravity: float) -> float:
        """m g d (N m)."""
        return self.mass * gravity * self.com_depth


@dataclass(frozen=True)
class Impact:
    time: float  # s, of the first contact
    omega: float  # rad/s, the angular speed then
    speed: float  # m/s, of the head centre
    penetration: float  # m, the deepest
    duration: float  # s, of the contact


def body(scene: Scene) -> Body:
    """The scene's pendulum as a rigid body (module docstring)."""
    g = scene.geometry
    w, depth, big, small = g.rod_half_width, g.head_centre_depth, g.head_radius, g.hole_radius

    def rod_bottom(x: float) -> float:  # the rod's lower end at x: the ring's outer circle
        return -depth + math.sqrt(big * big - x * x)

    ring_area = math.pi * (big**2 - small**2)
    area = ring_area + quad(lambda x: -rod_bottom(x), -w, w, epsabs=0, epsrel=1e-13)[0]
    first = -depth * ring_area + quad(lambda x: -(rod_bottom(x) ** 2) / 2, -w, w, epsabs=0, epsrel=1e-13)[0]
    ring_polar = math.pi * (big**4 - small**4) / 2 + depth**2 * ring_area

    def rod_polar(x: float) -> float:  # integral of x^2 + y^2 over y from the rod's lower end to 0
        y0 = rod_bottom(x)
        return -(x * x) * y0 - y0**3 / 3

    polar = ring_polar + quad(rod_polar, -w, w, epsabs=0, epsrel=1e-13)[0]
    rho_h = scene.pendulum.rho * scene.pendulum.thickness
    return Body(mass=rho_h * area, com_depth=-first / area, inertia=rho_h * polar)


def first_impact(scene: Scene, pendulum: Body | None = None) -> Impact:
    """The first contact of a release at rest from scene.theta0 > 0 without torque (module docstring); `pendulum`
    defaults to body(scene), or pass a model's own mass properties."""
    pendulum = pendulum or body(scene)
    mgd = pendulum.gravity_moment(scene.gravity)
    theta0 = scene.theta0
    t1 = math.sqrt(pendulum.inertia / mgd) * float(ellipk(math.sin(theta0 / 2) ** 2))
    energy = mgd * (1 - math.cos(theta0))
    omega1 = math.sqrt(2 * energy / pendulum.inertia)
    deepest = penetration(scene, energy)
    speed = scene.geometry.head_centre_depth * omega1
    return Impact(t1, omega1, speed, deepest, 2 * deepest / speed * HERTZ_DURATION_FACTOR)


def penetration(scene: Scene, energy: float) -> float:
    """How deep (m) the head's outer circle presses into the wall's face with `energy` (J) in the penalty: the
    E_c = c delta^(5/2) of the module docstring solved for delta."""
    c = 8 / 15 * scene.pendulum.thickness * scene.contact.stiffness * math.sqrt(2 * scene.geometry.head_radius)
    return (energy / c) ** 0.4


def impact_times(scene: Scene, t_end: float, pendulum: Body | None = None) -> list[float]:
    """When the rebounding pendulum meets the wall before t_end: t1 + n (2 t1 + t_c)."""
    first = first_impact(scene, pendulum)
    times, t = [], first.time
    while t < t_end:
        times.append(t)
        t += 2 * first.time + first.duration
    return times


def deepest_in_a_driven_run(scene: Scene, total_max: float, torque_max: float, dt: float) -> float:
    """A bound on the penetration (m) of a run driven by a torque of at most torque_max whose total energy
    (gravity's zero at the pivot) is at most total_max at its communication points, dt apart: the swing's
    energy above rest, m g d + total_max, plus what the torque can add within a step, torque_max times the
    angle a step turns at up to twice that energy, all pressed into the wall."""
    pendulum = body(scene)
    above_rest = total_max + pendulum.gravity_moment(scene.gravity)
    turn = math.sqrt(4 * above_rest / pendulum.inertia) * dt
    return penetration(scene, above_rest + torque_max * turn)
