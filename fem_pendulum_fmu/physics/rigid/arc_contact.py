"""The penalty wall law of contact.py, evaluated exactly for a rigid circular arc.

A rigid head is a circular arc (its outer boundary), so the contact integral
h * int k/2 max(d, 0)^2 ds needs no mesh: the arc is split where it crosses
the block's faces and where the nearest face changes (the lines on which two
face depths are equal), each inside piece has one linear depth
d = c + g . p, and that piece is integrated by Gauss-Legendre. The pieces are
only micrometres deep and millimetres wide for steel, which a sampled arc
would resolve poorly; here they are integrated to round-off.

Depth convention (the same as contact.py): d(p) = min(x_max - px, px - x_min,
y_max - py, py - y_min), positive inside; g = grad d is the inward direction
of the nearest face, the force on the body is h k d (-g) per unit length.

Plain functions over plain data: an `Arc` tuple and the scene's `WallBlock`.
Derivatives are with respect to a rigid rotation of the arc about the origin
(the pivot), which is all the rigid model needs. Scalars use the math module:
these run in the inner loop of a scalar Newton solve.
"""

from __future__ import annotations

import bisect
import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from ..scene import WallBlock

TWO_PI = 2.0 * math.pi
FACES = ("right", "left", "top", "bottom")  # x_max, x_min, y_max, y_min

# Gauss-Legendre on pieces no wider than MAX_PIECE rad: the integrands are
# trigonometric of degree 2, so 8 points are exact to round-off there.
_GL_X, _GL_W = (tuple(float(v) for v in a) for a in np.polynomial.legendre.leggauss(8))
_GL = tuple(zip(_GL_X, _GL_W, strict=True))
MAX_PIECE = 0.5


class Arc(NamedTuple):
    """Circle arc: centre (cx, cy), radius, counter-clockwise from angle `start` over `length` rad."""

    cx: float
    cy: float
    radius: float
    start: float
    length: float


class Piece(NamedTuple):
    """An angular interval [a, b] (absolute angles about the arc centre) inside the block,
    nearest to face `face` (index into FACES); `whole`: the circle's entire segment beyond that
    face, with nothing else inside (penalty then has a closed form)."""

    a: float
    b: float
    face: int
    whole: bool = False


class Penalty(NamedTuple):
    """Contact energy, force on the arc and derivatives of the energy with respect to a
    rotation of the arc about the origin."""

    energy: float
    fx: float
    fy: float
    d_energy: float  # dE/dtheta = minus the contact torque about the origin
    d2_energy: float  # d2E/dtheta2 without the jump terms at face switches (a Newton Jacobian)


# tuple.__new__(Penalty, values) builds the same named tuple as Penalty(*values) without the Python-level
# __new__ the class generates (2 of the ~12 thousand instructions of a contact evaluation each)
new_named = tuple.__new__

_LAST_FACES: list = [None, ()]  # the last block asked for and its face depths: one model asks again and again


def face_depths(block: WallBlock) -> tuple[tuple[float, float, float], ...]:
    """Each face depth as (c, gx, gy): d_face(p) = c + gx px + gy py. (The same block object again
    skips the lru_cache's hash of the dataclass, a third of a microsecond at every contact evaluation.)"""
    if _LAST_FACES[0] is not block:
        _LAST_FACES[:] = [block, _face_depths(block)]
    return _LAST_FACES[1]


@lru_cache(maxsize=64)
def _face_depths(block: WallBlock) -> tuple[tuple[float, float, float], ...]:
    return ((block.x_max, -1.0, 0.0), (-block.x_min, 1.0, 0.0), (block.y_max, 0.0, -1.0), (-block.y_min, 0.0, 1.0))


@lru_cache(maxsize=64)
def split_lines(block: WallBlock) -> tuple[tuple[float, float, float, float], ...]:
    """Lines (beta, nx, ny, C) with n . p = C, n = (cos beta, sin beta): the four faces and the
    six lines where two face depths are equal. Along an arc, the nearest face and the sign
    of the depth can only change where the arc crosses one of them."""
    s = math.sqrt(0.5)
    xc, yc = 0.5 * (block.x_min + block.x_max), 0.5 * (block.y_min + block.y_max)
    raw = [
        (1.0, 0.0, block.x_max),
        (1.0, 0.0, block.x_min),
        (0.0, 1.0, block.y_max),
        (0.0, 1.0, block.y_min),
        (1.0, 0.0, xc),
        (0.0, 1.0, yc),
        (-s, s, s * (block.y_max - block.x_max)),  # right = top
        (s, s, s * (block.x_max + block.y_min)),  # right = bottom
        (s, s, s * (block.x_min + block.y_max)),  # left = top
        (-s, s, s * (block.y_min - block.x_min)),  # left = bottom
    ]
    return tuple((math.atan2(ny, nx), nx, ny, c) for nx, ny, c in raw)


