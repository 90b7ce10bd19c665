"""One robot's role player (Algorithm 4 lines 2-7) as a pure class: the role_player node and the
``roles-collab`` simulation drive the same :class:`RolePlayer`.

Events in (typed, from whatever transport carries them):

* :meth:`RolePlayer.on_assignment` -- a negotiation round (:class:`RoundAssignment`): the
  robot's own initial process role, or none (left out, infeasible, aborted: the robot stops);
* :meth:`RolePlayer.on_role` -- another robot's process role from the shared channel;
* :meth:`RolePlayer.observe` -- the robot's tracked pose; :meth:`RolePlayer.control` -- one
  control step (the node runs both on every tracked pose, the simulation once per step);
* :meth:`RolePlayer.replan` -- the re-plan period: re-optimise the rest of the role by GP
  inference with the others' roles as time-indexed moving obstacles (:mod:`.role_playing`),
  then publish the role (also the heartbeat the engine's silence check listens to);
* :meth:`RolePlayer.check_pose_age` -- no fresh tracked pose: stop rather than drive blind.

Effects out through a :class:`PlayerPort`: a velocity command, a published process role, a log
line, and the question "which map does this round play on" (the node answers from the
engine's latched round map, the simulation with the scenario's map).

State (:class:`PlayerState`): IDLE without a role, WAITING before the role's start time,
PLAYING, ARRIVED once the role is over and the robot is within ``arrival_tolerance`` of its
destination (it then stops and says so on the channel).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Mapping, Protocol

from .conflict import SharedRole
from .controller import TrajectoryFollower
from .environment import RobotEnvironment
from .errors import RoleEngineError
from .role_playing import Replan, replan_process_role
from .tuning import PlayerTuning


class PlayerState(Enum):
    IDLE = 'idle'            # no role: before the first assignment, or left out of the round
    WAITING = 'waiting'      # a role whose start time has not come
    PLAYING = 'playing'
    ARRIVED = 'arrived'


@dataclass(frozen=True)
class RoundAssignment:
    """A negotiation round as a player needs it: ``initial_roles`` maps every assigned robot to its
    (role id, initial process role); ``status`` is 'assigned' when roles were handed out. ``session``:
    the engine's session (core.sessions); a round of another session than the player's is a new start
    (the node's SessionFollower has decided it is to be followed)."""

    round: int
    status: str
    message: str
    initial_roles: Mapping[str, tuple[str, SharedRole]]
    session: int = 0


@dataclass(frozen=True)
class PublishedRole:
    """What a player puts on the shared channel (its version counts its re-optimisations, >= 1)."""

    robot: str
    role_id: str
    round: int
    version: int
    role: SharedRole
    arrived: bool
    session: int = 0                # the engine session of the round


class PlayerPort(Protocol):
    """What the player asks its transport to do."""

    def command(self, linear: float, angular: float) -> None:
        """Drive the robot; (0, 0) stops it."""

    def publish_role(self, published: PublishedRole) -> None:
        ...

    def round_environment(self, round_: int) -> RobotEnvironment | None:
        """``Env_tau`` of the round's map for this robot's type; None while it is not known yet."""

    def log(self, level: str, text: str, throttle: float = 0.0) -> None:
        """``level``: info, warn or error; ``throttle`` s between repeats of the same line (0: none)."""


class RolePlayer:
    """One robot's role playing (module docstring)."""

    def __init__(self, robot: str, tuning: PlayerTuning, port: PlayerPort):
        self.robot = robot
        self.tuning = tuning
        self.port = port
        self.state = PlayerState.IDLE
        self.session = 0                                  # the engine session of the round (0: none)
        self.round = 0
        self.role: SharedRole | None = None
        self.role_id = ''
        self.version = 0
        self.follower: TrajectoryFollower | None = None
        self.others: dict[str, SharedRole] = {}
        self.robot_env: RobotEnvironment | None = None    # Env_tau of the round, asked for lazily
        self.position: tuple[float, float] | None = None
        self.yaw: float | None = None
        self.pose_time: float | None = None               # when the newest pose was observed
        self.arrived_at: float | None = None

    @property
    def arrived(self) -> bool:
        return self.state is PlayerState.ARRIVED

    def retune(self, tuning: PlayerTuning) -> None:
        """New tuning: the next command and re-plan use it (the current role's controller too)."""
        self.tuning = tuning
        if self.role is not None:
            self.follower = tuning.follower(self.role.trajectory, self.role.total_time)

    # --- the shared channel -------------------------------------------------------------------
    def on_assignment(self, assignment: RoundAssignment) -> None:
        if assignment.session == self.session and assignment.round <= self.round:
            return
        self.session, self.round = assignment.session, assignment.round
        self.others = {}
        self.arrived_at = None
        self.robot_env = None                # this round's map (robots excluded from it are obstacles)
        mine = assignment.initial_roles.get(self.robot)
        if assignment.status != 'assigned' or mine is None:
            self.role = self.follower = None
            self.state = PlayerState.IDLE
            self.port.command(0.0, 0.0)
            self.port.log('info', f'round {assignment.round}: no role ({assignment.status}: {assignment.message})')
            return
        for robot, (_, role) in assignment.initial_roles.items():
            self.on_role(robot, assignment.round, role)
        self.role_id = mine[0]
        self.state = PlayerState.WAITING
        self._adopt(mine[1], version=0)
        goal = self.role.trajectory[-1, :2]
        self.port.log('info', f'round {assignment.round}: playing {self.role_id} to ({goal[0]:.2f}, {goal[1]:.2f}) '
                              f'from t={self.role.start_time:.1f} s')

    def on_role(self, robot: str, round_: int, role: SharedRole) -> None:
        """Another robot's latest process role of this round (a moving obstacle of the next re-plan)."""
        if robot == self.robot or round_ != self.round:
            return
        self.others[robot] = role

    def _adopt(self, role: SharedRole, version: int) -> None:
        self.role = role
        self.version = version
        self.follower = self.tuning.follower(role.trajectory, role.total_time)

    def _publish(self) -> None:
        self.port.publish_role(PublishedRole(self.robot, self.role_id, self.round, max(self.version, 1), self.role,
                                             self.arrived, self.session))

    # --- tracked pose and control (Algorithm 4 lines 4, 7) -----------------------------------
    def observe(self, now: float, pose) -> None:
        """The robot's tracked pose (x, y, yaw) at ``now``."""
        self.position = (float(pose[0]), float(pose[1]))
        self.yaw = float(pose[2])
        self.pose_time = now

    def control(self, now: float) -> None:
        """One command from the newest pose: follow the role, stop before its start, at the destination
        (arrival: the role is over and the robot within ``arrival_tolerance``) and after."""
        if self.follower is None or self.position is None:
            return
        t = now - self.role.start_time
        if t < 0.0 or self.arrived:
            self.port.command(0.0, 0.0)
            return
        self.state = PlayerState.PLAYING
        if t >= self.role.total_time and math.dist(self.position, self.role.trajectory[-1, :2]) \
                <= self.tuning.arrival_tolerance:
            self.state = PlayerState.ARRIVED
            self.arrived_at = now
            self.port.command(0.0, 0.0)
            self.port.log('info', f'arrived at {self.role_id}')
            self._publish()
            return
        self.port.command(*self.follower.command(t, (*self.position, self.yaw)))

    def check_pose_age(self, now: float, timeout: float) -> None:
        """Stop a robot whose tracked pose is older than ``timeout`` (not seen, tracker down)."""
        if self.follower is None or self.arrived or now < self.role.start_time:
            return                           # nothing to stop: no role, arrived, or not started (still)
        age = math.inf if self.pose_time is None else now - self.pose_time
        if age > timeout:
            self.port.command(0.0, 0.0)
            self.port.log('warn', f'no tracked pose of {self.robot} for {timeout:g} s: stopped', throttle=5.0)

    # --- re-optimisation and heartbeat (Algorithm 4 lines 3, 5-6) ------------------------------
    def replan(self, now: float) -> Replan | None:
        """Re-optimise the rest of the role (when playing and the pose and map are known), then publish
        the role; the re-plan's outcome, or None when none was tried."""
        if self.role is None:
            return None
        result = None
        # A robot already within arrival_tolerance of its destination keeps its role: re-planning a role
        # that barely moves restarts it at every period (the robot's place along a near-stationary role is
        # its start), so the role would never end and the robot never arrive (seen after renegotiations
        # that hand a robot the point it stands on).
        at_goal = self.position is not None and \
            math.dist(self.position, self.role.trajectory[-1, :2]) <= self.tuning.arrival_tolerance
        if not self.arrived and not at_goal and self.position is not None and now >= self.role.start_time:
            if self.robot_env is None:
                self.robot_env = self.port.round_environment(self.round)
            if self.robot_env is not None:
                tuning = self.tuning
                try:
                    result = replan_process_role(tuning.gp_config(), self.robot_env, self.role,
                                                 list(self.others.values()), now, self.position,
                                                 horizon=tuning.conflict_horizon, avoidance=tuning.avoidance)
                except RoleEngineError as error:
                    self.port.log('warn', f're-optimisation failed, keeping the role: {error}', throttle=5.0)
            if result is not None and result.trajectory is not None:
                self._adopt(SharedRole(self.robot, result.trajectory, result.total_time, self.role.radius,
                                       result.start_time), self.version + 1)
                if result.conflicting:
                    self.port.log('info', f"re-planned around {', '.join(result.conflicting)}", throttle=2.0)
        self._publish()
        return result
