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
whose tracked pose is older than POSE_TIMEOUT. Every subscription goes through the node's input
guard (collab_tools.input_guard): a malformed message (a process role or assignment out of
bounds, a robot not in the team, a non-finite pose, an invalid stamp) is dropped, counted and
logged once per kind; an assignment is used whole or not at all.

Sessions (core.sessions): the player follows the current session of its engine (parameter
``engine``, the engine's node name in the team namespace): a later round of that session is
applied, and so is a new session's (a restarted engine counts from round 1 again); assignments of
other senders, of a session it has left, or more than MAX_ROUND_JUMP rounds ahead are ignored,
counted and logged once per kind, and so are process roles of another session or whose sender is
not a node of their robot. Its own process roles carry its node name and the session. While it
plays no role (at start, after a restart, when left out) it announces itself every re-plan period
on ``<team>/roles/players``, so an engine that excluded it as silent includes it again; a restarted
player gets its role from the latched assignment when it is still in the round.

It reads no file another node uses but its settings file (the team-wide tuning defaults, a
tracked config file; its ``scenario`` is not read): its robot's type, radius and velocity limits
come from the role engine's latched ``<team>/roles/team``, and the static obstacles its re-plans
avoid (``Env_tau``, grid frame included) from the engine's latched ``<team>/roles/map``, the
map of the round it plays (same stamp as the assignment). So it runs on any machine of the
team's ROS network. Until the team description arrives only its read-only parameters exist; then
a robot not in the team, or a bad start-up tuning value, stops it with exit code 2.

Its tuning (core.node_settings.player_tuning_schema: re-plan period, controller gains and velocity
caps, arrival tolerance, conflict horizon, GP and avoidance settings) are dynamic ROS parameters
whose defaults are the shared settings file's values.

The player's behaviour is core.player.RolePlayer (the roles-collab simulation drives the same
class); this node adapts it: messages in, commands, channel messages and log lines out.
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import OccupancyGrid
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from role_interfaces.msg import PlayerAnnouncement, ProcessRole, RoleAssignment, Team

from collab_tools import qos
from collab_tools.core.input_checks import MalformedInput, error_kind
from collab_tools.input_guard import InputGuard
from collab_tools.names import RobotNode
from collab_tools.node_support import ConfigurationError, run
from collab_tools.parameters import NodeParameters
from collab_tools.port_logging import PortLogger

from .core import gp_compiled
from .core.errors import RoleEngineError
from .core.node_settings import PLAYER_SETTINGS, player_settings_file, player_tuning_schema, team_member, tuned
from .core.sessions import SessionFollower, Verdict
from .core.player import PublishedRole, RolePlayer as PlayerBehaviour, RoundAssignment
from .core.tuning import PlayerTuning
from .role_messages import channel_role, environment_of, planar_pose, process_role_msg, shared_role, team_of

#: s (ROS time) without a tracked pose after which a playing robot is stopped (the camera runs at ~10 Hz).
POSE_TIMEOUT = 1.0


