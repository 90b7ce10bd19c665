"""Test fixtures of the GP planner tests: an exact analytic SDF and straight-line initial paths.

The analytic field (union of discs and axis-aligned boxes) has exact distances and gradients,
so finite-difference checks of the obstacle factors test the factors, not a grid's
interpolation error.
"""
from __future__ import annotations

import numpy as np


class AnalyticSDF:
    """Signed distance to a union of discs ``(cx, cy, r)`` and boxes ``(cx, cy, half_w, half_h)``.

    ``query(points (n, 2)) -> (distance (n,), gradient (n, 2))``, negative inside obstacles.
    """

    def __init__(self, circles=(), boxes=()):
        self.circles = np.asarray(circles, dtype=float).reshape(-1, 3)
        self.boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
        if len(self.circles) + len(self.boxes) == 0:
            raise ValueError('AnalyticSDF needs at least one obstacle')

    def query(self, points):
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        distances, gradients = [], []
        for cx, cy, radius in self.circles:
            offset = points - (cx, cy)
            norm = np.linalg.norm(offset, axis=1)
            safe = np.where(norm > 0.0, norm, 1.0)
            distances.append(norm - radius)
            gradients.append(np.where(norm[:, None] > 0.0, offset / safe[:, None], [1.0, 0.0]))
        for cx, cy, half_w, half_h in self.boxes:
            offset = points - (cx, cy)
            excess = np.abs(offset) - (half_w, half_h)
            outside = np.maximum(excess, 0.0)
            outside_norm = np.linalg.norm(outside, axis=1)
            inside = np.minimum(np.max(excess, axis=1), 0.0)
            distances.append(outside_norm + inside)
            sign = np.where(offset >= 0.0, 1.0, -1.0)
            safe = np.where(outside_norm > 0.0, outside_norm, 1.0)
            grad_out = sign * outside / safe[:, None]
            axis = np.argmax(excess, axis=1)
            grad_in = np.zeros_like(points)
            grad_in[np.arange(len(points)), axis] = sign[np.arange(len(points)), axis]
            gradients.append(np.where(outside_norm[:, None] > 0.0, grad_out, grad_in))
        distances = np.array(distances)
        nearest = np.argmin(distances, axis=0)
        columns = np.arange(points.shape[0])
        return distances[nearest, columns], np.array(gradients)[nearest, columns]


def straight_line(start_xy, goal_xy, state_count: int, total_time: float) -> np.ndarray:
    """Constant-velocity straight line (N+1, 4) from ``start_xy`` to ``goal_xy``."""
    start_xy = np.asarray(start_xy, dtype=float)
    goal_xy = np.asarray(goal_xy, dtype=float)
    fraction = np.linspace(0.0, 1.0, state_count)[:, None]
    positions = start_xy + fraction * (goal_xy - start_xy)
    velocity = np.broadcast_to((goal_xy - start_xy) / total_time, (state_count, 2))
    return np.hstack([positions, velocity])
