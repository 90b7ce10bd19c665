"""role_player: one robot's role player (Algorithm 4), run in its robot's namespace.

``ros2 run role_engine role_player --ros-args -r __ns:=/pioneer_1 -p settings_file:=...`` is the
node ``/pioneer_1/role_player``: its robot is the last component of its namespace (``names.RobotNode``).
It hears the assignment (``<team>/roles/assignment``, latched) and the others' process roles
(``<team>/roles/channel``), tracks its own robot by colour on the top-view camera
(``<team>/<camera>``, sensor-data QoS), and drives it along its process role with the core
controller (``cmd_vel`` in its namespace, at the camera rate). Every ``replan_period`` it
re-optimises the rest of its role by GP inference with the others' roles as time-indexed moving
obstacles (core.role_playing: warm start from the remaining part of the current role, detours when
a head-on conflict remains) and publishes it on the channel; that message is also its heartbeat,
so it is published every period even when the role is kept. At the destination it stops and says
so (``arrived``). A robot left out of the assignment, or of an aborted one, stops. A malformed
process role on the channel is dropped with a log line.

Its tuning (role_parameters.PLAYER_TUNING: re-plan period, controller gains and velocity caps,
arrival tolerance, conflict horizon, GP and avoidance settings) are dynamic ROS parameters whose
defaults are the shared settings file's values.
"""
from __future__ import annotations

import math
import sys

from geometry_msgs.msg import Twist
from rclpy.node import Node
from role_interfaces.msg import ProcessRole, RoleAssignment

from collab_tools import qos
from collab_tools.names import RobotNode
from collab_tools.node_support import ConfigurationError, run
from collab_tools.parameters import NodeParameters
from collab_tools.top_camera import TopCamera

from .core.conflict import SharedRole
from .core.controller import TrajectoryFollower
from .core.errors import RoleEngineError
from .core.formation_task import replan_process_role
from .core.grid import GridFrame
from .core.top_view import environment_from_top_view
from .core.tracking import ColorTracker, TrackedTarget
from .core.tuning import PlayerTuning
from .role_engine_node import declare_settings
from .role_messages import process_role_msg, shared_role
from .role_parameters import PLAYER_TUNING, declare_tuning


class RolePlayer(Node):
    def __init__(self):
        super().__init__('role_player')
        params = NodeParameters(self)
        self.names = RobotNode(self, params)
        self.task, scenario, team, camera = declare_settings(params)
        self.frame = GridFrame.covering(scenario.world.bounds, self.task.grid_resolution)
        members = {m.name: m for m in team}
        self.robot = self.names.robot
        if self.robot not in members:
            raise ConfigurationError(f"parameter robot: must be one of {', '.join(members)} (got {self.robot!r}, "
                                     f'the last component of the namespace {self.get_namespace()})')
        self.member = members[self.robot]
        limits = self.member.robot_type
        self.tuning = declare_tuning(params, PlayerTuning.from_task(self.task, limits), PLAYER_TUNING, self._retune,
                                     high={'max_linear_velocity': limits.max_linear_velocity,
                                           'max_angular_velocity': limits.max_angular_velocity})
        self.robot_env = None                # Env_tau: from the scenario's static obstacles, built lazily
        self.target = TrackedTarget(self.robot, self.member.color, self.member.robot_type.radius, self.member.height)
        self.observation = None
        self.yaw = None
        self.round = 0
        self.role: SharedRole | None = None
        self.role_id = ''
        self.version = 0
        self.follower: TrajectoryFollower | None = None
        self.arrived = False
        self.others: dict[str, SharedRole] = {}
        self.cmd_pub = self.create_publisher(Twist, 'cmd_vel', qos.COMMAND_OUT)
        self.channel_pub = self.create_publisher(ProcessRole, self.names.team('roles/channel'), qos.RELIABLE)
        self.create_subscription(RoleAssignment, self.names.team('roles/assignment'), self._on_assignment,
                                 qos.LATCHED)
        self.create_subscription(ProcessRole, self.names.team('roles/channel'), self._on_role, qos.RELIABLE)
        self.camera = TopCamera(self, self.names.team(camera), on_frame=self._on_frame)
        self.replan_timer = self.create_timer(self.tuning.replan_period, self._replan)
        self.exit_when_done = False
        self.get_logger().info(f'{self.robot} ({self.member.robot_type.name}) ready')

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
        self.robot_env = None                # rebuilt: robots excluded since stand where the camera sees them
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

    # --- tracking and control (Algorithm 4 lines 4, 7) -----------------------------------------
    def _on_frame(self) -> None:
        try:
            _, rgb = self.camera.frame()
            tracker = ColorTracker([self.target], self.camera.geometry())
            observation = tracker.track(rgb, {self.robot: self.observation} if self.observation else None)[self.robot]
        except (ValueError, RoleEngineError) as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return
        if not observation.found:
            self.get_logger().warn('own robot not seen on the camera image', throttle_duration_sec=5.0)
            self.cmd_pub.publish(Twist())
            return
        self.observation = observation
        if observation.heading is not None:
            self.yaw = observation.heading
        if self.follower is None or self.yaw is None:
            return
        t = self._now() - self.role.start_time
        pose = (*observation.position, self.yaw)
        if t < 0.0 or self.arrived:
            self.cmd_pub.publish(Twist())
            return
        if t >= self.role.total_time and math.dist(observation.position, self.role.trajectory[-1, :2]) \
                <= self.tuning.arrival_tolerance:
            self.arrived = True
            self.cmd_pub.publish(Twist())
            self.get_logger().info(f'arrived at {self.role_id}')
            self._publish_role()
            return
        linear, angular = self.follower.command(t, pose)
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = linear, angular
        self.cmd_pub.publish(cmd)

    # --- re-optimisation and heartbeat (Algorithm 4 lines 3, 5-6) ----------------------------
    def _replan(self) -> None:
        if self.role is None:
            return
        now = self._now()
        if not self.arrived and self.observation is not None and now >= self.role.start_time:
            if self.robot_env is None:
                self.robot_env = self._static_environment().for_robot(self.member.robot_type)
            try:
                tuning = self.tuning
                result = replan_process_role(tuning.gp_config(), self.robot_env, self.role,
                                             list(self.others.values()), now, self.observation.position,
                                             horizon=tuning.conflict_horizon, avoidance=tuning.avoidance)
            except RoleEngineError as error:
                self.get_logger().warn(f're-optimisation failed, keeping the role: {error}',
                                       throttle_duration_sec=5.0)
                result = None
            if result is not None and result.trajectory is not None:
                self._adopt(SharedRole(self.robot, result.trajectory, result.total_time, self.role.radius,
                                       result.start_time), self.version + 1)
                if result.conflicting:
                    self.get_logger().info(f"re-planned around {', '.join(result.conflicting)}",
                                           throttle_duration_sec=2.0)
        self._publish_role()

    def _static_environment(self):
        """The static obstacles as the camera sees them now (robots, by their roles, are not obstacles)."""
        _, rgb = self.camera.frame()
        discs = [(*r.positions([self._now()])[0], r.radius, self.member.height) for r in self.others.values()]
        discs.append((*self.observation.position, self.member.robot_type.radius, self.member.height))
        return environment_from_top_view(rgb, self.camera.geometry(), self.frame, robot_discs=discs,
                                         name='top_view')


def main(args=None) -> int:
    return run(RolePlayer, 'role_player', args)


if __name__ == '__main__':
    sys.exit(main())
