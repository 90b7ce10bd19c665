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
no workable assignment says ``infeasible``. A malformed process role on the channel (out of
bounds, a robot not in the team) or camera image (an invalid stamp) is dropped, counted and logged
once per kind by the node's input guard (collab_tools.input_guard).

Sessions (core.sessions): the node picks a random session id at start and puts it, with its node
name as the sender, into every assignment and initial process role; its rounds count from 1 in each
session, so players follow a restarted engine. It takes process roles of its own session sent by a
node of the role's robot, and ignores, counts and logs once per kind the others (``other session``,
``forged sender``). A player that plays no role announces itself on ``<team>/roles/players``
(role_interfaces/PlayerAnnouncement); a robot excluded as silent whose player is back is re-included
and the robots renegotiate (core.engine). Its tuning (core.node_settings.engine_tuning_schema) are dynamic ROS parameters
whose defaults are the shared settings file's values.

The decisions (when to negotiate, who is excluded, when to renegotiate or abort, and why) are
core.engine.RoleEngine's; this node adapts it: camera frames and channel messages in, the
team, the round's map, the assignment and the initial process roles out.

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

from rclpy.node import Node
from rclpy.task import Future
from nav_msgs.msg import OccupancyGrid
from role_interfaces.msg import PlayerAnnouncement, ProcessRole, RoleAssignment, Team

from collab_tools import qos
from collab_tools.core.input_checks import MalformedInput
from collab_tools.core.session_following import new_session
from collab_tools.input_guard import InputGuard
from collab_tools.names import TeamNode
from collab_tools.node_support import run
from collab_tools.parameters import NodeParameters
from collab_tools.port_logging import PortLogger
from collab_tools.top_camera import TopCamera

from .core.engine import CameraView, RoleEngine as EngineBehaviour, RoundOutcome
from .core import gp_compiled
from .core.errors import RoleEngineError
from .core.grid import GridFrame
from .core.sessions import check_announcement_sender, engine_channel_verdict
from .core.node_settings import ENGINE_SETTINGS, engine_settings_file, engine_tuning_schema, tuned
from .core.top_view import environment_from_top_view
from .core.tracking import ColorTracker, TrackedTarget
from .core.tuning import EngineTuning
from .role_messages import channel_role, occupancy_grid_msg, process_role_msg, team_msg


