"""role_engine: the central computer of the role engine (Algorithm 1), a team-level node.

Runs in the team namespace (``/role_engine`` by default; ``-r __ns:=/sim1`` moves it and its topics).
Waits for a camera frame (``<team>/<camera>``, sensor-data QoS) in which every robot of the
scenario is found by colour tracking, builds the environment from that image (robots are not
obstacles), negotiates, evaluates by GP inference and assigns the formation's roles by GRA
(core.central), then publishes the assignment on ``<team>/roles/assignment`` (latched) and the
initial process roles on ``<team>/roles/channel`` (reliable). It watches the channel and the camera
(core.problems.ProblemWatch): a robot that is silent (no process role for ``silence_timeout`` s),
stuck or far off its role is excluded and the remaining robots renegotiate from their tracked
positions (the excluded robot is then an obstacle as the camera sees it). When that is not
negotiable (fewer usable robots than ``min_robots``, or no feasible assignment) the assignment
says ``aborted`` and why, and the node exits if ``exit_when_done``. A first negotiation that finds
no workable assignment says ``infeasible``. A malformed process role on the channel is dropped
with a log line. Its tuning (role_parameters.ENGINE_TUNING) are dynamic ROS parameters whose
defaults are the shared settings file's values.

It owns the team definition (the settings file's bridge scenario) and hands what the other role
nodes need to them over ROS, so they read no scenario and can run on other machines:

* ``<team>/roles/team`` (role_interfaces/Team, latched, at start): names, types, radii, velocity
  limits, colours and heights; header.frame_id = the scenario's world frame;
* ``<team>/roles/map`` (nav_msgs/OccupancyGrid, latched, Nav2 conventions, world frame): the
  environment each assignment was negotiated on (the static obstacles as the camera saw them,
  robots of the round removed, robots excluded from it left as obstacles), published just
  before the assignment with the same stamp, so a player knows which round a map belongs to.

It keeps its own camera subscription and colour tracking rather than the robot_tracker's poses:
it runs where the camera is, it segments the image itself, and tracking the robots on the very
image it segments keeps their discs (cut out of the obstacles) aligned with it; a pose from
another frame would be off by the robots' motion and leave parts of them as obstacles.
"""
from __future__ import annotations

import sys
import time

from rclpy.node import Node
from rclpy.task import Future
from nav_msgs.msg import OccupancyGrid
from role_interfaces.msg import ProcessRole, RoleAssignment, Team

from pybullet_bridge.core.scenario import load_scenario
from collab_tools import qos
from collab_tools.names import TeamNode
from collab_tools.node_support import ConfigurationError, run
from collab_tools.parameters import NodeParameters
from collab_tools.top_camera import TopCamera

from .core.central import plan_roles
from .core.errors import RoleEngineError
from .core.formation_task import TypedGPEvaluator, load_formation_task, team_from_scenario
from .core.grid import GridFrame
from .core.negotiation import Agent
from .core.problems import ProblemWatch
from .core.top_view import environment_from_top_view
from .core.tracking import ColorTracker, TrackedTarget
from .core.tuning import EngineTuning
from .role_messages import occupancy_grid_msg, process_role_msg, shared_role, team_msg
from .role_parameters import ENGINE_TUNING, declare_tuning


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


def declare_settings(params: NodeParameters):
    """The engine's read-only settings: (task, scenario, team, camera namespace). The players take only the
    settings file (role_player_node.declare_player_settings): the team and map reach them over ROS."""
    path = params.declare('settings_file', '', 'formation settings YAML (config/roles/formation_demo.yaml): the '
                          'scenario, the formation and the team-wide defaults of the tuning parameters',
                          required=True)
    camera = params.declare('camera', 'top_camera', "the top camera's namespace, relative to the team namespace",
                            check=lambda v: None if v.strip('/') else 'must be a non-empty namespace')
    return (*load_settings(path), camera)


