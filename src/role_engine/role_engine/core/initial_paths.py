"""Initial process roles: N+1 evenly timed states [x, y, vx, vy] along a path (Fig. 3).

``Make_Init_Path`` of Algorithm 2 (line 10): the E-Map initialisation distributes the
states evenly by arc length along the line segments through the auxiliary nodes (green
path of Fig. 3); the straight-line initialisation of the original GPMP (red dashed line)
is the special case with no intermediate node, kept for the comparison of Table III.

Velocities are consistent with the spacing: central differences of the positions over
the time step at interior states, one-sided differences at the two ends, so a straight
line gets the constant velocity ``(goal - start) / total_time`` everywhere.
"""
from __future__ import annotations

import math

import numpy as np

from .astar import AuxiliaryPath, EMapPlanner
from .errors import RoleEngineError

#: Columns of a trajectory array.
STATE_COLUMNS = ('x', 'y', 'vx', 'vy')


class InfeasiblePathError(RoleEngineError):
    """No initial path exists: the E-Map has no route between the two points."""


def _check_timing(total_time: float, num_intervals: int) -> None:
    if isinstance(total_time, bool) or not isinstance(total_time, (int, float)) \
            or not math.isfinite(total_time) or total_time <= 0:
        raise RoleEngineError(f'total_time: must be a finite number > 0 s (got {total_time!r})')
    if isinstance(num_intervals, bool) or not isinstance(num_intervals, (int, np.integer)) or num_intervals < 1:
        raise RoleEngineError(f'num_intervals: must be an integer >= 1 (got {num_intervals!r})')


def state_times(total_time: float, num_intervals: int) -> np.ndarray:
    """(N+1,) times of the states, evenly spaced from 0 to ``total_time``."""
    _check_timing(total_time, num_intervals)
    return np.linspace(0.0, float(total_time), int(num_intervals) + 1)


def velocities_from_positions(positions: np.ndarray, dt: float) -> np.ndarray:
    """(N+1, 2) velocities: central differences inside, one-sided at the ends."""
    return np.gradient(positions, dt, axis=0, edge_order=1)


def polyline_trajectory(waypoints: np.ndarray, total_time: float, num_intervals: int) -> np.ndarray:
    """(N+1, 4) states evenly spaced in time and in arc length along the polyline ``waypoints``."""
    _check_timing(total_time, num_intervals)
    points = np.asarray(waypoints, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 1:
        raise RoleEngineError(f'waypoints: must have shape (K, 2) with K >= 1 (got {points.shape})')
    if not np.isfinite(points).all():
        raise RoleEngineError('waypoints: every coordinate must be finite')
    cumulative = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
    samples = np.linspace(0.0, cumulative[-1], int(num_intervals) + 1)
    if cumulative[-1] == 0.0:
        positions = np.repeat(points[:1], len(samples), axis=0)
    else:
        positions = np.stack([np.interp(samples, cumulative, points[:, k]) for k in range(2)], axis=1)
    dt = float(total_time) / int(num_intervals)
    return np.hstack([positions, velocities_from_positions(positions, dt)])


def straight_line_trajectory(start, goal, total_time: float, num_intervals: int) -> np.ndarray:
    """(N+1, 4) straight-line initialisation of the original GPMP (Fig. 3, red dashed line)."""
    return polyline_trajectory(np.array([start, goal], dtype=float), total_time, num_intervals)


def emap_trajectory(planner: EMapPlanner, start, goal, total_time: float, num_intervals: int,
                    ) -> tuple[np.ndarray, AuxiliaryPath]:
    """(N+1, 4) E-Map initialisation through the auxiliary nodes, and the path it follows.

    Raises :class:`InfeasiblePathError` (with the planner's reason) when no path exists.
    """
    _check_timing(total_time, num_intervals)
    path = planner.plan(start, goal)
    if not path.feasible:
        raise InfeasiblePathError(path.reason)
    return polyline_trajectory(path.waypoints, total_time, num_intervals), path
