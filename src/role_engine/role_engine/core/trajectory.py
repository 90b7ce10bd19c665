"""Evaluating a process role between its states: cubic Hermite interpolation.

A process role is an (N+1, 4) array of evenly timed states [x, y, vx, vy] over
``total_time``. Between two states the posterior mean of the constant-velocity GP prior
(Eq. 17-19) is the cubic that matches both positions and velocities, i.e. the cubic
Hermite interpolant used here; after ``total_time`` the role rests at its last position.
"""
from __future__ import annotations

import math

import numpy as np

from .errors import RoleEngineError


def check_trajectory(trajectory: np.ndarray) -> np.ndarray:
    """The trajectory as a float (N+1, 4) array of finite states, N >= 1."""
    states = np.asarray(trajectory, dtype=float)
    if states.ndim != 2 or states.shape[1] != 4 or len(states) < 2:
        raise RoleEngineError(f'trajectory: must have shape (N+1, 4) with N >= 1 (got {states.shape})')
    if not np.isfinite(states).all():
        raise RoleEngineError('trajectory: every state must be finite')
    return states


def interpolate(trajectory: np.ndarray, total_time: float, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities and accelerations (each (K, 2)) at ``times`` (K,) in s.

    Times before 0 give the first state; times after ``total_time`` the last position at rest.
    """
    states = check_trajectory(trajectory)
    if not (math.isfinite(total_time) and total_time > 0):
        raise RoleEngineError(f'total_time: must be a finite number > 0 s (got {total_time})')
    times = np.atleast_1d(np.asarray(times, dtype=float))
    intervals = len(states) - 1
    dt = total_time / intervals
    clipped = np.clip(times, 0.0, total_time)
    index = np.minimum((clipped / dt).astype(int), intervals - 1)
    s = (clipped / dt - index)[:, None]
    p0, v0 = states[index, :2], states[index, 2:] * dt
    p1, v1 = states[index + 1, :2], states[index + 1, 2:] * dt
    positions = ((2 * s**3 - 3 * s**2 + 1) * p0 + (s**3 - 2 * s**2 + s) * v0
                 + (-2 * s**3 + 3 * s**2) * p1 + (s**3 - s**2) * v1)
    velocities = ((6 * s**2 - 6 * s) * p0 + (3 * s**2 - 4 * s + 1) * v0
                  + (-6 * s**2 + 6 * s) * p1 + (3 * s**2 - 2 * s) * v1) / dt
    accelerations = ((12 * s - 6) * p0 + (6 * s - 4) * v0 + (-12 * s + 6) * p1 + (6 * s - 2) * v1) / dt**2
    after = times > total_time
    velocities[after] = 0.0
    accelerations[after] = 0.0
    return positions, velocities, accelerations


def densify(trajectory: np.ndarray, total_time: float,
            samples_per_interval: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times (K,), positions (K, 2), velocities (K, 2) with ``samples_per_interval`` steps per interval."""
    states = check_trajectory(trajectory)
    if isinstance(samples_per_interval, bool) or not isinstance(samples_per_interval, (int, np.integer)) \
            or samples_per_interval < 1:
        raise RoleEngineError(f'samples_per_interval: must be an integer >= 1 (got {samples_per_interval!r})')
    times = np.linspace(0.0, total_time, (len(states) - 1) * int(samples_per_interval) + 1)
    positions, velocities, _ = interpolate(states, total_time, times)
    return times, positions, velocities


#: Window of the nearest-path-point search around a role's clock (s behind, s ahead) and its step (s).
PROJECTION_BACK = 3.0
PROJECTION_AHEAD = 1.0
PROJECTION_STEP = 0.02


def nearest_sample(times: np.ndarray, positions: np.ndarray, point, around: float,
                   back: float = PROJECTION_BACK, ahead: float = PROJECTION_AHEAD) -> int:
    """Index of the sample (``times`` (K,) increasing, ``positions`` (K, 2)) nearest ``point`` among those
    timed in ``[around - back, around + ahead]`` (``around`` clipped to the samples' span); the earliest
    of equally near ones. Where a robot is along its role, whatever the role's clock says."""
    around = min(max(float(around), float(times[0])), float(times[-1]))
    low = int(np.searchsorted(times, around - back, side='left'))
    high = int(np.searchsorted(times, around + ahead, side='right'))
    low = min(low, len(times) - 1)
    high = max(high, low + 1)
    distances = np.hypot(*(positions[low:high] - np.asarray(point, dtype=float)).T)
    return low + int(np.argmin(distances))


def nearest_time(trajectory: np.ndarray, total_time: float, point, around: float,
                 step: float = PROJECTION_STEP) -> float:
    """The role time (s from its start, in [0, total_time]) whose position is nearest ``point`` within
    the window of :func:`nearest_sample` around ``around``, on samples ``step`` s apart."""
    times = np.linspace(0.0, total_time, max(2, int(math.ceil(total_time / step)) + 1))
    positions = interpolate(trajectory, total_time, times)[0]
    return float(times[nearest_sample(times, positions, point, around)])