class RoleEngine(Node):
    def __init__(self):
        super().__init__('role_engine')
        params = NodeParameters(self)
        self.names = TeamNode(self, params)
        self.task, scenario, self.team, camera = declare_settings(params)
        self.exit_when_done = params.declare('exit_when_done', False,
                                             'exit once the formation is complete or the task is aborted')
        self.tuning = declare_tuning(params, EngineTuning.from_task(self.task), ENGINE_TUNING, self._retune)
        self.members = {m.name: m for m in self.team}
        self.frame = GridFrame.covering(scenario.world.bounds, self.task.grid_resolution)
        self.world_frame = scenario.world.frame_id
        self.targets = [TrackedTarget(m.name, m.color, m.robot_type.radius, m.height) for m in self.team]
        self.camera = TopCamera(self, self.names.team(camera))
        self.assignment_pub = self.create_publisher(RoleAssignment, self.names.team('roles/assignment'), qos.LATCHED)
        self.channel_pub = self.create_publisher(ProcessRole, self.names.team('roles/channel'), qos.RELIABLE)
        self.map_pub = self.create_publisher(OccupancyGrid, self.names.team('roles/map'), qos.LATCHED)
        team_pub = self.create_publisher(Team, self.names.team('roles/team'), qos.LATCHED)
        team = team_msg(self.team, self.world_frame)
        team.header.stamp = self.get_clock().now().to_msg()
        team_pub.publish(team)
        self.create_subscription(ProcessRole, self.names.team('roles/channel'), self._on_role, qos.RELIABLE)
        self.watch = ProblemWatch(self.tuning.problems)
        self.round = 0
        self.active: list[str] = []          # robots of the current round
        self.excluded: list[str] = []
        self.arrived: set[str] = set()
        self.observations = None
        self.phase = 'negotiate'
        self.pending_why = 'initial negotiation'
        self.finished = Future()
        self.create_timer(0.25, self._tick)
        self.get_logger().info(f"{len(self.team)} robots ({', '.join(self.members)}), formation "
                               f"{self.task.formation['type']}")

    def _retune(self, name: str, value) -> None:
        """A tuning parameter was set: the next check or negotiation uses it (RoleEngineError refuses)."""
        self.tuning = self.tuning.with_values({name: value})
        self.watch.settings = self.tuning.problems
        self.get_logger().info(f'{name} set to {value}')

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
        try:
            role = shared_role(msg)
        except (ValueError, RoleEngineError) as error:
            self.get_logger().error(f'dropped malformed process role: {error}')
            return
        self.watch.heard(msg.robot, self._now(), role, arrived=msg.arrived)
        if msg.arrived and msg.robot not in self.arrived:
            self.arrived.add(msg.robot)
            self.get_logger().info(f'{msg.robot} arrived at {msg.role_id} ({len(self.arrived)}/{len(self.active)})')
            if self.arrived >= set(self.active):
                self.get_logger().info(f'round {self.round}: formation complete')
                self._finish()

    def _finish(self) -> None:
        if self.exit_when_done and not self.finished.done():
            self.finished.set_result(True)

    def _tick(self) -> None:
        if self.phase == 'negotiate':
            self._negotiate(self.pending_why)
        elif self.phase == 'watch':
            self._observe()
            problems = [p for p in self.watch.problems(self._now()) if p.robot in self.active]
            if problems:
                why = '; '.join(str(p) for p in problems)
                self.get_logger().warn(f'round {self.round}: {why}; renegotiating without them')
                self.excluded.extend(p.robot for p in problems)
                self.phase = 'negotiate'
                self.pending_why = why
                self._negotiate(why)

    def _observe(self) -> None:
        """Feed the camera-tracked positions of the round's robots to the problem watch."""
        if not self.camera.ready():
            return
        try:
            stamp, _ = self.camera.frame()
            self._track()
        except (ValueError, RoleEngineError) as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return
        t = stamp.nanoseconds * 1e-9
        for robot in self.active:
            observation = self.observations.get(robot)
            if observation is not None and observation.found:
                self.watch.observed(robot, t, observation.position)

    def _negotiate(self, why: str = 'initial negotiation') -> None:
        if not self.camera.ready():
            return
        try:
            rgb = self._track()
        except (ValueError, RoleEngineError) as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return
        robots = [m for m in self.team if m.name not in self.excluded]
        if self.round > 0 and len(robots) < self.tuning.min_robots:
            self._abort(f'{why}: {len(robots)} usable robot(s) left, the formation needs min_robots = '
                        f'{self.tuning.min_robots}')
            return
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
                                  num_intervals=self.task.states - 1, lam=self.tuning.qualification_lambda,
                                  epsilon=self.task.gp.get('epsilon', 0.1), evaluate=TypedGPEvaluator(self.task))
        except RoleEngineError as error:
            self.get_logger().error(f'round {self.round}: {error}')
        msg = RoleAssignment(round=self.round, excluded_robots=list(self.excluded))
        if plan is None or not plan.feasible:
            # A renegotiation after a problem that finds no assignment aborts the task.
            msg.status = 'infeasible' if self.round == 1 else 'aborted'
            msg.message = f'{why}: ' + (plan.reason if plan is not None else 'no robot left to assign')
            self.active = []
            self.phase = 'done'
            self.get_logger().error(f'round {self.round}: {msg.status}: {msg.message}')
        else:
            start_time = self._now() + self.tuning.start_delay
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
            self.watch.expect({r.robot: shared_role(r) for r in msg.initial_roles})
            self.phase = 'watch'
            self.get_logger().info(f'round {self.round} ({why}): ' + ', '.join(
                f'{r}->{j}' for r, j in zip(msg.robots, msg.role_ids)) + f' (planned in {time.perf_counter() - began:.1f} s wall)')
        msg.header.stamp = self.get_clock().now().to_msg()
        if msg.status == 'assigned':
            # Before the assignment, with its stamp: the players play this round on this map.
            self.map_pub.publish(occupancy_grid_msg(environment, self.world_frame, msg.header.stamp))
        self.assignment_pub.publish(msg)
        for role in msg.initial_roles:
            self.channel_pub.publish(role)
        if msg.status != 'assigned':
            self._finish()

    def _abort(self, why: str) -> None:
        """Not negotiable: publish an 'aborted' assignment naming why, and stop watching."""
        self.round += 1
        self.active = []
        self.phase = 'done'
        msg = RoleAssignment(round=self.round, excluded_robots=list(self.excluded), status='aborted', message=why)
        msg.header.stamp = self.get_clock().now().to_msg()
        self.assignment_pub.publish(msg)
        self.get_logger().error(f'round {self.round}: aborted: {why}')
        self._finish()


def main(args=None) -> int:
    return run(RoleEngine, 'role_engine', args)


if __name__ == '__main__':
    sys.exit(main())
