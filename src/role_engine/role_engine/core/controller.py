"""Following a process role with a differential-drive robot (Sec. V-B).

The process role gives positions and velocities only; the paper drives the robots with
a separate kinematic controller (ref. [26]) that turns them into linear and angular
velocity commands. Used here: the classic unicycle tracking law of Kanayama et al.
(1990). With the reference pose (x_r, y_r, theta_r) and velocities (v_r, w_r) taken
from the role at time t (heading and turn rate from its velocity and acceleration) and
the error expressed in the robot frame (e_x ahead, e_y left, e_theta):

    v = v_r cos(e_theta) + k_x e_x
    w = w_r + v_r (k_y e_y + k_theta sin(e_theta))

The command is then clamped to the robot type's limits (``max_linear_velocity``,
``max_angular_velocity``; the bridge clamps accelerations itself). Where the reference
is (nearly) at rest its heading is undefined: the robot then turns toward the reference
point when it is more than ``position_tolerance`` away, else stops.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .environment import RobotType
from .errors import RoleEngineError
from .trajectory import check_trajectory, interpolate

#: Reference speed (m/s) below which the reference heading is taken as undefined.
REST_SPEED = 1e-3


@dataclass(frozen=True)
class TrackingGains:
    """Gains of the tracking law: k_x (1/s), k_y (1/m^2), k_theta (1/m)."""

    k_x: float = 1.5
    k_y: float = 8.0
    k_theta: float = 3.0
    #: Proportional gains of the at-rest approach: linear (1/s) and turning (1/s).
    k_approach: float = 1.0
    k_turn: float = 2.0

    def __post_init__(self) -> None:
        for name in ('k_x', 'k_y', 'k_theta', 'k_approach', 'k_turn'):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise RoleEngineError(f'gains.{name}: must be a finite number > 0 (got {value!r})')


def wrap_angle(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class TrajectoryFollower:
    """Turns a process role and the robot's pose into (linear, angular) velocity commands."""

    def __init__(self, trajectory: np.ndarray, total_time: float, robot_type: RobotType, *,
                 gains: TrackingGains = TrackingGains(), position_tolerance: float = 0.03):
        self.states = check_trajectory(trajectory)
        if not (math.isfinite(total_time) and total_time > 0):
            raise RoleEngineError(f'total_time: must be a finite number > 0 s (got {total_time})')
        if not (math.isfinite(position_tolerance) and position_tolerance > 0):
            raise RoleEngineError(f'position_tolerance: must be a finite number > 0 m (got {position_tolerance})')
        self.total_time = float(total_time)
        self.robot_type = robot_type
        self.gains = gains
        self.position_tolerance = position_tolerance

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration of the role at time ``t`` (s from its start)."""
        positions, velocities, accelerations = interpolate(self.states, self.total_time, [t])
        return positions[0], velocities[0], accelerations[0]

    def finished(self, t: float, pose) -> bool:
        """The role is over and the robot stands within ``position_tolerance`` of its end."""
        return t >= self.total_time and math.dist(pose[:2], self.states[-1, :2]) <= self.position_tolerance

    def command(self, t: float, pose) -> tuple[float, float]:
        """(linear m/s, angular rad/s) for the robot at ``pose`` = (x, y, yaw) at time ``t``."""
        x, y, yaw = (float(v) for v in pose)
        if not all(math.isfinite(v) for v in (x, y, yaw, t)):
            raise RoleEngineError(f'controller: pose and time must be finite (got {pose}, {t})')
        position, velocity, acceleration = self.reference(t)
        dx, dy = position[0] - x, position[1] - y
        e_x = math.cos(yaw) * dx + math.sin(yaw) * dy
        e_y = -math.sin(yaw) * dx + math.cos(yaw) * dy
        speed = float(np.hypot(*velocity))
        gains = self.gains
        if speed < REST_SPEED:
            distance = math.hypot(dx, dy)
            if distance <= self.position_tolerance:
                return 0.0, 0.0
            bearing = wrap_angle(math.atan2(dy, dx) - yaw)
            # Drive only while roughly facing the point, so the robot never swings wide.
            linear = gains.k_approach * distance * max(math.cos(bearing), 0.0) ** 2
            return self._clamp(linear, gains.k_turn * bearing)
        heading = math.atan2(velocity[1], velocity[0])
        turn_rate = (velocity[0] * acceleration[1] - velocity[1] * acceleration[0]) / speed**2
        e_theta = wrap_angle(heading - yaw)
        linear = speed * math.cos(e_theta) + gains.k_x * e_x
        angular = turn_rate + speed * (gains.k_y * e_y + gains.k_theta * math.sin(e_theta))
        return self._clamp(linear, angular)

    def _clamp(self, linear: float, angular: float) -> tuple[float, float]:
        limit_v = self.robot_type.max_linear_velocity
        limit_w = self.robot_type.max_angular_velocity
        if limit_v is not None:
            linear = min(max(linear, -limit_v), limit_v)
        if limit_w is not None:
            angular = min(max(angular, -limit_w), limit_w)
        return float(linear), float(angular)
