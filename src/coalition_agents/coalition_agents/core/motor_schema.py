"""Motor schemas (MS): velocity commands from the information a coalition provides (no ROS).

The paper leaves the behaviours to the application ("one only needs to implement the behaviors
(MSs) and specify the required information", Sec. V-A5). Ours, for a differential-drive robot
(commands ``Velocity(linear m/s, angular rad/s)``; the node publishes them on /<robot>/cmd_vel):

* :class:`GoToGoal` -- MS ``navigate`` (Table II: F_G(local), F_G(goal) -> go to the goal):
  turn towards the goal, drive with speed ``max_speed * cos(heading error)``, slowing within
  ``slow_radius``, stop within ``tolerance``.
* :class:`BoxPush` -- MS ``push_box_cooperatively`` (Fig. 10: F_G(local), F_G(box), F_G(goal),
  F_B(local), F_B(Y)): go to a staging point behind the box on the goal-box line, then push
  along it, steering so the box heads for the goal. Synchronisation (the paper: the shared
  bumper information is "used to determine whether the teammate is ready to push, to
  synchronize their behaviors"): in contact, push only while the teammate's bumper is pressed
  too; otherwise hold still and wait for it. Without contact, creep forward until touching.
* :class:`MaintainRelativePosition` -- the helpers' MS ``maintain_relative_position`` (footnote
  14): keep the leader at the relative position it had when the helper started, from the
  helper's own fiducial F_R(leader, helper) -- so a helper that localises the leader keeps it in
  view while it drives, and a pushing teammate beside the leader keeps pace with it. A pushing
  teammate (its bumper given) creeps into contact with the box and keeps pressing on it (at
  least at ``creep_speed``): the leader's BoxPush waits for its bumper, so both push together.
* :class:`HeadingEstimator` -- F_G is a position: a robot localised through a teammate's
  fiducial has no measured heading. The estimate is the direction of its own displacement
  between fixes at least ``min_step`` apart while it drives forward, propagated in between with
  the commanded turn rate (dead reckoning of the command, as odometry would).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import ConfigError
from .information_values import wrap


@dataclass(frozen=True)
class Velocity:
    linear: float = 0.0
    angular: float = 0.0


STOP = Velocity()


def _positive(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ConfigError(f'motor_schema.{name}: must be a number > 0 (got {value!r})')
    return float(value)


def _clip(value: float, bound: float) -> float:
    return max(-bound, min(bound, value))


class HeadingEstimator:
    """Heading from motion between position fixes (module docstring)."""

    def __init__(self, min_step: float = 0.15):
        self.min_step = _positive('heading_min_step', min_step)
        self.heading: float | None = None
        self._anchor: tuple[float, float] | None = None
        self._straight = True

    def measured(self, yaw: float) -> None:
        """A measured heading (the robot's own GPS) replaces the estimate."""
        self.heading = wrap(yaw)

    def commanded(self, command: Velocity, dt: float) -> None:
        """Propagate with the command sent for the last ``dt`` seconds."""
        if self.heading is not None:
            self.heading = wrap(self.heading + command.angular * dt)
        if command.linear <= 0.0 or abs(command.angular) > 0.6:
            # Reversing or turning sharply: the next displacement is not along the heading.
            self._anchor = None

    def fix(self, x: float, y: float) -> float | None:
        """A position fix; returns the current heading estimate (None before the first)."""
        if self._anchor is None:
            self._anchor = (x, y)
            return self.heading
        dx, dy = x - self._anchor[0], y - self._anchor[1]
        if math.hypot(dx, dy) >= self.min_step:
            self.heading = math.atan2(dy, dx)
            self._anchor = (x, y)
        return self.heading


class GoToGoal:
    """MS navigate: drive to ``goal`` (module docstring)."""

    def __init__(self, max_speed: float = 0.4, max_turn: float = 1.2, gain: float = 1.5,
                 slow_radius: float = 0.6, tolerance: float = 0.2, probe_speed: float = 0.15):
        self.max_speed = _positive('max_speed', max_speed)
        self.max_turn = _positive('max_turn', max_turn)
        self.gain = _positive('gain', gain)
        self.slow_radius = _positive('slow_radius', slow_radius)
        self.tolerance = _positive('tolerance', tolerance)
        self.probe_speed = _positive('probe_speed', probe_speed)

    def distance(self, position: tuple[float, float], goal: tuple[float, float]) -> float:
        return math.hypot(goal[0] - position[0], goal[1] - position[1])

    def command(self, position: tuple[float, float], heading: float | None, goal: tuple[float, float]) -> Velocity:
        distance = self.distance(position, goal)
        if distance <= self.tolerance:
            return STOP
        if heading is None:
            # drive straight to learn the heading, within the speed limit
            return Velocity(min(self.probe_speed, self.max_speed), 0.0)
        error = wrap(math.atan2(goal[1] - position[1], goal[0] - position[0]) - heading)
        speed = self.max_speed * max(0.0, math.cos(error)) * min(1.0, distance / self.slow_radius)
        return Velocity(speed, _clip(self.gain * error, self.max_turn))


@dataclass(frozen=True)
class BoxPushState:
    """What :class:`BoxPush` decided, for status and logs."""

    phase: str            # approach | align | push | wait_teammate | done
    box_to_goal: float    # m


class BoxPush:
    """MS push_box_cooperatively (module docstring). ``standoff``: how far behind the box centre
    the robot centre stands when touching it (half the box depth + the robot radius);
    ``lateral_offset``: where along the box's back face this robot pushes (+ = left of the
    push direction), so that two pushers stand side by side."""

    def __init__(self, standoff: float, lateral_offset: float = 0.0, tolerance: float = 0.3,
                 staging_margin: float = 0.35, max_speed: float = 0.25, line_tolerance: float = 0.6,
                 drive: GoToGoal | None = None):
        self.standoff = _positive('standoff', standoff)
        self.lateral_offset = float(lateral_offset)
        self.tolerance = _positive('box_tolerance', tolerance)
        self.staging_margin = _positive('staging_margin', staging_margin)
        self.max_speed = _positive('push_speed', max_speed)
        self.line_tolerance = _positive('line_tolerance', line_tolerance)
        self.drive = drive or GoToGoal(max_speed=0.3, tolerance=0.08, slow_radius=0.3)
        self.phase = 'approach'

    def _frame(self, box, goal):
        ux, uy = goal[0] - box[0], goal[1] - box[1]
        norm = math.hypot(ux, uy)
        return (ux / norm, uy / norm) if norm > 1e-9 else (1.0, 0.0)

    def command(self, position, heading: float | None, box, goal, pressed: bool,
                teammate_pressed: bool | None) -> tuple[Velocity, BoxPushState]:
        """``teammate_pressed`` None: pushing alone (no teammate in the coalition)."""
        box_to_goal = math.hypot(goal[0] - box[0], goal[1] - box[1])
        if box_to_goal <= self.tolerance:
            self.phase = 'done'
            return STOP, BoxPushState('done', box_to_goal)
        ux, uy = self._frame(box, goal)
        lx, ly = -uy, ux  # left of the push direction
        # Robot position in the push frame: along (u, from the box centre) and across (l).
        rx, ry = position[0] - box[0], position[1] - box[1]
        along, across = rx * ux + ry * uy, rx * lx + ry * ly
        behind = along < -0.5 * self.standoff and abs(across - self.lateral_offset) < self.line_tolerance
        if self.phase in ('push', 'wait_teammate', 'align') and not behind:
            self.phase = 'approach'  # the box turned away or slid off: go around again
        if heading is None:
            return Velocity(self.drive.probe_speed, 0.0), BoxPushState('approach', box_to_goal)
        if self.phase == 'approach' and behind and along >= -(self.standoff + self.staging_margin + self.drive.tolerance):
            self.phase = 'align'  # already between the staging point and the box
        if self.phase == 'approach':
            stage = (box[0] - ux * (self.standoff + self.staging_margin) + lx * self.lateral_offset,
                     box[1] - uy * (self.standoff + self.staging_margin) + ly * self.lateral_offset)
            if self.drive.distance(position, stage) > self.drive.tolerance:
                return self.drive.command(position, heading, stage), BoxPushState('approach', box_to_goal)
            self.phase = 'align'
        push_heading = math.atan2(uy, ux)
        if self.phase == 'align':
            error = wrap(push_heading - heading)
            if abs(error) > 0.15:
                return Velocity(0.0, _clip(2.0 * error, self.drive.max_turn)), BoxPushState('align', box_to_goal)
            self.phase = 'push'
        # Push: aim at a point ahead on the box-goal line through our pushing spot, so the box
        # is driven along the line (the across error steers back onto it).
        target = (goal[0] + lx * self.lateral_offset, goal[1] + ly * self.lateral_offset)
        error = wrap(math.atan2(target[1] - position[1], target[0] - position[0]) - heading)
        turn = _clip(1.5 * error, 0.6)
        if not pressed:
            self.phase = 'push'
            return Velocity(0.5 * self.max_speed, turn), BoxPushState('push', box_to_goal)  # creep into contact
        if teammate_pressed is False:
            self.phase = 'wait_teammate'
            return STOP, BoxPushState('wait_teammate', box_to_goal)
        self.phase = 'push'
        return Velocity(self.max_speed * max(0.2, math.cos(error)), turn), BoxPushState('push', box_to_goal)


class MaintainRelativePosition:
    """Helper MS: keep the leader at ``target`` (x forward, y left, m) in the helper's frame, from
    the helper's fiducial reading of the leader (module docstring)."""

    def __init__(self, target: tuple[float, float], max_speed: float = 0.35, max_turn: float = 1.0,
                 gain: float = 1.2, tolerance: float = 0.1, creep_speed: float = 0.08, search_turn: float = 0.4):
        self.target = (float(target[0]), float(target[1]))
        self.search_turn = _positive('search_turn', search_turn)
        #: bearing (rad, helper frame) at which the leader was last seen
        self.last_bearing: float | None = None
        self.creep_speed = _positive('creep_speed', creep_speed)
        self.max_speed = _positive('follow_max_speed', max_speed)
        self.max_turn = _positive('follow_max_turn', max_turn)
        self.gain = _positive('follow_gain', gain)
        self.tolerance = _positive('follow_tolerance', tolerance)

    def command(self, leader: tuple[float, float] | None, pressed: bool | None = None) -> Velocity:
        """``leader``: the leader's position in the helper's frame (None: not seen now: turn on
        the spot towards where it was last seen, so that a leader that left the fiducial's field
        of view -- a helper keeping it abeam has it at the edge -- comes back into view; never
        seen: stop). ``pressed``: for a pushing teammate (box pushing), its own bumper -- out of
        contact it creeps forward into it (the leader waits for that, :class:`BoxPush`), in
        contact it never backs off the box."""
        if leader is None:
            if self.last_bearing is None:
                return STOP
            return Velocity(0.0, math.copysign(self.search_turn, self.last_bearing))
        self.last_bearing = math.atan2(leader[1], leader[0])
        ex, ey = leader[0] - self.target[0], leader[1] - self.target[1]
        # Keep the leader's bearing where it was (turn) and its forward distance (drive).
        bearing_error = wrap(math.atan2(leader[1], leader[0]) - math.atan2(self.target[1], self.target[0]))
        turn = _clip(self.gain * bearing_error, self.max_turn)
        if pressed is False:
            return Velocity(max(self.creep_speed, _clip(self.gain * ex, self.max_speed)), turn)
        if pressed:  # keep pressing (at least creeping) so the leader sees its teammate ready
            return Velocity(min(max(self.gain * ex, self.creep_speed), self.max_speed), turn)
        if math.hypot(ex, ey) <= self.tolerance:
            return STOP
        return Velocity(_clip(self.gain * ex, self.max_speed), turn)


__all__ = ['BoxPush', 'BoxPushState', 'GoToGoal', 'HeadingEstimator', 'MaintainRelativePosition', 'STOP',
           'Velocity', 'wrap']
