"""The wall block's signed distance and its gradient: the one computation of them that the FE and
reduced models' gaps and contact normals use (the rigid model's arc has its own, exact, in
rigid/arc_contact.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scene import WallBlock


@dataclass(frozen=True)
class Box:
    """The block as centre (cx, cy) and half sizes (hx, hy): the form the distance is computed in."""

    cx: float
    cy: float
    hx: float
    hy: float

    @classmethod
    def of(cls, block: WallBlock) -> Box:
        return cls(
            0.5 * (block.x_min + block.x_max),
            0.5 * (block.y_min + block.y_max),
            0.5 * (block.x_max - block.x_min),
            0.5 * (block.y_max - block.y_min),
        )

    def distances(self, px: np.ndarray, py: np.ndarray) -> np.ndarray:
        """Signed distances of points to the block (m, negative inside)."""
        qx, qy = np.abs(px - self.cx) - self.hx, np.abs(py - self.cy) - self.hy
        return np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0)) + np.minimum(np.maximum(qx, qy), 0.0)

    def distances_and_normals(self, px: np.ndarray, py: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Signed distances and the distance's unit gradient (nx, ny) at points: outside the block the
        direction from its nearest point, inside the normal of the nearer face."""
        qx, qy = np.abs(px - self.cx) - self.hx, np.abs(py - self.cy) - self.hy
        ox, oy = np.maximum(qx, 0.0), np.maximum(qy, 0.0)
        outside = np.hypot(ox, oy)
        dist = outside + np.minimum(np.maximum(qx, qy), 0.0)
        sx, sy = np.sign(px - self.cx), np.sign(py - self.cy)
        with np.errstate(invalid="ignore", divide="ignore"):
            nx = np.where(outside > 0, ox / np.where(outside > 0, outside, 1.0), (qx >= qy).astype(float))
            ny = np.where(outside > 0, oy / np.where(outside > 0, outside, 1.0), (qy > qx).astype(float))
        return dist, nx * sx, ny * sy

    def normal(self, px: float, py: float) -> tuple[float, float]:
        """`distances_and_normals`' gradient at one point, in float arithmetic (microseconds fewer than
        numpy's at one point, and the same bits: the length is numpy's hypot)."""
        qx, qy = abs(px - self.cx) - self.hx, abs(py - self.cy) - self.hy
        ox, oy = max(qx, 0.0), max(qy, 0.0)
        outside = float(np.hypot(ox, oy))
        if outside > 0.0:
            nx, ny = ox / outside, oy / outside
        else:
            nx, ny = float(qx >= qy), float(qy > qx)
        return nx * ((px > self.cx) - (px < self.cx)), ny * ((py > self.cy) - (py < self.cy))


def box_signed_distance(px: np.ndarray, py: np.ndarray, block: WallBlock) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed distance of points to `block` (negative inside) and its unit gradient (nx, ny)."""
    return Box.of(block).distances_and_normals(px, py)