def circle_may_touch(cx: float, cy: float, radius: float, block: WallBlock) -> bool:
    """False when the whole circle is certainly outside the block: its centre is farther from
    the block than the radius, or the block lies inside the circle without reaching it."""
    # conditionals, not builtin min and max: this runs at every contact evaluation
    x_min, x_max, y_min, y_max = block.x_min, block.x_max, block.y_min, block.y_max
    dx = x_min - cx if cx < x_min else cx - x_max if cx > x_max else 0.0
    dy = y_min - cy if cy < y_min else cy - y_max if cy > y_max else 0.0
    r2 = radius * radius
    if dx * dx + dy * dy > r2:
        return False
    fx = cx - x_min if cx - x_min > x_max - cx else x_max - cx  # the farther side: |x - cx| is the larger
    fy = cy - y_min if cy - y_min > y_max - cy else y_max - cy
    return fx * fx + fy * fy >= r2


def _offset(arc: Arc, angle: float) -> float:
    """Arc parameter (0 at arc.start) of an absolute angle, in [0, 2 pi)."""
    return (angle - arc.start) % TWO_PI


def _one_face_piece(arc: Arc, block: WallBlock) -> list[Piece] | None:
    """The inside pieces when the circle crosses one face well away from its ends, else None.

    If the centre lies outside face F's half-plane at distance R - delta (delta > 0), the circle's
    points beyond F's line form a segment of depth <= delta whose extent along F is its chord. With
    that chord inside F's extent by more than delta at both ends and the block deeper than 2 delta,
    the segment lies in the block, F is its nearest face everywhere (the other faces are more than
    delta away) and the rest of the circle is outside F's half-plane, so outside the block: the arc
    inside the block is one piece, bounded by the chord's ends. A centre outside F with delta <= 0
    means the circle misses the block. This is the resting or impacting head on one face; corners
    and deep contacts take the general split (None)."""
    cx, cy, R = arc.cx, arc.cy, arc.radius
    for face, (c, gx, gy) in enumerate(face_depths(block)):
        centre_depth = c + gx * cx + gy * cy
        if centre_depth >= 0.0:
            continue
        delta = R + centre_depth  # depth of the circle's deepest point below F's line
        if delta <= 0.0:
            return []
        if gx != 0.0:  # a vertical face: the chord runs along y
            lo, hi, t, thick = block.y_min, block.y_max, cy, block.x_max - block.x_min
        else:
            lo, hi, t, thick = block.x_min, block.x_max, cx, block.y_max - block.y_min
        half_chord = math.sqrt(delta * (2.0 * R - delta))
        if not (lo + delta < t - half_chord and t + half_chord < hi - delta and thick > 2.0 * delta):
            return None
        peak = math.atan2(gy, gx)  # the deepest point's direction from the centre
        half = math.acos(-centre_depth / R)
        s0 = _offset(arc, peak - half)
        if s0 + 2.0 * half > arc.length:  # the rod joint's gap reaches the segment
            return None
        return [new_named(Piece, (arc.start + s0, arc.start + s0 + 2.0 * half, face, True))]
    return None


