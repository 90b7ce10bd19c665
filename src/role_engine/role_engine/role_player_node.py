"""role_player: one robot's role player (Algorithm 4), run in its robot's namespace.

``ros2 run role_engine role_player --ros-args -r __ns:=/pioneer_1 -p settings_file:=...`` is the
node ``/pioneer_1/role_player``: its robot is the last component of its namespace (``names.RobotNode``).
It hears the assignment (``<team>/roles/assignment``, latched) and the others' process roles
(``<team>/roles/channel``), takes its robot's pose from the robot tracker (``tracked_pose`` in its
namespace, sensor-data QoS) and drives it along its process role with the core controller
(``cmd_vel`` in its namespace, at the tracker's rate). Every ``replan_period`` it re-optimises the
rest of its role by GP inference with the others' roles as time-indexed moving obstacles
(core.role_playing: warm start from the remaining part of the current role, detours when a head-on
conflict remains) and publishes it on the channel; that message is also its heartbeat, so it is
published every period even when the role is kept. At the destination it stops and says so
(``arrived``). A robot left out of the assignment, or of an aborted one, stops; so does a robot
whose tracked pose is older than POSE_TIMEOUT. A malformed process role on the channel is dropped
with a log line.

It reads no file another node uses but its settings file (the team-wide tuning defaults, a
tracked config file; its ``scenario`` is not read): its robot's type, radius and velocity limits
come from the role engine's latched ``<team>/roles/team``, and the static obstacles its re-plans
avoid (``Env_tau``, grid frame included) from the engine's latched ``<team>/roles/map``, the
map of the round it plays (same stamp as the assignment). So it runs on any machine of the
team's ROS network. Until the team description arrives only its read-only parameters exist; then
a robot not in the team, or a bad start-up tuning value, stops it with exit code 2.

Its tuning (role_parameters.PLAYER_TUNING: re-plan period, controller gains and velocity caps,
arrival tolerance, conflict horizon, GP and avoidance settings) are dynamic ROS parameters whose
defaults are the shared settings file's values.
"""
from __future__ import annotations

import math
import sys

from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import OccupancyGrid
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from role_interfaces.msg import ProcessRole, RoleAssignment, Team

from collab_tools import qos
from collab_tools.names import RobotNode
from collab_tools.node_support import ConfigurationError, run
from collab_tools.parameters import NodeParameters

from .core.conflict import SharedRole
from .core.controller import TrajectoryFollower
from .core.errors import RoleEngineError
from .core.formation_task import load_formation_task, replan_process_role
from .core.tuning import PlayerTuning
from .role_messages import environment_of, planar_pose, process_role_msg, shared_role, team_of
from .role_parameters import PLAYER_TUNING, declare_tuning

#: s (ROS time) without a tracked pose after which a playing robot is stopped (the camera runs at ~10 Hz).
POSE_TIMEOUT = 1.0


def declare_player_settings(params: NodeParameters):
    """The settings file of a player: the formation task, its scenario not read (ConfigurationError)."""
    path = params.declare('settings_file', '', 'formation settings YAML (config/roles/formation_demo.yaml): the '
                          'team-wide defaults of the tuning parameters (its scenario is not read: the team and the '
                          'map come from the role engine)', required=True)
    try:
        return load_formation_task(path, check_scenario=False)
    except ValueError as error:
        raise ConfigurationError(f'parameter settings_file: {error}') from None


