"""What ``roles-collab`` and ``roles-formation`` measure on driven paths: distances between robots,
clearance to the static obstacles, contacts, jerk (paper Sec. V-A-3's smoothness cost)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.conflict import SharedRole


def pair_distances(positions: dict[str, np.ndarray]) -> dict[tuple[str, str], np.ndarray]:
    """Centre distance over time (K,) of every robot pair, from (K, 2) positions per robot."""
    names = sorted(positions)
    return {(a, b): np.hypot(*(positions[a] - positions[b]).T)
            for i, a in enumerate(names) for b in names[i + 1:]}


def contact_onsets(distance: np.ndarray, threshold: float) -> int:
    """How often ``distance`` drops below ``threshold`` (a contact that lasts counts once)."""
    inside = np.asarray(distance) < threshold
    return int(inside[0]) + int(np.count_nonzero(inside[1:] & ~inside[:-1])) if len(inside) else 0


def separation_measures(positions: dict[str, np.ndarray], radii: dict[str, float], times: np.ndarray) -> dict:
    """min_distance (centres) with its pair and sum of radii, min_clearance, collisions (onsets)."""
    distances = pair_distances(positions)
    if not distances:
        return {'min_distance': None, 'min_distance_pair': None, 'min_distance_time': None,
                'sum_of_radii': None, 'min_clearance': None, 'collisions': 0, 'collisions_by_pair': {}}
    closest = min(distances, key=lambda pair: float(distances[pair].min()))
    k = int(np.argmin(distances[closest]))
    clearances = {pair: d - (radii[pair[0]] + radii[pair[1]]) for pair, d in distances.items()}
    by_pair = {f'{a}-{b}': contact_onsets(d, radii[a] + radii[b]) for (a, b), d in distances.items()}
    return {'min_distance': float(distances[closest][k]), 'min_distance_pair': list(closest),
            'min_distance_time': float(times[k]), 'sum_of_radii': radii[closest[0]] + radii[closest[1]],
            'min_clearance': float(min(c.min() for c in clearances.values())),
            'collisions': int(sum(by_pair.values())), 'collisions_by_pair': by_pair}


@dataclass(frozen=True)
class ObstacleBox:
    """A static obstacle as the simulation builds it: a box of ``size`` (m) at ``center``, rotated by ``yaw``."""

    name: str
    center: tuple[float, float]
    size: tuple[float, float]
    yaw: float = 0.0

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        """(K,) distance from each point to the box's boundary; negative inside."""
        p = np.asarray(points, dtype=float).reshape(-1, 2) - np.asarray(self.center, dtype=float)
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        local = np.abs(np.column_stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1]]))
        q = local - 0.5 * np.asarray(self.size, dtype=float)
        outside = np.hypot(*np.maximum(q, 0.0).T)
        inside = np.minimum(np.max(q, axis=1), 0.0)
        return outside + inside


def obstacle_clearances(positions: dict[str, np.ndarray], radii: dict[str, float], obstacles: list[ObstacleBox],
                        times: np.ndarray) -> dict:
    """Robot-obstacle clearance from positions over time (ground truth) and the boxes of the map.

    Clearance of a robot at an instant = distance from its centre to the nearest box minus its
    radius (the disc touches an obstacle at 0, overlaps it below). Per robot: the least clearance,
    when, where and against which box, and its ``contacts`` (onsets of clearance < 0: a contact
    that lasts counts once, whichever box). Overall: ``min_obstacle_clearance`` (and its robot) and
    ``obstacle_contacts`` (the sum). Without obstacles every clearance is None and no contact.
    """
    per_robot: dict[str, dict] = {}
    for robot in sorted(positions):
        points = np.asarray(positions[robot], dtype=float).reshape(-1, 2)
        if not obstacles or len(points) == 0:
            per_robot[robot] = {'min_clearance': None, 'time': None, 'position': None, 'obstacle': None,
                                'contacts': 0}
            continue
        distances = np.vstack([box.signed_distance(points) for box in obstacles])     # (boxes, K)
        nearest = np.argmin(distances, axis=0)
        clearance = distances[nearest, np.arange(len(points))] - radii[robot]
        k = int(np.argmin(clearance))
        per_robot[robot] = {'min_clearance': float(clearance[k]), 'time': float(times[k]),
                            'position': [float(v) for v in points[k]], 'obstacle': obstacles[nearest[k]].name,
                            'contacts': contact_onsets(clearance, 0.0)}
    measured = {r: v for r, v in per_robot.items() if v['min_clearance'] is not None}
    worst = min(measured, key=lambda r: measured[r]['min_clearance']) if measured else None
    return {'obstacle_clearance': per_robot,
            'min_obstacle_clearance': measured[worst]['min_clearance'] if worst else None,
            'min_obstacle_clearance_robot': worst,
            'obstacle_contacts': int(sum(v['contacts'] for v in per_robot.values()))}


def finite_difference_jerk(velocities: np.ndarray, dt: float) -> np.ndarray:
    """|jerk| (K-2,) of planar velocities (K, 2) sampled every ``dt``."""
    if len(velocities) < 3:
        return np.zeros(0)
    return np.hypot(*(np.diff(velocities, n=2, axis=0) / dt**2).T)


def hermite_jerk(role: SharedRole, t: float) -> float:
    """|d^3 p / dt^3| of the role's cubic Hermite interpolant (core/trajectory.py) at time ``t``; 0 at rest."""
    states = role.trajectory
    intervals = len(states) - 1
    dt = role.total_time / intervals
    local = t - role.start_time
    if local < 0.0 or local > role.total_time:
        return 0.0
    k = min(int(local / dt), intervals - 1)
    p0, v0, p1, v1 = states[k, :2], states[k, 2:] * dt, states[k + 1, :2], states[k + 1, 2:] * dt
    return float(np.hypot(*((12 * p0 + 6 * v0 - 12 * p1 + 6 * v1) / dt**3)))