def inside_pieces(arc: Arc, block: WallBlock) -> list[Piece]:
    """The parts of the arc strictly inside the block, split where the nearest face changes."""
    cx, cy, R = arc.cx, arc.cy, arc.radius
    if not circle_may_touch(cx, cy, R, block):
        return []
    fast = _one_face_piece(arc, block)
    if fast is not None:
        return fast
    # crossings outside the (slightly grown) block cannot start, end or split an inside part
    slack = 1e-9 * (block.x_max - block.x_min + block.y_max - block.y_min)
    x_lo, x_hi, y_lo, y_hi = block.x_min - slack, block.x_max + slack, block.y_min - slack, block.y_max + slack
    cuts = [0.0, arc.length]
    for beta, nx, ny, c in split_lines(block):
        cos_arg = (c - nx * cx - ny * cy) / R
        if -1.0 < cos_arg < 1.0:
            half = math.acos(cos_arg)
            for angle in (beta - half, beta + half):
                if x_lo <= cx + R * math.cos(angle) <= x_hi and y_lo <= cy + R * math.sin(angle) <= y_hi:
                    s = _offset(arc, angle)
                    if s < arc.length:
                        cuts.append(s)
    cuts.sort()
    faces = face_depths(block)
    pieces: list[Piece] = []
    for s0, s1 in zip(cuts[:-1], cuts[1:], strict=True):
        if s1 <= s0:
            continue
        mid = arc.start + 0.5 * (s0 + s1)
        px, py = cx + R * math.cos(mid), cy + R * math.sin(mid)
        depth, face = math.inf, -1
        for j, (c, gx, gy) in enumerate(faces):
            d = c + gx * px + gy * py
            if d < depth:
                depth, face = d, j
        if depth <= 0.0:
            continue
        a, b = arc.start + s0, arc.start + s1
        if pieces and pieces[-1].face == face and pieces[-1].b == a:
            pieces[-1] = Piece(pieces[-1].a, b, face)  # a cut by an irrelevant line
        else:
            pieces.append(Piece(a, b, face))
    return pieces


def penalty(arc: Arc, block: WallBlock, hk: float, pieces: list[Piece] | None = None) -> Penalty:
    """Energy h k/2 int d^2 ds over the inside pieces, the force on the arc, and dE/dtheta,
    d2E/dtheta2 for a rotation of the arc about the origin (end points of the pieces either
    have d = 0 or are fixed material points, so no boundary terms enter dE/dtheta)."""
    if pieces is None:
        pieces = inside_pieces(arc, block)
    if not pieces:
        return Penalty(0.0, 0.0, 0.0, 0.0, 0.0)
    if len(pieces) == 1 and pieces[0].whole:
        segment = _segment_penalty(arc, block, hk, pieces[0].face)
        if segment is not None:
            return segment
    cx, cy, R = arc.cx, arc.cy, arc.radius
    faces = face_depths(block)
    cos, sin = math.cos, math.sin  # local names: this loop is the rigid model's inner loop in contact
    e = fx = fy = de = d2e = 0.0
    for a, b, face, _ in pieces:
        c, gx, gy = faces[face]
        n_sub = max(1, math.ceil((b - a) / MAX_PIECE))
        width = (b - a) / n_sub
        half = 0.5 * width
        s_d = s_dd = s_dj = s_h = 0.0
        for k in range(n_sub):
            mid = a + (k + 0.5) * width
            for xi, wi in _GL:  # leggauss(8)
                ang = mid + half * xi
                px, py = cx + R * cos(ang), cy + R * sin(ang)
                d = c + gx * px + gy * py
                jd = gy * px - gx * py  # d(depth)/dtheta: g . (J p), J p = (-py, px)
                s_d += wi * d
                s_dd += wi * d * d
                s_dj += wi * d * jd
                s_h += wi * (jd * jd - d * (gx * px + gy * py))  # d2(d^2/2)/dtheta2
        scale = hk * half * R  # ds = R d(angle), Gauss weights on [-1, 1]
        e += 0.5 * scale * s_dd
        fx -= scale * s_d * gx
        fy -= scale * s_d * gy
        de += scale * s_dj
        d2e += scale * s_h
    return Penalty(e, fx, fy, de, d2e)


# The segment of a circle of radius R cut by a face at depth delta = R (1 - cos phi): with the depth
# d = R (cos psi - cos phi) over |psi| <= phi, int d^2 ds = R^3 S(phi) and int d ds = R^2 C(phi), where
# S = 2 phi + phi cos 2 phi - 3/2 sin 2 phi and C = 2 (sin phi - phi cos phi). Both cancel to high
# powers of phi, so they are summed as their series, to the terms below 1e-20 of the first (10 terms at
# phi = 0.5, 5 at the steel scene's deepest contact, phi ~ 0.05):
# S = x^5 sum_j (-1)^j (j + 1) x^2j / (2j + 5)! with x = 2 phi, C = phi^3 sum_j (-1)^j 4 (j + 1) phi^2j / (2j + 3)!.
SEGMENT_PHI_MAX = 0.5
SERIES_CUT = 1e-20
_S_SERIES = tuple((-1) ** j * (j + 1) / math.factorial(2 * j + 5) for j in range(10))
_C_SERIES = tuple((-1) ** j * 4 * (j + 1) / math.factorial(2 * j + 3) for j in range(10))
# _SERIES[n - 1]: the first n terms' (S, C) coefficients, highest first (Horner); _PHI_LIMITS[n - 1]: the
# largest phi whose first left-out terms, of S and of C, are below SERIES_CUT of their first
_SERIES = tuple(tuple(zip(_S_SERIES[:n], _C_SERIES[:n], strict=True))[::-1] for n in range(1, 11))
_PHI_LIMITS = tuple(
    min(
        0.5 * (SERIES_CUT * math.factorial(2 * n + 5) / (120 * (n + 1))) ** (0.5 / n),
        (SERIES_CUT * math.factorial(2 * n + 3) / (6 * (n + 1))) ** (0.5 / n),
    )
    for n in range(1, 11)
)


