"""Problem detection of the central computer (Algorithm 1, "detect a problem"): silent, stuck, off role.

The role engine feeds a :class:`ProblemWatch` with what it hears and sees -- every process
role a robot publishes on the shared channel (:meth:`ProblemWatch.heard`) and every
camera-tracked position (:meth:`ProblemWatch.observed`) -- and asks it for the
:meth:`~ProblemWatch.problems` at the current time. A robot of the current round has a
problem when it is

* **silent**: no process role for ``silence_timeout`` s (counted from the roles' start time
  for a robot never heard);
* **stuck**: its tracked position stayed within ``stuck_distance`` of where it was
  ``stuck_time`` s ago, while its roles asked it to move more than ``stuck_distance`` over
  that time (at each observation the latest role's speed there, or the speed needed to
  reach where that role puts it within ``stuck_time`` s, integrated over the window; role
  players re-plan from where they are, so the role's own positions do not tell);
* **off role**: its tracked position has been farther than ``off_role_distance`` from where
  its latest process role puts it now for more than ``off_role_grace`` s.

Where the paper is silent: a robot that has reported ``arrived``, or whose role has not
started yet (or started less than ``stuck_time`` s ago), is never stuck or off role; a
robot whose role tells it to wait (e.g. to let another one pass) is not stuck, because its
role does not ask it to move; an observation older than ``stuck_time`` s is not used for
the off-role check (nothing recent is known). A condition that clears (the robot moves
again, comes back to its role) is no longer reported.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from collab_tools.core.fields import Fields

from .conflict import SharedRole
from .errors import RoleEngineError, check_real
from .trajectory import interpolate

PROBLEM_KINDS = ('silent', 'stuck', 'off_role')


@dataclass(frozen=True)
class ProblemSettings:
    """Thresholds of :class:`ProblemWatch` (module docstring); all finite, times in s, distances in m."""

    silence_timeout: float = 4.0
    stuck_distance: float = 0.1
    stuck_time: float = 8.0
    off_role_distance: float = 0.6
    off_role_grace: float = 4.0

    def __post_init__(self) -> None:
        for name in ('silence_timeout', 'stuck_distance', 'stuck_time', 'off_role_distance'):
            check_real(getattr(self, name), f'problem_detection.{name}', positive=True)
        check_real(self.off_role_grace, 'problem_detection.off_role_grace', non_negative=True)

    @classmethod
    def from_mapping(cls, data: Any, path: str = 'problem_detection', *,
                     silence_timeout: float = 4.0) -> 'ProblemSettings':
        """From a settings-file mapping (``silence_timeout`` is a top-level field of the task)."""
        fields = Fields(data if data is not None else {}, path,
                        allowed=('stuck_distance', 'stuck_time', 'off_role_distance', 'off_role_grace'),
                        error=RoleEngineError)
        return cls(silence_timeout=silence_timeout,
                   stuck_distance=fields.number('stuck_distance', cls.stuck_distance, gt=0.0),
                   stuck_time=fields.number('stuck_time', cls.stuck_time, gt=0.0),
                   off_role_distance=fields.number('off_role_distance', cls.off_role_distance, gt=0.0),
                   off_role_grace=fields.number('off_role_grace', cls.off_role_grace, ge=0.0))


@dataclass(frozen=True)
class Problem:
    """One robot's problem: ``kind`` is one of :data:`PROBLEM_KINDS`, ``detail`` says why."""

    robot: str
    kind: str
    detail: str

    def __str__(self) -> str:
        return f'{self.robot} {self.detail}'


@dataclass
class _RobotState:
    role: SharedRole
    started: float                 # start time of the round's initial role (later roles restart from 'now')
    last_heard: float
    arrived: bool = False
    track: deque = None            # (t, x, y) observations, oldest first
    off_since: float | None = None