class RoleEngine(Node):
    def __init__(self):
        super().__init__('role_engine')
        # GP kernels loaded (or compiled) now, not in the first plan.
        self.get_logger().info(f'compiled GP kernels ready in {gp_compiled.warm_up():.2f} s')
        params = NodeParameters(self)
        self.names = TeamNode(self, params)
        settings = params.declare_schema(ENGINE_SETTINGS)
        self.task, scenario, self.team = engine_settings_file(settings['settings_file'])
        self.exit_when_done = settings['exit_when_done']
        tuning = EngineTuning.from_task(self.task)
        schema = engine_tuning_schema(tuning)
        tuning = tuned(tuning, params.declare_schema(schema, on_change={
            name: (lambda value, name=name: self._retune(name, value)) for name in schema.names}))
        self.frame = GridFrame.covering(scenario.world.bounds, self.task.grid_resolution)
        self.world_frame = scenario.world.frame_id
        self.targets = [TrackedTarget(m.name, m.color, m.robot_type.radius, m.height) for m in self.team]
        self.camera = TopCamera(self, self.names.team(settings['camera']))
        self.assignment_pub = self.create_publisher(RoleAssignment, self.names.team('roles/assignment'), qos.LATCHED)
        self.channel_pub = self.create_publisher(ProcessRole, self.names.team('roles/channel'), qos.RELIABLE)
        self.map_pub = self.create_publisher(OccupancyGrid, self.names.team('roles/map'), qos.LATCHED)
        team_pub = self.create_publisher(Team, self.names.team('roles/team'), qos.LATCHED)
        team = team_msg(self.team, self.world_frame)
        team.header.stamp = self.get_clock().now().to_msg()
        team_pub.publish(team)
        self.team_names = frozenset(m.name for m in self.team)
        self.sender, self.session = self.get_fully_qualified_name(), new_session()
        self.inputs = InputGuard.of(self)
        self.inputs.subscribe(ProcessRole, self.names.team('roles/channel'), self._on_role, qos.RELIABLE)
        self.inputs.subscribe(PlayerAnnouncement, self.names.team('roles/players'), self._on_announcement,
                              qos.RELIABLE)
        self.log = PortLogger(self.get_logger()).log    # the engine's log lines
        self.engine = EngineBehaviour(self.task, self.team, tuning, self)
        self.observations = None
        self.finished = Future()
        self.create_timer(0.25, self._tick)
        self.get_logger().info(f"{len(self.team)} robots ({', '.join(m.name for m in self.team)}), formation "
                               f"{self.task.formation['type']}, session {self.session}")

    def _retune(self, name: str, value) -> None:
        """A tuning parameter was set: the next check or negotiation uses it (RoleEngineError refuses)."""
        self.engine.retune(self.engine.tuning.with_values({name: value}))
        self.get_logger().info(f'{name} set to {value}')

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_role(self, msg: ProcessRole) -> None:
        if msg.robot and msg.robot not in self.team_names:
            channel_role(msg, self.team_names)          # MalformedInput 'unknown robot': counted, logged
        if not engine_channel_verdict(self.sender, self.session, msg.sender, msg.session, msg.robot):
            return  # its own initial roles
        if not self.engine.accepts(msg.robot, msg.round, msg.version):
            return  # the engine's own initial roles, or a role of an earlier round
        self.engine.heard(msg.robot, self._now(), channel_role(msg, self.team_names), msg.role_id, msg.arrived)

    def _on_announcement(self, msg: PlayerAnnouncement) -> None:
        if msg.robot not in self.team_names:
            raise MalformedInput(f'ignored an announcement of robot {msg.robot[:40]!r}: not in the team',
                                 kind='unknown robot')
        check_announcement_sender(msg.sender, msg.robot)
        self.engine.announced(msg.robot)

    def _tick(self) -> None:
        self.engine.tick(self._now(), self._look())

    def _look(self) -> CameraView | None:
        """The robots tracked on the newest camera frame and that frame's environment; None without one."""
        if not self.camera.ready():
            return None
        try:
            stamp, rgb = self.camera.frame()
            tracker = ColorTracker(self.targets, self.camera.geometry())
            self.observations = tracker.track(rgb, self.observations)
        except (ValueError, RoleEngineError) as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return None
        observations, geometry = self.observations, self.camera.geometry()
        heights = {m.name: m.height for m in self.team}
        radii = {m.name: m.robot_type.radius for m in self.team}

        def environment(robots):
            discs = [(*observations[name].position, radii[name], heights[name]) for name in robots]
            return environment_from_top_view(rgb, geometry, self.frame, robot_discs=discs, name='top_view')

        positions = {name: (o.position if o.found else None) for name, o in observations.items()}
        return CameraView(stamp.nanoseconds * 1e-9, positions, environment)

    # --- the engine's port -----------------------------------------------------------------------
    def publish_round(self, outcome: RoundOutcome) -> None:
        msg = RoleAssignment(sender=self.sender, session=self.session, round=outcome.round, excluded_robots=list(outcome.excluded), status=outcome.status,
                             message=outcome.message)
        for assigned in outcome.roles:
            role = assigned.role
            role_msg = process_role_msg(assigned.robot, assigned.role_id, outcome.round, 0, role.start_time,
                                        role.total_time, role.radius, role.trajectory, sender=self.sender,
                                        session=self.session)
            role_msg.header.stamp = self.get_clock().now().to_msg()
            msg.robots.append(assigned.robot)
            msg.role_ids.append(assigned.role_id)
            msg.goal_x.append(assigned.goal[0])
            msg.goal_y.append(assigned.goal[1])
            msg.initial_roles.append(role_msg)
        msg.header.stamp = self.get_clock().now().to_msg()
        if outcome.environment is not None:
            # Before the assignment, with its stamp: the players play this round on this map.
            self.map_pub.publish(occupancy_grid_msg(outcome.environment, self.world_frame, msg.header.stamp))
        self.assignment_pub.publish(msg)
        for role_msg in msg.initial_roles:
            self.channel_pub.publish(role_msg)

    def task_ended(self) -> None:
        if self.exit_when_done and not self.finished.done():
            self.finished.set_result(True)


def main(args=None) -> int:
    return run(RoleEngine, 'role_engine', args)


if __name__ == '__main__':
    sys.exit(main())