def _segment_penalty(arc: Arc, block: WallBlock, hk: float, face: int) -> Penalty | None:
    """penalty() of a whole segment beyond one face, in closed form (None beyond SEGMENT_PHI_MAX).

    The segment depends on the centre's depth alone, delta = R + c + g . centre; the energy is
    hk/2 R^3 S(phi), the force hk R^2 C(phi) along -g, and a rotation about the pivot moves delta
    by g . (J centre) (the rotation about the circle's own centre leaves the segment as it is), so
    dE/dtheta = P g . (J centre) and d2E/dtheta2 = hk 2 R phi (g . J centre)^2 - P g . centre."""
    c, gx, gy = face_depths(block)[face]
    cx, cy, R = arc.cx, arc.cy, arc.radius
    delta = R + (c + gx * cx + gy * cy)
    phi = 2.0 * math.asin(math.sqrt((delta if delta > 0.0 else 0.0) / (2.0 * R)))
    if phi > SEGMENT_PHI_MAX:
        return None
    x, p2 = 2.0 * phi, phi * phi
    x2 = x * x
    s_sum = c_sum = 0.0
    for s_j, c_j in _SERIES[bisect.bisect_left(_PHI_LIMITS, phi)]:
        s_sum = s_sum * x2 + s_j
        c_sum = c_sum * p2 + c_j
    energy = 0.5 * hk * (R * R * R) * (x2 * x2 * x) * s_sum  # products, not **: float_pow is slow
    force = hk * R * R * (p2 * phi) * c_sum
    lever = gy * cx - gx * cy  # d delta / d theta
    d2 = hk * 2.0 * R * phi * lever * lever - force * (gx * cx + gy * cy)
    return new_named(Penalty, (energy, -force * gx, -force * gy, force * lever, d2))


def deepest_point(arc: Arc, block: WallBlock, pieces: list[Piece]) -> tuple[float, float, float, int]:
    """(depth, px, py, face) of the deepest arc point among the pieces (which must be non-empty).

    On a piece d = c + g.(centre) + R cos(angle - angle_of_g), so the maximum is at the piece's
    ends or where the radius points along g."""
    cx, cy, R = arc.cx, arc.cy, arc.radius
    faces = face_depths(block)
    best = (-math.inf, 0.0, 0.0, -1)
    for a, b, face, whole in pieces:
        c, gx, gy = faces[face]
        peak = math.atan2(gy, gx)
        peak += TWO_PI * math.ceil((a - peak) / TWO_PI)
        if peak > b:
            candidates: tuple[float, ...] = (a, b)
        else:  # a whole segment's ends lie on the face (depth 0): its deepest point is the peak
            candidates = (peak,) if whole else (a, b, peak)
        for ang in candidates:
            px, py = cx + R * math.cos(ang), cy + R * math.sin(ang)
            d = c + gx * px + gy * py
            if d > best[0]:
                best = (d, px, py, face)
    return best


def _on_arc(arc: Arc, angle: float) -> bool:
    return _offset(arc, angle) <= arc.length


def point_box(px: float, py: float, block: WallBlock) -> tuple[float, float, float]:
    """Distance from a point outside (or on) the block to it, and the nearest block point."""
    x_min, x_max, y_min, y_max = block.x_min, block.x_max, block.y_min, block.y_max
    qx = x_min if px < x_min else x_max if px > x_max else px  # not builtin min/max: a gap asks this
    qy = y_min if py < y_min else y_max if py > y_max else py
    return math.hypot(px - qx, py - qy), qx, qy


