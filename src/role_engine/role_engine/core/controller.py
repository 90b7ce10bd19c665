"""Following a process role with a differential-drive robot (Sec. V-B).

The process role gives positions and velocities only; the paper drives the robots with
a separate kinematic controller (ref. [26]) that turns them into linear and angular
velocity commands. Used here: the unicycle tracking law of Kanayama et al. (1990), applied
to the point of the role's *path* nearest the robot rather than to the point the role's
clock names. With the reference pose (x_r, y_r, theta_r) at the projection time tau (the
time in ``[t - PROJECTION_BACK, t + PROJECTION_AHEAD]``, t clipped to the role, whose role
position is nearest the robot: trajectory.nearest_sample), the path's curvature kappa and
speed v_r there, the error in the robot frame (e_x ahead, e_y left, e_theta) and the lag
``l`` = arc length of the role from tau to t (> 0: the role's clock is ahead of the robot):

    v = v_r cos(e_theta) + k_x (e_x + l),  |v| <= CATCH_UP max(v_r, v_r(t))
    w = kappa v + v_r (k_y e_y + k_theta sin(e_theta))

(the speed cap: a robot that lags catches up at most CATCH_UP times as fast as its role -- which
the GP keeps under its speed limit -- not in a sprint at the platform's limit through a narrow passage, which is
where a lagging robot overshot its goal and touched the pillars before).

Why the projection: a robot that lags behind its role and steers at the clock's point cuts
every bend (the point lies round the corner, so the lateral error points across the
inside of the bend) -- into the obstacle the role was planned to clear by the GP's epsilon.
Measured against the nearest path point the lateral error stays the robot's distance from
the planned path, and the lag only sets the speed (the robot catches up along the path).
Where the path is (nearly) at rest at tau (its start, a waiting spot, its end), the clock's
point is tracked as in Kanayama's law (tau = t); a robot still short of the end of a role
whose time is over keeps following the path to it, until it is within ``REVERSE_DISTANCE`` of
the end: then it approaches the end point directly (forward, or backward when it lies behind: a
re-plan that started fast overshot the goal and turned back, and at the turning point the path's
heading flipped with every pose).

The command is then clamped to the robot type's limits (``max_linear_velocity``,
``max_angular_velocity``; the bridge clamps accelerations itself). Where the reference
is (nearly) at rest at t its heading is undefined: the robot then turns toward the reference
point when it is more than ``position_tolerance`` away, else stops.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .environment import RobotType
from .errors import RoleEngineError
from .trajectory import PROJECTION_STEP, check_trajectory, interpolate, nearest_sample

#: Reference speed (m/s) below which the reference heading is taken as undefined.
REST_SPEED = 1e-3
#: A lagging robot drives at most this many times the role's speed (here or at its clock).
CATCH_UP = 1.5
#: Heading error [rad] beyond which the robot turns in place toward its path before driving on
#: (the rotate-to-heading threshold of Nav2's RotationShimController, 45 deg).
ALIGN_ANGLE = math.pi / 4
#: Deceleration [m/s^2] the speed near the role's end is planned with: half a Pioneer's 1 m/s^2, so
#: the camera's latency and the command period still fit in the stop.
APPROACH_DECELERATION = 0.5
#: A point at rest at most this far behind the robot [m] is approached backward (an overshoot).
REVERSE_DISTANCE = 0.5
#: Within this of +-pi [rad] a turn in place keeps its direction (the sign of the error is noise there).
FLIP_MARGIN = 0.5
#: Fastest turn in place [rad/s] (Nav2's rotate_to_heading_angular_vel): faster, a robot with a
#: Pioneer's 3 rad/s^2 cannot stop the turn in time and swings past the heading, back and forth.
ROTATE_SPEED = 1.8


@dataclass(frozen=True)
class TrackingGains:
    """Gains of the tracking law: k_x (1/s), k_y (1/m^2), k_theta (1/m)."""

    k_x: float = 1.5
    k_y: float = 20.0
    k_theta: float = 5.0
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
        self._turning = 0.0          # sign of the last turn in place (0: not turning in place)
        # The role sampled densely once: positions, velocities, accelerations and arc length.
        self._times = np.linspace(0.0, self.total_time, max(2, int(math.ceil(self.total_time / PROJECTION_STEP)) + 1))
        self._positions, self._velocities, self._accelerations = interpolate(self.states, self.total_time,
                                                                             self._times)
        # The role rests at its end from total_time on (trajectory.interpolate): so does its last sample.
        self._velocities[-1] = 0.0
        self._accelerations[-1] = 0.0
        steps = np.hypot(*np.diff(self._positions, axis=0).T)
        self._arc = np.concatenate([[0.0], np.cumsum(steps)])

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration of the role at time ``t`` (s from its start)."""
        positions, velocities, accelerations = interpolate(self.states, self.total_time, [t])
        return positions[0], velocities[0], accelerations[0]

    def finished(self, t: float, pose) -> bool:
        """The role is over and the robot stands within ``position_tolerance`` of its end."""
        return t >= self.total_time and math.dist(pose[:2], self.states[-1, :2]) <= self.position_tolerance

    def projection(self, t: float, point) -> int:
        """Index (into the dense samples) of the role position nearest ``point`` within
        ``[t - PROJECTION_BACK, t + PROJECTION_AHEAD]`` (t clipped to the role; trajectory.nearest_sample)."""
        return nearest_sample(self._times, self._positions, point, t)

    def command(self, t: float, pose) -> tuple[float, float]:
        """(linear m/s, angular rad/s) for the robot at ``pose`` = (x, y, yaw) at time ``t`` (module docstring)."""
        x, y, yaw = (float(v) for v in pose)
        if not all(math.isfinite(v) for v in (x, y, yaw, t)):
            raise RoleEngineError(f'controller: pose and time must be finite (got {pose}, {t})')
        gains = self.gains
        k = self.projection(t, (x, y))
        lag = 0.0
        near_end = t >= self.total_time and math.dist((x, y), self.states[-1, :2]) <= REVERSE_DISTANCE
        if float(np.hypot(*self._velocities[k])) >= REST_SPEED and not near_end:
            # Follow the path from the nearest point; the role's clock only sets the speed.
            position, velocity, acceleration = self._positions[k], self._velocities[k], self._accelerations[k]
            lag = float(np.interp(min(t, self.total_time), self._times, self._arc) - self._arc[k])
        else:
            position, velocity, acceleration = self.reference(t)
        speed = float(np.hypot(*velocity))
        # At most CATCH_UP x what the role asks for, here or at its clock: a robot that lags catches up
        # a little faster than its role, not in a sprint at the platform's limit through a narrow passage.
        cruise = CATCH_UP * max(speed, float(np.hypot(*self.reference(t)[1])))
        dx, dy = position[0] - x, position[1] - y
        if speed < REST_SPEED:
            distance = math.hypot(dx, dy)
            if distance <= self.position_tolerance:
                return 0.0, 0.0
            bearing = wrap_angle(math.atan2(dy, dx) - yaw)
            direction = 1.0
            if abs(bearing) > math.pi / 2 and distance <= REVERSE_DISTANCE:
                # Just past the point (an overshoot): back up to it. Turning round instead, a bearing
                # near +-pi flips sign with every noisy pose, and the robot stood turning neither way.
                bearing, direction = wrap_angle(bearing - math.pi), -1.0
            # Drive only while roughly facing the point (or its back to it), so the robot never swings wide.
            linear = direction * gains.k_approach * distance * max(math.cos(bearing), 0.0) ** 2
            return self._clamp(linear, self._turn_toward(bearing))
        e_x = math.cos(yaw) * dx + math.sin(yaw) * dy
        e_y = -math.sin(yaw) * dx + math.cos(yaw) * dy
        heading = math.atan2(velocity[1], velocity[0])
        curvature = (velocity[0] * acceleration[1] - velocity[1] * acceleration[0]) / speed**3
        e_theta = wrap_angle(heading - yaw)
        if abs(e_theta) > ALIGN_ANGLE:
            # Turn in place first: a unicycle driving while it turns that far sweeps a wide arc off
            # its path (or backs up along the wrong one) before the lateral terms catch it.
            return self._clamp(0.0, self._turn_toward(e_theta))
        self._turning = 0.0
        # Catching up, never faster than a stop at APPROACH_DECELERATION allows before the role's end (a
        # lagging robot otherwise ran past its goal); the role's own speed there is always allowed.
        to_end = max(self._arc[-1] - self._arc[k] + e_x, 0.0)
        cruise = min(cruise, max(speed, math.sqrt(2.0 * APPROACH_DECELERATION * to_end)))
        linear = min(max(speed * math.cos(e_theta) + gains.k_x * (e_x + lag), -cruise), cruise)
        linear, _ = self._clamp(linear, 0.0)
        angular = curvature * linear + speed * (gains.k_y * e_y + gains.k_theta * math.sin(e_theta))
        limit_w = self.robot_type.max_angular_velocity
        if limit_w is not None and abs(angular) > limit_w:
            # Saturated turning keeps the commanded curvature: slower on the same arc, not straight on.
            linear *= limit_w / abs(angular)
        return self._clamp(linear, angular)

    def _turn_toward(self, angle: float) -> float:
        """Turning rate toward a heading error ``angle``. Near +-pi the error's sign flips with every
        noisy pose; the robot then keeps turning the way it already turns instead of standing still."""
        if self._turning and abs(angle) > math.pi - FLIP_MARGIN:
            angle = math.copysign(abs(angle), self._turning)
        self._turning = math.copysign(1.0, angle) if angle else 0.0
        return min(max(self.gains.k_turn * angle, -ROTATE_SPEED), ROTATE_SPEED)

    def _clamp(self, linear: float, angular: float) -> tuple[float, float]:
        limit_v = self.robot_type.max_linear_velocity
        limit_w = self.robot_type.max_angular_velocity
        if limit_v is not None:
            linear = min(max(linear, -limit_v), limit_v)
        if limit_w is not None:
            angular = min(max(angular, -limit_w), limit_w)
        return float(linear), float(angular)
