"""The rule behind model.fidelity = "auto": the cheapest model whose physics the scene needs.

An impact puts energy into elastic vibration when the contact is short
against the pendulum's first elastic period; a contact that lasts several
periods loads the body quasi-statically and a rigid body loses nothing. So the
rule compares the contact duration t_c (the rigid model's estimate, the same the
step control uses, at the impact speed of `impact_speed`) with the first
elastic frequency f1 of the hinged pendulum (reduced/modes.py):

* a deformable wall: fem (only the FE model meshes the wall);
* f1 t_c >= RIGID_CONTACT_PERIODS, or no contact and f1 >= RIGID_SWING_RATIO
  times the pendulum's own frequency: rigid;
* a stiff body (E / rho > 1e5 m^2/s^2) whose impacts excite only modes the reduced basis
  holds (its model.modes eigenmodes reach EXCITED_BAND / t_c, the band a pulse of that
  length excites), or that meets no wall: reduced;
* otherwise (a soft body, whose rod a pivot torque bends far beyond a linear basis, or an
  impact too short for the basis): fem.

docs/notes/reduced.md gives the measurements behind the thresholds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .mass_properties import gravity_moment, swing_energy
from .reduced.modes import first_elastic_frequency, modal_basis
from .reduced.strain import uses_linear_strain
from .rigid.model import RigidModel
from .scene import Scene

RIGID_CONTACT_PERIODS = 2.0  # f1 * t_c at or above this: the impact is quasi-static for the body
EXCITED_BAND = 2.0  # an impact of duration t_c excites modes up to EXCITED_BAND / t_c: reduced needs them all
DESIGN_RELEASE = math.pi / 2  # impacts are judged at least as fast as from a release at this angle
RIGID_SWING_RATIO = 100.0  # no contact: f1 / f_pendulum at or above this (static deflection < 1e-4 of the swing)


@dataclass(frozen=True)
class Choice:
    fidelity: str
    reason: str


def choose(scene: Scene) -> Choice:
    """The fidelity "auto" runs for `scene`, and why."""
    if scene.wall.kind == "deformable":
        return Choice("fem", "wall.kind = deformable needs the FE model")
    f1 = first_elastic_frequency(scene)
    rigid = RigidModel(scene.with_values({"model.fidelity": "rigid"}))
    if rigid.contact_on:
        omega_hit = impact_speed(rigid)
        if omega_hit > 0.0:  # (always, with gravity or a start speed)
            # the rigid model's contact estimate at the moment of touching, moving into the wall
            t_c, _ = rigid.contact_scales(RigidModel.state(0.0, -omega_hit))
            ratio = f1 * t_c
            if ratio >= RIGID_CONTACT_PERIODS:
                return Choice(
                    "rigid",
                    f"contact {t_c * 1e3:.3g} ms lasts {ratio:.3g} first elastic periods "
                    f"(f1 = {f1:.4g} Hz, rigid from {RIGID_CONTACT_PERIODS:g})",
                )
            f_top = math.sqrt(modal_basis(scene).eigen_omega2[-1]) / (2.0 * math.pi)
            f_band = EXCITED_BAND / t_c
            why = (
                f"contact {t_c * 1e3:.3g} ms lasts only {ratio:.3g} first elastic periods (f1 = {f1:.4g} Hz): "
                f"impacts excite vibration up to about {f_band:.4g} Hz; the {scene.model.modes} modes of "
                f"model.modes reach {f_top:.4g} Hz"
            )
            if f_top < f_band:
                return Choice("fem", why)
            return soft_or_reduced(scene, why)
    f_swing = math.sqrt(max(gravity_moment(scene), 1e-300) / rigid.inertia) / (2.0 * math.pi)
    ratio = f1 / f_swing
    if ratio >= RIGID_SWING_RATIO:
        return Choice("rigid", f"no impact; f1 = {f1:.4g} Hz is {ratio:.3g} times the swing frequency")
    return soft_or_reduced(scene, f"no impact, but f1 = {f1:.4g} Hz is only {ratio:.3g} times the swing frequency")


def soft_or_reduced(scene: Scene, why: str) -> Choice:
    """reduced, unless the body is soft: a soft rod bends far beyond what a linear basis carries
    under a modest pivot torque (rubber: 2.4 rad of bending at 0.3 N.m, docs/notes/reduced.md)."""
    if uses_linear_strain(scene):
        return Choice("reduced", why)
    return Choice("fem", why + "; the body is soft (E / rho <= 1e5 m^2/s^2): large deflections need fem")


def impact_speed(rigid: RigidModel) -> float:
    """Angular speed at theta = 0, where the head touches the wall: that of the released swing, and
    at least that of a release from horizontal, since the torque input (unknown at initialisation)
    can drive a pendulum released at rest against the wall into it (the controller loop does).
    Energy balance of the rigid body."""
    scene = rigid.scene
    energy = 0.5 * rigid.inertia * scene.omega0**2 + swing_energy(scene)
    return math.sqrt(2.0 * max(energy, swing_energy(scene, DESIGN_RELEASE)) / rigid.inertia)