class ProblemWatch:
    """Who of the current round is silent, stuck or off role (module docstring)."""

    def __init__(self, settings: ProblemSettings):
        if not isinstance(settings, ProblemSettings):
            raise RoleEngineError(f'settings: must be ProblemSettings (got {type(settings).__name__})')
        self.settings = settings
        self._robots: dict[str, _RobotState] = {}

    @property
    def robots(self) -> list[str]:
        return sorted(self._robots)

    def expect(self, roles: dict[str, SharedRole]) -> None:
        """A new round: these robots play these initial roles (silence counts from their start)."""
        self._robots = {name: _RobotState(role, float(role.start_time), float(role.start_time), track=deque())
                        for name, role in roles.items()}

    def heard(self, robot: str, t: float, role: SharedRole | None = None, arrived: bool = False) -> None:
        """A process role of ``robot`` arrived at ``t`` (its heartbeat); robots of other rounds are ignored."""
        state = self._robots.get(robot)
        if state is None:
            return
        state.last_heard = max(state.last_heard, float(t))
        if role is not None:
            state.role = role
        state.arrived = state.arrived or bool(arrived)

    def observed(self, robot: str, t: float, position) -> None:
        """The camera saw ``robot`` at ``position`` (x, y) at ``t``."""
        state = self._robots.get(robot)
        point = np.asarray(position, dtype=float)
        if state is None or point.shape != (2,) or not np.isfinite(point).all() or not math.isfinite(t):
            return
        if state.track and t < state.track[-1][0]:
            return                                     # out of order: keep the history monotonic
        state.track.append((float(t), float(point[0]), float(point[1]), self._asked_speed(state, t, point)))
        # Keep one sample at or before the stuck window's start, drop older ones.
        while len(state.track) >= 2 and state.track[1][0] <= t - self.settings.stuck_time:
            state.track.popleft()

    def _asked_speed(self, state: _RobotState, t: float, point: np.ndarray) -> float:
        """How fast the latest role asks the robot to move at ``t``: its speed there, or the speed
        needed to reach where it should be within ``stuck_time`` (a role that has ended far away)."""
        if t < state.started:
            return 0.0
        role = state.role
        positions, velocities, _ = interpolate(role.trajectory, role.total_time, [t - role.start_time])
        return max(float(np.hypot(*velocities[0])),
                   float(np.hypot(*(positions[0] - point))) / self.settings.stuck_time)

    def problems(self, t: float) -> list[Problem]:
        """The problems at time ``t``, sorted by robot (at most one per robot: silent > stuck > off role)."""
        found = []
        for name in sorted(self._robots):
            problem = self._silent(name, t) or self._stuck(name, t) or self._off_role(name, t)
            if problem is not None:
                found.append(problem)
        return found

    def _silent(self, name: str, t: float) -> Problem | None:
        state = self._robots[name]
        quiet = t - state.last_heard
        if quiet > self.settings.silence_timeout:
            return Problem(name, 'silent', f'went silent (no process role for {quiet:.1f} s)')
        return None

    def _moving_expected(self, state: _RobotState, t: float) -> bool:
        return not state.arrived and bool(state.track) and t >= state.started

    def _stuck(self, name: str, t: float) -> Problem | None:
        state, settings = self._robots[name], self.settings
        if not self._moving_expected(state, t) or t - state.started < settings.stuck_time:
            return None
        t0, x0, y0, _ = state.track[0]
        if t0 > t - settings.stuck_time:
            return None                                # not watched for a whole window yet
        moved = max(math.dist((x0, y0), (x, y)) for _, x, y, _ in state.track)
        if moved > settings.stuck_distance:
            return None
        samples = np.array([(ts, asked) for ts, _, _, asked in state.track])
        asked = float(np.sum(np.diff(samples[:, 0]) * 0.5 * (samples[1:, 1] + samples[:-1, 1])))
        if asked <= settings.stuck_distance:
            return None                                # its role lets it wait here
        return Problem(name, 'stuck', f'is stuck (moved {moved:.2f} m in {t - t0:.1f} s while its role asked '
                                      f'for {asked:.2f} m)')

    def _off_role(self, name: str, t: float) -> Problem | None:
        state, settings = self._robots[name], self.settings
        if not self._moving_expected(state, t):
            state.off_since = None
            return None
        seen, x, y, _ = state.track[-1]
        if t - seen > settings.stuck_time:
            return None
        expected = state.role.positions([seen])[0]
        off = math.dist((x, y), expected)
        if off <= settings.off_role_distance:
            state.off_since = None
            return None
        if state.off_since is None:
            state.off_since = seen
        if t - state.off_since > settings.off_role_grace:
            return Problem(name, 'off_role', f'is off its role ({off:.2f} m from where it should be for '
                                             f'{t - state.off_since:.1f} s)')
        return None