def outside_distance(arc: Arc, block: WallBlock) -> tuple[float, float, float, float, float]:
    """Euclidean distance from an arc with no point inside the block to the block:
    (distance, px, py, nx, ny), p the arc point attaining it and n the unit direction from
    the block to p (the gap's gradient with respect to p).

    The closest pair is one of: an arc end and the block; a corner and the circle point
    radially facing it; an edge's foot of the perpendicular from the centre and the circle
    point facing it (when those circle points lie on the arc). Each candidate is an actual
    arc-to-block distance, so the minimum over them is exact."""
    cx, cy, R = arc.cx, arc.cy, arc.radius
    best = (math.inf, 0.0, 0.0, 0.0, 0.0)  # dist, px, py, qx, qy

    def consider(dist: float, px: float, py: float, qx: float, qy: float) -> None:
        nonlocal best
        if dist < best[0]:
            best = (dist, px, py, qx, qy)

    # block points facing the centre: the clamped centre, corners, feet on the edges
    x0, x1, y0, y1 = block.x_min, block.x_max, block.y_min, block.y_max
    feet = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)]
    if x0 < cx < x1:
        feet += [(cx, y0), (cx, y1)]
    if y0 < cy < y1:
        feet += [(x0, cy), (x1, cy)]
    for qx, qy in feet:
        rx, ry = qx - cx, qy - cy
        rho = math.hypot(rx, ry)
        if rho == 0.0:
            continue
        if _on_arc(arc, math.atan2(ry, rx)):
            px, py = cx + R * rx / rho, cy + R * ry / rho
            consider(abs(rho - R), px, py, qx, qy)
    for ang in (arc.start, arc.start + arc.length):
        px, py = cx + R * math.cos(ang), cy + R * math.sin(ang)
        dist, qx, qy = point_box(px, py, block)
        consider(dist, px, py, qx, qy)
    dist, px, py, qx, qy = best
    if dist > 0.0:
        nx, ny = (px - qx) / dist, (py - qy) / dist
    else:  # touching: the block's outward direction, seen from the circle's centre
        rx, ry = cx - qx, cy - qy
        rho = math.hypot(rx, ry) or 1.0
        nx, ny = rx / rho, ry / rho
    return dist, px, py, nx, ny


def signed_gap(arc: Arc, block: WallBlock, pieces: list[Piece] | None = None) -> tuple[float, float]:
    """(gap, d gap / d theta) for a rotation of the arc about the origin.

    gap > 0: Euclidean clearance between arc and block; gap < 0: minus the largest depth of
    an arc point inside the block (the penalty law's depth)."""
    cx, cy, R = arc.cx, arc.cy, arc.radius
    # fast path (free flight): the centre is outside, more than R from the block, and the
    # circle point facing the block's nearest point lies on the arc; then the gap is exact.
    dist_c, qx, qy = point_box(cx, cy, block)
    if dist_c > R:
        rx, ry = qx - cx, qy - cy
        if _on_arc(arc, math.atan2(ry, rx)):
            nx, ny = -rx / dist_c, -ry / dist_c
            px, py = cx - R * nx, cy - R * ny
            return dist_c - R, ny * px - nx * py
    return _contact_or_outside_gap(arc, block, pieces)


def clear_gap(cx: float, cy: float, radius: float, start: float, length: float, block: WallBlock) -> float | None:
    """signed_gap's gap for the arc (cx, cy, radius, start, length) when its fast path applies (the
    circle clear of the block, its point facing the block on the arc), by the same arithmetic;
    None otherwise. Without building an Arc: the rigid model's free flight asks it every step."""
    # the block's point nearest the centre (conditionals: builtin min and max cost a microsecond here)
    x_min, x_max, y_min, y_max = block.x_min, block.x_max, block.y_min, block.y_max
    qx = x_min if cx < x_min else x_max if cx > x_max else cx
    qy = y_min if cy < y_min else y_max if cy > y_max else cy
    dist_c = math.hypot(cx - qx, cy - qy)
    if dist_c > radius and (math.atan2(qy - cy, qx - cx) - start) % TWO_PI <= length:
        return dist_c - radius
    return None


def _contact_or_outside_gap(arc: Arc, block: WallBlock, pieces: list[Piece] | None) -> tuple[float, float]:
    """signed_gap beyond its fast path: the deepest point inside, else the exact outside distance."""
    if pieces is None:
        pieces = inside_pieces(arc, block)
    if pieces:
        depth, px, py, face = deepest_point(arc, block, pieces)
        _, gx, gy = face_depths(block)[face]
        return -depth, -(gy * px - gx * py)
    dist, px, py, nx, ny = outside_distance(arc, block)
    return dist, ny * px - nx * py