class RolePlayer(Node):
    def __init__(self):
        super().__init__('role_player')
        # GP kernels loaded (or compiled) now, not in the first plan.
        self.get_logger().info(f'compiled GP kernels ready in {gp_compiled.warm_up():.2f} s')
        self.params = NodeParameters(self)
        self.names = RobotNode(self, self.params)
        settings = self.params.declare_schema(PLAYER_SETTINGS)
        self.task = player_settings_file(settings['settings_file'])
        self.sender = self.get_fully_qualified_name()
        self.sessions = SessionFollower(self.names.team(settings['engine']))
        self.robot = self.names.robot
        self.member = None                   # from the team description
        self.player: PlayerBehaviour | None = None
        self.replan_timer = None
        self.map_msg: OccupancyGrid | None = None
        self.assignment_stamp = None
        self.log = PortLogger(self.get_logger()).log     # the player's log lines
        self.cmd_pub = self.create_publisher(Twist, 'cmd_vel', qos.COMMAND_OUT)
        self.channel_pub = self.create_publisher(ProcessRole, self.names.team('roles/channel'), qos.RELIABLE)
        self.announce_pub = self.create_publisher(PlayerAnnouncement, self.names.team('roles/players'), qos.RELIABLE)
        self.inputs = InputGuard.of(self)
        self.team_names: frozenset[str] = frozenset()
        # A team description that names no usable team is dropped; this robot missing from a valid one,
        # or a bad start-up tuning value, stops the node (ConfigurationError: exit 2).
        self.inputs.subscribe(Team, self.names.team('roles/team'), self._on_team, qos.LATCHED,
                              fatal=(ConfigurationError,))
        self.get_logger().info(f"{self.robot}: waiting for the team description on {self.names.team('roles/team')}")

    def _on_team(self, msg: Team) -> None:
        """The team is fixed for the node's life: its robot's type, limits and tuning are declared now;
        a robot not in the team or a bad start-up tuning value stops the node (exit 2)."""
        if self.member is not None:
            return
        try:
            team = team_of(msg, self.task.inflation_margin)
        except ValueError as error:      # dropped by the guard (not fatal: a plain ValueError)
            raise MalformedInput(f'ignored the team description: {error}', kind='team description') from None
        member = team_member(team, self.robot, self.get_namespace())
        try:
            tuning = PlayerTuning.from_task(self.task, member.robot_type)
            schema = player_tuning_schema(tuning)
            values = self.params.declare_schema(schema, on_change={
                name: (lambda value, name=name: self._retune(name, value)) for name in schema.names})
            tuning = tuned(tuning, values)
        except ParameterException as error:
            raise ConfigurationError(str(error)) from None
        self.member = member
        self.team_names = frozenset(m.name for m in team)
        self.player = PlayerBehaviour(self.robot, tuning, self)
        inputs = self.inputs
        inputs.subscribe(RoleAssignment, self.names.team('roles/assignment'), self._on_assignment, qos.LATCHED)
        inputs.subscribe(ProcessRole, self.names.team('roles/channel'), self._on_role, qos.RELIABLE)
        inputs.subscribe(OccupancyGrid, self.names.team('roles/map'), self._on_map, qos.LATCHED)
        inputs.subscribe(PoseStamped, 'tracked_pose', self._on_pose, qos.SENSOR_IN)
        self.replan_timer = self.create_timer(tuning.replan_period, self._replan)
        self.create_timer(POSE_TIMEOUT / 4.0, lambda: self.player.check_pose_age(self._now(), POSE_TIMEOUT))
        self.get_logger().info(f'{self.robot} ({member.robot_type.name}) ready, following {self.sessions.engine}')
        self._announce()

    def _retune(self, name: str, value) -> None:
        """A tuning parameter was set: the next period, re-plan and command use it (RoleEngineError refuses)."""
        self.player.retune(self.player.tuning.with_values({name: value}))
        if name == 'replan_period':
            self.replan_timer.timer_period_ns = int(round(self.player.tuning.replan_period * 1e9))
        self.get_logger().info(f'{name} set to {value}')

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # --- messages in -----------------------------------------------------------------------------
    def _on_assignment(self, msg: RoleAssignment) -> None:
        if self.sessions.check_assignment(msg.sender, msg.session, msg.round) is Verdict.OLD:
            return
        # Converted whole before the player sees it: a malformed initial role drops the assignment
        # (the guard counts and logs it), never half of it.
        self.inputs.stamp(msg.header.stamp)
        roles = {}
        for index, role in enumerate(msg.initial_roles):
            try:
                roles[role.robot] = (role.role_id, self._playable(shared_role(role, self.team_names)))
            except ValueError as error:
                raise MalformedInput(f'assignment of round {msg.round}: initial_roles[{index}]: {error}',
                                     kind=f'assignment: {error_kind(error)}') from None
        left = self.sessions.session
        if self.sessions.follow(msg.session, msg.round) and left:
            self.get_logger().info(f'following the new session {msg.session} of {msg.sender} (left session {left})')
        self.assignment_stamp = msg.header.stamp
        self.player.on_assignment(RoundAssignment(msg.round, msg.status, msg.message, roles, msg.session))

    def _playable(self, role):
        """The role, once its controller can be built (RoleEngineError, a ValueError, when not)."""
        self.player.tuning.follower(role.trajectory, role.total_time)
        return role

    def _on_role(self, msg: ProcessRole) -> None:
        if msg.robot == self.robot or not self.sessions.channel_verdict(msg.sender, msg.session, msg.robot,
                                                                         msg.round):
            return
        self.player.on_role(msg.robot, msg.round, channel_role(msg, self.team_names))

    def _on_pose(self, msg: PoseStamped) -> None:
        pose = planar_pose(msg)
        now = self._now()
        self.player.observe(now, pose)
        self.player.control(now)

    def _on_map(self, msg: OccupancyGrid) -> None:
        self.inputs.stamp(msg.header.stamp)
        self.map_msg = msg

    # --- the player's port -----------------------------------------------------------------------
    def command(self, linear: float, angular: float) -> None:
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = float(linear), float(angular)
        self.cmd_pub.publish(cmd)

    def publish_role(self, published: PublishedRole) -> None:
        role = published.role
        msg = process_role_msg(published.robot, published.role_id, published.round, published.version,
                               role.start_time, role.total_time, role.radius, role.trajectory, published.arrived,
                               sender=self.sender, session=published.session)
        msg.header.stamp = self.get_clock().now().to_msg()
        self.channel_pub.publish(msg)

    def _replan(self) -> None:
        self.player.replan(self._now())
        if self.player.role is None:
            self._announce()

    def _announce(self) -> None:
        """Tell the engine this player is here and plays no role (a restarted player is included again)."""
        msg = PlayerAnnouncement(sender=self.sender, robot=self.robot, session=self.sessions.session,
                                 round=self.sessions.round)
        msg.header.stamp = self.get_clock().now().to_msg()
        self.announce_pub.publish(msg)

    def round_environment(self, round_: int):
        """Env_tau of the round from the engine's map of this round (same stamp), None until it is here."""
        if self.map_msg is None or self.map_msg.header.stamp != self.assignment_stamp:
            self.get_logger().warn(f'round {round_}: waiting for its map', throttle_duration_sec=5.0)
            return None
        try:
            return environment_of(self.map_msg, name=f'round {round_} map').for_robot(self.member.robot_type)
        except (ValueError, RoleEngineError) as error:
            self.get_logger().error(f'unusable map of round {round_}: {error}', throttle_duration_sec=5.0)
            return None


def main(args=None) -> int:
    return run(RolePlayer, 'role_player', args)


if __name__ == '__main__':
    sys.exit(main())
