"""Conflict field among time-indexed process roles (``MakeConflictField``, Algorithm 4 line 3, Fig. 5).

Robot j at time t compares its own process role with the others' (from the shared
channel) over the coming ``horizon``: at every sampled time tau, another robot i is in
conflict when its role brings it closer to j's role at that same tau than their two
radii plus ``clearance``. The places robot i occupies at those conflicting times (discs
of radius r_i around its role positions) form the conflict area, the gray area of Fig. 5.
For robot j's planner they are obstacles in its configuration space, i.e. grown by j's
own inflation radius, and added to its map: the result is the new SDF of Algorithm 4.

The role-playing update (:mod:`.role_playing`) uses :func:`find_conflicts` for the same
comparison but keeps the others *time-indexed* (moving obstacles at the same time) instead
of adding their discs to a static SDF: a static disc on the other's path blocks a detour at
every time, also when the other robot is long gone.

Where the paper is silent: without j's own role (``own=None``) every position of the
others within the horizon counts; times beyond a role's end hold its last position.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .environment import RobotEnvironment
from .errors import RoleEngineError
from .sdf import SignedDistanceField
from .trajectory import check_trajectory, interpolate


@dataclass(frozen=True)
class SharedRole:
    """A process role as published on the shared channel, timed from ``start_time`` (s)."""

    name: str
    trajectory: np.ndarray
    total_time: float
    radius: float
    start_time: float = 0.0

    def positions(self, times: np.ndarray) -> np.ndarray:
        return interpolate(self.trajectory, self.total_time, np.asarray(times) - self.start_time)[0]


@dataclass
class ConflictField:
    """The conflict area (grid of ``robot_env``) and robot j's SDF with it added."""

    area: np.ndarray
    sdf: SignedDistanceField
    conflicting: list[str]


def _check_role(role: SharedRole) -> None:
    check_trajectory(role.trajectory)
    if not (math.isfinite(role.total_time) and role.total_time > 0):
        raise RoleEngineError(f'shared role {role.name!r}.total_time: must be a finite number > 0 (got {role.total_time})')
    if not (math.isfinite(role.radius) and role.radius >= 0):
        raise RoleEngineError(f'shared role {role.name!r}.radius: must be a finite number >= 0 (got {role.radius})')


@dataclass(frozen=True)
class RoleConflict:
    """Another robot's role in conflict with the own one: when they first and last come too close."""

    name: str
    first_time: float
    last_time: float
    min_gap: float          # smallest centre distance minus both radii over the sampled times [m]


def check_conflict_window(t: float, horizon: float, samples: int, clearance: float) -> None:
    if not (math.isfinite(t) and math.isfinite(horizon) and horizon >= 0):
        raise RoleEngineError(f'conflict field: t and horizon must be finite, horizon >= 0 (got {t}, {horizon})')
    if samples < 1 or not (math.isfinite(clearance) and clearance >= 0):
        raise RoleEngineError(f'conflict field: samples >= 1 and clearance >= 0 (got {samples}, {clearance})')


def find_conflicts(own: SharedRole, others: list[SharedRole], t: float, *, horizon: float = 3.0,
                   samples: int = 15, clearance: float = 0.05) -> list[RoleConflict]:
    """The others whose roles come closer to ``own`` than both radii plus ``clearance`` at the same
    sampled time in ``[t, t + horizon]`` (the comparison of MakeConflictField), earliest first."""
    check_conflict_window(t, horizon, samples, clearance)
    for role in others + [own]:
        _check_role(role)
    times = t + np.linspace(0.0, horizon, samples + 1)
    own_positions = own.positions(times)
    conflicts = []
    for role in others:
        gap = np.hypot(*(role.positions(times) - own_positions).T) - role.radius - own.radius
        close = np.flatnonzero(gap < clearance)
        if close.size:
            conflicts.append(RoleConflict(role.name, float(times[close[0]]), float(times[close[-1]]),
                                          float(gap.min())))
    return sorted(conflicts, key=lambda c: (c.first_time, c.name))


def make_conflict_field(robot_env: RobotEnvironment, others: list[SharedRole], t: float, *,
                        own: SharedRole | None = None, horizon: float = 3.0, samples: int = 15,
                        clearance: float = 0.05) -> ConflictField:
    """Conflict area of the ``others`` around time ``t`` and robot j's SDF with it (module docstring)."""
    check_conflict_window(t, horizon, samples, clearance)
    for role in others + ([own] if own is not None else []):
        _check_role(role)
    frame = robot_env.frame
    own_inflation = robot_env.robot_type.inflation
    times = t + np.linspace(0.0, horizon, samples + 1)
    own_positions = own.positions(times) if own is not None else None
    own_radius = own.radius if own is not None else robot_env.robot_type.radius
    area = np.zeros(frame.shape, dtype=bool)
    blocked = np.zeros(frame.shape, dtype=bool)
    conflicting = []
    ny, nx = frame.shape
    for role in others:
        positions = role.positions(times)
        if own_positions is not None:
            gap = np.hypot(*(positions - own_positions).T)
            positions = positions[gap < role.radius + own_radius + clearance]
        if len(positions) == 0:
            continue
        conflicting.append(role.name)
        for radius, target in ((role.radius, area), (role.radius + own_inflation, blocked)):
            reach = int(math.ceil(radius / frame.resolution)) + 1
            for centre_cell, centre in zip(frame.world_to_cell(positions), positions):
                y0, x0 = np.maximum(centre_cell - reach, 0)
                y1, x1 = np.minimum(centre_cell + reach + 1, [ny, nx])
                if y0 >= y1 or x0 >= x1:
                    continue
                iy, ix = np.mgrid[y0:y1, x0:x1]
                world = frame.cell_to_world(np.column_stack([iy.ravel(), ix.ravel()]))
                inside = np.hypot(*(world - centre).T) <= radius
                target[iy.ravel()[inside], ix.ravel()[inside]] = True
    sdf = SignedDistanceField.from_occupancy(robot_env.inflated | blocked, frame.resolution, frame.origin,
                                             border_is_obstacle=robot_env.environment.border_is_obstacle)
    return ConflictField(area, sdf, conflicting)
