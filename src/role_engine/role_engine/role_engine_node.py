"""role_engine: the central computer of the role engine (Algorithm 1).

Waits for a camera frame in which every robot of the scenario is found by colour
tracking, builds the environment from that image (robots are not obstacles), negotiates,
evaluates by GP inference and assigns the formation's roles by GRA (core.central), then
publishes the assignment on /roles/assignment (latched) and the initial process roles on
/roles/channel. It watches the channel: a robot whose role player has published no
process role for ``silence_timeout`` seconds is excluded and the remaining robots
renegotiate from their tracked positions (the silent robot is then an obstacle as the
camera sees it); when that is not workable the assignment says ``infeasible`` and why.
"""
from __future__ import annotations

import sys
import time

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from role_interfaces.msg import ProcessRole, RoleAssignment

from pybullet_bridge.core.scenario import load_scenario
from collab_tools.node_support import ConfigurationError, declare as declare_parameter, run

from .camera_view import CameraView
from .core.central import plan_roles
from .core.errors import RoleEngineError
from .core.formation_task import SilenceWatch, TypedGPEvaluator, load_formation_task, team_from_scenario
from .core.grid import GridFrame
from .core.negotiation import Agent
from .core.top_view import environment_from_top_view
from .core.tracking import ColorTracker, TrackedTarget
from .role_messages import process_role_msg

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
CHANNEL = QoSProfile(depth=20, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def load_settings(path: str):
    """Settings and team, or ConfigurationError naming the field."""
    if not path:
        raise ConfigurationError('parameter settings_file: required (path to config/roles/formation_demo.yaml)')
    try:
        task = load_formation_task(path)
        scenario = load_scenario(task.scenario)
        return task, scenario, team_from_scenario(scenario, task.inflation_margin)
    except ValueError as error:          # RoleEngineError and the bridge's ScenarioError
        raise ConfigurationError(f'parameter settings_file: {error}') from None


def arena_grid(bounds, resolution: float) -> GridFrame:
    """The planning grid over the scenario's world bounds."""
    xmin, ymin, xmax, ymax = bounds
    return GridFrame(resolution, (xmin, ymin), (int(round((ymax - ymin) / resolution)),
                                                int(round((xmax - xmin) / resolution))))


class RoleEngine(Node):
    def __init__(self):
        super().__init__('role_engine')
        declare = lambda *spec: declare_parameter(self, *spec)  # noqa: E731
        declare('settings_file', '', 'formation settings YAML (config/roles/formation_demo.yaml)')
        declare('camera', 'top_camera', 'camera namespace')
        declare('exit_when_done', False, 'exit once every robot has reached its formation point')
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        self.task, scenario, self.team = load_settings(p('settings_file'))
        self.members = {m.name: m for m in self.team}
        self.frame = arena_grid(scenario.world.bounds, self.task.grid_resolution)
        self.targets = [TrackedTarget(m.name, m.color, m.robot_type.radius, m.height) for m in self.team]
        self.camera = CameraView(self, p('camera'))
        self.assignment_pub = self.create_publisher(RoleAssignment, '/roles/assignment', LATCHED)
        self.channel_pub = self.create_publisher(ProcessRole, '/roles/channel', CHANNEL)
        self.create_subscription(ProcessRole, '/roles/channel', self._on_role, CHANNEL)
        self.watch = SilenceWatch(self.task.silence_timeout)
        self.round = 0
        self.active: list[str] = []          # robots of the current round
        self.excluded: list[str] = []
        self.arrived: set[str] = set()
        self.observations = None
        self.phase = 'negotiate'
        self.exit_when_done = bool(self.get_parameter('exit_when_done').value)
        self.finished = Future()
        self.create_timer(0.25, self._tick)
        self.get_logger().info(f"{len(self.team)} robots ({', '.join(self.members)}), formation "
                               f"{self.task.formation['type']}")

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _track(self):
        stamp, rgb = self.camera.frame()
        tracker = ColorTracker(self.targets, self.camera.geometry())
        self.observations = tracker.track(rgb, self.observations)
        return rgb

    def _on_role(self, msg: ProcessRole) -> None:
        if msg.round != self.round or msg.version == 0 or msg.robot not in self.active:
            return  # the engine's own initial roles, or a role of an earlier round
        self.watch.heard(msg.robot, self._now())
        if msg.arrived and msg.robot not in self.arrived:
            self.arrived.add(msg.robot)
            self.get_logger().info(f'{msg.robot} arrived at {msg.role_id} ({len(self.arrived)}/{len(self.active)})')
            if self.arrived >= set(self.active):
                self.get_logger().info(f'round {self.round}: formation complete')
                if not self.finished.done():
                    self.finished.set_result(True)

    def _tick(self) -> None:
        if self.phase == 'negotiate':
            self._negotiate()
        elif self.phase == 'watch':
            silent = [r for r in self.watch.silent(self._now()) if r in self.active]
            if silent:
                self.get_logger().warn(f"round {self.round}: no process role from {', '.join(silent)} for "
                                       f'{self.task.silence_timeout:.1f} s; renegotiating without them')
                self.excluded.extend(silent)
                self.phase = 'negotiate'
                self._negotiate(f"{', '.join(silent)} went silent")

    def _negotiate(self, why: str = 'initial negotiation') -> None:
        if not self.camera.ready():
            return
        try:
            rgb = self._track()
        except (ValueError, RoleEngineError) as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return
        robots = [m for m in self.team if m.name not in self.excluded]
        missing = [m.name for m in robots if not self.observations[m.name].found]
        if missing:
            self.get_logger().warn(f"not seen on the camera image: {', '.join(missing)}", throttle_duration_sec=5.0)
            return
        discs = [(*self.observations[m.name].position, m.robot_type.radius, m.height) for m in robots]
        environment = environment_from_top_view(rgb, self.camera.geometry(), self.frame, robot_discs=discs,
                                                name='top_view')
        agents = [Agent(m.name, m.robot_type, self.observations[m.name].position) for m in robots]
        roles = self.task.roles(len(agents)) if agents else []
        self.round += 1
        began = time.perf_counter()
        plan = None
        try:
            if agents:
                plan = plan_roles(agents, roles, environment, total_time=self.task.total_time,
                                  num_intervals=self.task.states - 1, lam=self.task.qualification_lambda,
                                  epsilon=self.task.gp.get('epsilon', 0.1), evaluate=TypedGPEvaluator(self.task))
        except RoleEngineError as error:
            self.get_logger().error(f'round {self.round}: {error}')
        msg = RoleAssignment(round=self.round, excluded_robots=list(self.excluded))
        if plan is None or not plan.feasible:
            msg.status = 'infeasible'
            msg.message = f'{why}: ' + (plan.reason if plan is not None else 'no robot left to assign')
            self.active = []
            self.phase = 'done'
            self.get_logger().error(f'round {self.round}: {msg.message}')
        else:
            start_time = self._now() + self.task.start_delay
            destinations = {r.name: r.destination for r in roles}
            msg.status, msg.message = 'assigned', why
            for name, (role_id, trajectory) in plan.process_roles.items():
                radius = self.members[name].robot_type.radius
                role = process_role_msg(name, role_id, self.round, 0, start_time, self.task.total_time, radius,
                                        trajectory)
                role.header.stamp = self.get_clock().now().to_msg()
                msg.robots.append(name)
                msg.role_ids.append(role_id)
                msg.goal_x.append(destinations[role_id][0])
                msg.goal_y.append(destinations[role_id][1])
                msg.initial_roles.append(role)
            self.active = list(msg.robots)
            self.arrived = set()
            self.watch.expect(self.active, start_time)
            self.phase = 'watch'
            self.get_logger().info(f'round {self.round} ({why}): ' + ', '.join(
                f'{r}->{j}' for r, j in zip(msg.robots, msg.role_ids)) + f' (planned in {time.perf_counter() - began:.1f} s wall)')
        msg.header.stamp = self.get_clock().now().to_msg()
        self.assignment_pub.publish(msg)
        for role in msg.initial_roles:
            self.channel_pub.publish(role)


def main(args=None) -> int:
    return run(RoleEngine, 'role_engine', args)


if __name__ == '__main__':
    sys.exit(main())