class RolePlayer(Node):
    def __init__(self):
        super().__init__('role_player')
        self.params = NodeParameters(self)
        self.names = RobotNode(self, self.params)
        self.task = declare_player_settings(self.params)
        self.robot = self.names.robot
        self.member = None                   # from the team description
        self.tuning: PlayerTuning | None = None
        self.replan_timer = None
        self.map_msg: OccupancyGrid | None = None
        self.robot_env = None                # Env_tau of the round, from the round's map, built lazily
        self.position = None
        self.yaw = None
        self.pose_received = None            # ROS time of the newest tracked pose
        self.round = 0
        self.assignment_stamp = None
        self.role: SharedRole | None = None
        self.role_id = ''
        self.version = 0
        self.follower: TrajectoryFollower | None = None
        self.arrived = False
        self.others: dict[str, SharedRole] = {}
        self.exit_when_done = False
        self.cmd_pub = self.create_publisher(Twist, 'cmd_vel', qos.COMMAND_OUT)
        self.channel_pub = self.create_publisher(ProcessRole, self.names.team('roles/channel'), qos.RELIABLE)
        self.create_subscription(Team, self.names.team('roles/team'), self._on_team, qos.LATCHED)
        self.get_logger().info(f"{self.robot}: waiting for the team description on {self.names.team('roles/team')}")

    def _fatal(self, message: str) -> None:
        """A start-up error found once the team is known: node_support.run exits 2 with the message."""
        raise ConfigurationError(message)

    def _on_team(self, msg: Team) -> None:
        if self.member is not None:
            return                           # the team is fixed for the node's life
        try:
            members = {m.name: m for m in team_of(msg, self.task.inflation_margin)}
        except ValueError as error:
            self.get_logger().error(f'ignored the team description: {error}')
            return
        if self.robot not in members:
            self._fatal(f"parameter robot: must be one of {', '.join(members)} (got {self.robot!r}, "
                        f'the last component of the namespace {self.get_namespace()})')
        member = members[self.robot]
        limits = member.robot_type
        try:
            self.tuning = declare_tuning(self.params, PlayerTuning.from_task(self.task, limits), PLAYER_TUNING,
                                         self._retune, high={'max_linear_velocity': limits.max_linear_velocity,
                                                             'max_angular_velocity': limits.max_angular_velocity})
        except (ConfigurationError, ParameterException) as error:
            self._fatal(str(error))
        self.member = member
        self.create_subscription(RoleAssignment, self.names.team('roles/assignment'), self._on_assignment,
                                 qos.LATCHED)
        self.create_subscription(ProcessRole, self.names.team('roles/channel'), self._on_role, qos.RELIABLE)
        self.create_subscription(OccupancyGrid, self.names.team('roles/map'), self._on_map, qos.LATCHED)
        self.create_subscription(PoseStamped, 'tracked_pose', self._on_pose, qos.SENSOR_IN)
        self.replan_timer = self.create_timer(self.tuning.replan_period, self._replan)
        self.create_timer(POSE_TIMEOUT / 4.0, self._check_pose_age)
        self.get_logger().info(f'{self.robot} ({limits.name}) ready')

    def _retune(self, name: str, value) -> None:
        """A tuning parameter was set: the next period, re-plan and command use it (RoleEngineError refuses)."""
        self.tuning = self.tuning.with_values({name: value})
        if name == 'replan_period':
            self.replan_timer.timer_period_ns = int(round(self.tuning.replan_period * 1e9))
        if self.role is not None:
            self.follower = self.tuning.follower(self.role.trajectory, self.role.total_time)
        self.get_logger().info(f'{name} set to {value}')

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # --- the shared channel --------------------------------------------------------------
    def _on_assignment(self, msg: RoleAssignment) -> None:
        if msg.round <= self.round:
            return
        self.round = msg.round
        self.others = {}
        self.arrived = False
        self.assignment_stamp = msg.header.stamp
        self.robot_env = None                # rebuilt from this round's map (robots excluded since are obstacles)
        mine = [r for r in msg.initial_roles if r.robot == self.robot]
        if msg.status != 'assigned' or not mine:
            self.role = self.follower = None
            self.cmd_pub.publish(Twist())
            self.get_logger().info(f'round {msg.round}: no role ({msg.status}: {msg.message})')
            return
        for role in msg.initial_roles:
            self._on_role(role)
        self.role_id = mine[0].role_id
        self._adopt(shared_role(mine[0]), version=0)
        goal = self.role.trajectory[-1, :2]
        self.get_logger().info(f'round {msg.round}: playing {self.role_id} to ({goal[0]:.2f}, {goal[1]:.2f}) '
                               f'from t={self.role.start_time:.1f} s')

    def _on_role(self, msg: ProcessRole) -> None:
        if msg.robot == self.robot or msg.round != self.round:
            return
        try:
            role = shared_role(msg)
        except (ValueError, RoleEngineError) as error:
            self.get_logger().error(f'dropped malformed process role: {error}')
            return
        self.others[msg.robot] = role

    def _adopt(self, role: SharedRole, version: int) -> None:
        self.role = role
        self.version = version
        self.follower = self.tuning.follower(role.trajectory, role.total_time)

    def _publish_role(self) -> None:
        msg = process_role_msg(self.robot, self.role_id, self.round, max(self.version, 1), self.role.start_time,
                               self.role.total_time, self.role.radius, self.role.trajectory, self.arrived)
        msg.header.stamp = self.get_clock().now().to_msg()
        self.channel_pub.publish(msg)

    # --- tracked pose and control (Algorithm 4 lines 4, 7) ------------------------------------
    def _on_pose(self, msg: PoseStamped) -> None:
        try:
            x, y, self.yaw = planar_pose(msg)
        except ValueError as error:
            self.get_logger().warn(f'dropped a tracked pose: {error}', throttle_duration_sec=5.0)
            return
        self.position = (x, y)
        self.pose_received = self._now()
        if self.follower is None:
            return
        t = self._now() - self.role.start_time
        if t < 0.0 or self.arrived:
            self.cmd_pub.publish(Twist())
            return
        if t >= self.role.total_time and math.dist(self.position, self.role.trajectory[-1, :2]) \
                <= self.tuning.arrival_tolerance:
            self.arrived = True
            self.cmd_pub.publish(Twist())
            self.get_logger().info(f'arrived at {self.role_id}')
            self._publish_role()
            return
        linear, angular = self.follower.command(t, (x, y, self.yaw))
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = linear, angular
        self.cmd_pub.publish(cmd)

    def _check_pose_age(self) -> None:
        """No fresh tracked pose (robot not seen, tracker down): stop rather than drive blind."""
        if self.follower is None or self.arrived or self._now() < self.role.start_time:
            return                           # nothing to stop: no role, arrived, or not started (still)
        age = math.inf if self.pose_received is None else self._now() - self.pose_received
        if age > POSE_TIMEOUT:
            self.cmd_pub.publish(Twist())
            self.get_logger().warn(f'no tracked pose of {self.robot} for {POSE_TIMEOUT:g} s: stopped',
                                   throttle_duration_sec=5.0)

    # --- the round's map ------------------------------------------------------------------------
    def _on_map(self, msg: OccupancyGrid) -> None:
        self.map_msg = msg

    def _round_environment(self):
        """Env_tau of the round from the engine's map of this round (same stamp), None until it is here."""
        if self.map_msg is None or self.map_msg.header.stamp != self.assignment_stamp:
            self.get_logger().warn(f'round {self.round}: waiting for its map', throttle_duration_sec=5.0)
            return None
        try:
            return environment_of(self.map_msg, name=f'round {self.round} map').for_robot(self.member.robot_type)
        except (ValueError, RoleEngineError) as error:
            self.get_logger().error(f'unusable map of round {self.round}: {error}', throttle_duration_sec=5.0)
            return None

    # --- re-optimisation and heartbeat (Algorithm 4 lines 3, 5-6) ----------------------------
    def _replan(self) -> None:
        if self.role is None:
            return
        now = self._now()
        if not self.arrived and self.position is not None and now >= self.role.start_time:
            if self.robot_env is None:
                self.robot_env = self._round_environment()
            result = None
            if self.robot_env is not None:
                try:
                    tuning = self.tuning
                    result = replan_process_role(tuning.gp_config(), self.robot_env, self.role,
                                                 list(self.others.values()), now, self.position,
                                                 horizon=tuning.conflict_horizon, avoidance=tuning.avoidance)
                except RoleEngineError as error:
                    self.get_logger().warn(f're-optimisation failed, keeping the role: {error}',
                                           throttle_duration_sec=5.0)
            if result is not None and result.trajectory is not None:
                self._adopt(SharedRole(self.robot, result.trajectory, result.total_time, self.role.radius,
                                       result.start_time), self.version + 1)
                if result.conflicting:
                    self.get_logger().info(f"re-planned around {', '.join(result.conflicting)}",
                                           throttle_duration_sec=2.0)
        self._publish_role()


def main(args=None) -> int:
    return run(RolePlayer, 'role_player', args)


if __name__ == '__main__':
    sys.exit(main())
