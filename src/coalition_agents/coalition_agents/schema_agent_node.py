"""schema_agent: one robot's IQ-ASyMTRe coalition agent (paper Algorithm 2, Section V) on ROS.

The reasoning is :class:`~.core.agent.SchemaAgent` and the life cycle (search, settle rule,
negotiation, commitment, streaming, motor schemas, re-forming) :class:`~.core.lifecycle.AgentLifecycle`,
both pure Python; this node declares the parameters (:data:`~.core.settings.AGENT_SETTINGS`; the
dynamic ones apply at run time), converts messages, owns the timers and QoS, and connects it to

* the bridge: ``set_sensor_active`` switches the ES-EPS pairs a potential solution needs; their
  topics (QoS SENSOR_IN) are what the sensors retrieve: ``fiducials`` (each detected robot or
  object X gives F_R(X, robot)), ``gps``, ``scan``, ``bumper`` (:class:`~.core.live_sensing.LiveSensing`;
  a report retrieving new information makes the agent reason at once); ``cmd_vel`` if ``drive``;
* the agent channel (:class:`~.transport.agent_channel.AgentChannel`: batches in bundles on
  ``<team>/coalition/bundles``, one subscription per process, link model, retries, exactly-once
  delivery, commitments): requests, offers, negotiation, streamed INFORMATION values (the stream
  timer runs only while the robot holds a coalition);
* ``coalition`` (coalition_interfaces/AgentStatus, LATCHED): its typed state, the coalition, its
  leader, members and cost and the stamps of its search; it reads the statuses of the robots in
  ``exit_after`` at ``<team>/<teammate>/coalition``. ``commitments`` lists every coalition it
  serves at once (its own first) and what its schemas do for each (capability sharing).

The node is ``schema_agent`` in its robot's namespace (``/<robot>/schema_agent``,
:class:`collab_tools.names.RobotNode`); what the team shares lives under ``team_namespace``
(default: the parent of the node's namespace). Its reasoning runs in ``reasoning_slice`` (steps of a
:class:`~.core.cooperative_work.CooperativeWork` queue, shared by the agents of a
schema_agent_host) so the channel, timers and sensor reports are served in between.

Every callback goes through the InputGuard (malformed input dropped, counted, logged once per kind); dead
and restarted teammates: :mod:`.core.teammate_faults`. Bad parameters exit 2.
"""
from __future__ import annotations

import math
import sys

from bridge_interfaces.msg import BumperState, FiducialDetections
from bridge_interfaces.srv import SetSensorActive
from builtin_interfaces.msg import Time
from coalition_interfaces.msg import AgentStatus, CoalitionCommitment
from collab_tools import qos
from collab_tools.input_guard import InputGuard, MalformedInput
from collab_tools.names import RobotNode
from collab_tools.node_support import ConfigurationError, run
from collab_tools.parameters import NodeParameters
from collab_tools.port_logging import PortLogger
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist, Vector3
from rclpy.node import Node
from rclpy.task import Future
from sensor_msgs.msg import LaserScan

from .core.agent import SchemaAgent
from .core.agent_state import AgentState, StatusReport
from .core.cooperative_work import CooperativeWork
from .core.errors import CoalitionError
from .core.lifecycle import AgentLifecycle
from .core.live_sensing import fiducial_values
from .core.motor_schema import Velocity
from .core.settings import AGENT_SETTINGS, BRIDGE_SENSORS, AgentSettings
from .core.solution_space import SolutionSpaceCache
from .core.transport.codec import ChannelCodec, ChannelMessage, offer_message, request_message
from .core.transport.reliable_channel import Received
from .transport.agent_channel import CHANNEL_TOPIC, AgentChannel
from .transport.channel_hub import ChannelHub

#: Bridge sensors: name -> (topic suffix, message type).
SENSOR_TOPICS = {
    'fiducial': ('fiducials', FiducialDetections),
    'gps': ('gps', PoseWithCovarianceStamped),
    'laser': ('scan', LaserScan),
    'bumper': ('bumper', BumperState),
}
assert tuple(SENSOR_TOPICS) == BRIDGE_SENSORS


class SchemaAgentNode(Node):
    """One robot's agent, node ``schema_agent`` in its robot's namespace (``/<robot>/schema_agent``).

    ``namespace``, ``cli_args``, ``parameter_overrides``, ``context``: as for rclpy's Node (a
    schema_agent_host gives each hosted agent its namespace and its own arguments; a standalone
    node takes them from the command line). ``solution_caches`` (schemas, costs files ->
    SolutionSpaceCache) and ``work`` (a CooperativeWork queue) are shared by a host between its
    agents: robots of equal capabilities then reuse each other's generated, memoised sub-trees
    (the reasoning is deterministic, so sharing changes no result, only the CPU time), and the
    agents' deferred work runs through one queue; ``hub`` (a
    :class:`~.transport.channel_hub.ChannelHub`) holds the process's one channel publisher,
    subscriptions and timer. None: the agent's own.
    """

    def __init__(self, namespace: str | None = None, *, cli_args: list[str] | None = None,
                 parameter_overrides: list | None = None, context=None, solution_caches: dict | None = None,
                 work: CooperativeWork | None = None, hub: ChannelHub | None = None):
        super().__init__('schema_agent', namespace=namespace, context=context, cli_args=cli_args,
                         use_global_arguments=cli_args is None, parameter_overrides=parameter_overrides)
        self._port_logger = PortLogger(self.get_logger())  # the life cycle's log lines
        self.params = NodeParameters(self)
        self.names = RobotNode(self, self.params)
        self.robot = self.names.robot
        values = self.params.declare_schema(AGENT_SETTINGS, {
            'max_speed': lambda v: self.lifecycle.set_max_speed(v),
            'goal_tolerance': lambda v: self.lifecycle.set_goal_tolerance(v),
            'stream_rate': self._set_stream_rate, 'tick_period': self._set_tick_period})
        settings = AgentSettings.build(values, self.robot, f'namespace {self.get_namespace()}')
        self.settings = settings
        self.exit_when_done = settings['exit_when_done']
        cache = None
        if solution_caches is not None:
            cache = solution_caches.setdefault(settings.solution_cache_key(),
                                               SolutionSpaceCache(settings.library, settings.costs))
        try:
            agent = SchemaAgent(self.robot, settings.team, settings.library, settings.costs, settings.task, self,
                                team_task=settings.team_task, reading_timeout_s=settings['reading_timeout'],
                                cache=cache)
            if settings.task is not None:
                agent.reasoner.task_space()  # the robot must be able to run the task's MS
        except (CoalitionError, ValueError) as exc:
            raise ConfigurationError(f'parameter task: {exc}') from None
        self.agent = agent
        self.work = work
        if self.work is None:
            trigger = self.create_guard_condition(lambda: self.work.run())
            self.work = CooperativeWork(trigger.trigger, 2 * settings['reasoning_slice'], self._step_failed)
        self.channel = AgentChannel(self, self.robot, ChannelCodec.for_team(settings.library, agent.team),
                                    settings.link, team=agent.team, on_message=self._on_message, policy=settings.retry,
                                    work=self.work, topic=self.names.team(CHANNEL_TOPIC), hub=hub, liveness=settings.liveness(),
                                    watched=lambda: self.lifecycle.watched_teammates(), on_teammate=self._on_teammate)
        self.finished = Future()
        self.lifecycle = AgentLifecycle(agent, settings, self, self.channel)
        # Per-robot names are relative (this node's namespace is its robot's).
        self.status_pub = self.create_publisher(AgentStatus, 'coalition', qos.LATCHED)
        self.sensor_client = self.create_client(SetSensorActive, 'set_sensor_active')
        self._pending_switches: list[tuple[str, bool]] = []
        self._retrieved: dict[str, tuple] = {}  # sensor -> the instances of its last report
        inputs = InputGuard.of(self)  # every callback: malformed input dropped, counted, logged once per kind
        for sensor in settings.team[self.robot].sensor_names:
            topic, msg_type = SENSOR_TOPICS[sensor]
            inputs.subscribe(msg_type, topic, lambda msg, sensor=sensor: self._on_sensor(sensor, msg), qos.SENSOR_IN)
        self.cmd_pub = self.create_publisher(Twist, 'cmd_vel', qos.COMMAND_OUT) if settings['drive'] else None
        self.stream_timer = self.create_timer(1.0 / settings['stream_rate'],
                                              lambda: self.lifecycle.on_stream_timer(self._now()))
        self._streaming = True  # until the first status says what it holds
        for name in settings['exit_after']:
            inputs.subscribe(AgentStatus, self.names.teammate(name, 'coalition'),
                             lambda msg, name=name: self._on_teammate_status(name, msg), qos.LATCHED)
        self.tick_timer = self.create_timer(settings['tick_period'], self._tick)
        self.lifecycle.publish()
        self.get_logger().info(f"{self.robot}: task {settings.task_name}, team {', '.join(agent.team)}, "
                               f"link {settings.link!r}, search {settings['search_time']:g} s, "
                               f"settle {settings['settle_time']:g} s")

    # --- dynamic parameters (the others are read-only) -------------------------------------------
    def _set_stream_rate(self, value: float) -> None:
        self.stream_timer.timer_period_ns = int(1e9 / value)
        self.stream_timer.reset() if self._streaming else None

    def _stream_while(self, serving: bool) -> None:  # the stream timer runs only while a coalition is held
        if serving != self._streaming:
            self._streaming = serving
            self.stream_timer.reset() if serving else self.stream_timer.cancel()

    def _set_tick_period(self, value: float) -> None:
        self.lifecycle.set_tick_period(value)
        self.tick_timer.timer_period_ns = int(value * 1e9)
        self.tick_timer.reset()

    # --- SchemaAgent's Outbox ---------------------------------------------------------------------
    def set_sensor(self, sensor: str, active: bool) -> None:
        self._pending_switches.append((sensor, active))
        self._flush_switches()

    def _flush_switches(self) -> None:
        if not self._pending_switches or not self.sensor_client.service_is_ready():
            return
        for sensor, active in self._pending_switches:
            future = self.sensor_client.call_async(SetSensorActive.Request(sensor=sensor, active=active))
            future.add_done_callback(lambda f, sensor=sensor, active=active: self._switched(sensor, active, f))
        self._pending_switches.clear()

    def _switched(self, sensor: str, active: bool, future) -> None:
        response = future.result()
        if response is None or not response.success:
            self.get_logger().error(f"{self.robot}: could not switch {sensor} {'on' if active else 'off'}: "
                                    f"{getattr(response, 'message', 'no response')}")

    def send_request(self, request, recipients) -> None:
        self.channel.send(request_message(request, self.channel.new_id()), recipients)

    def send_offer(self, offer, reply_to: ChannelMessage) -> None:
        self.channel.send(offer_message(offer, self.channel.new_id(), reply_to))

    # --- the life cycle's port ----------------------------------------------------------------------
    def publish_status(self, report: StatusReport) -> None:
        self.status_pub.publish(status_message(report, self.channel.stats(), self.get_clock().now().to_msg()))
        self._stream_while(bool(report.commitments))

    def command(self, velocity: Velocity) -> None:
        if self.cmd_pub is not None:
            self.cmd_pub.publish(Twist(linear=Vector3(x=velocity.linear), angular=Vector3(z=velocity.angular)))

    def log(self, level: str, text: str) -> None:
        self._port_logger.log(level, text)

    def finish(self) -> None:
        if not self.finished.done():
            self.finished.set_result(True)

    def request_reasoning(self) -> None:
        self.work.request(self._reason_step)

    def teammates_listening(self) -> int:
        return self.channel.teammates_listening(lambda teammate: self.names.teammate(teammate, 'coalition'))

    # --- inputs -------------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_sensor(self, sensor: str, msg) -> None:
        if sensor not in self.agent.active_sensors:
            return  # a report published before we switched it off
        detected, values = sensor_values(sensor, msg)  # malformed: the input guard drops it
        found = self.agent.sensing.report(sensor, self._now(), detected, values)
        if self._retrieved.get(sensor) != found:  # new information: reason now, not at the next tick
            self._retrieved[sensor] = found
            self.request_reasoning()

    def _on_message(self, message: ChannelMessage, received: Received) -> None:
        self.lifecycle.on_message(message, received, self._now())

    def _on_teammate_status(self, robot: str, msg) -> None:
        if msg.state not in AgentState._value2member_map_ or msg.robot != robot:
            raise MalformedInput(f'status: {msg.robot[:40]!r} state {msg.state} on {robot}\'s topic', 'bad status')
        self.lifecycle.on_teammate_status(robot, AgentState(msg.state))

    def _on_teammate(self, event: str, robot: str, detail: str) -> None:  # the channel's liveness
        if event == 'back':
            self.lifecycle.on_teammate_back(robot, self._now())
        else:
            self.lifecycle.on_teammate_lost(robot, self._now(), detail, restarted=event == 'restarted')

    def _reason_step(self) -> bool:
        return self.lifecycle.reasoning_step(self._now())

    def _step_failed(self, step, exc: Exception) -> None:
        self.get_logger().error(f'{self.robot}: {getattr(step, "__name__", step)} failed: {type(exc).__name__}: {exc}')

    def _tick(self) -> None:
        now = self._now()
        if now <= 0.0:
            return  # no /clock yet
        self._flush_switches()
        self.lifecycle.on_tick(now)


def stamp(seconds: float | None) -> Time:
    """A status stamp from the node's clock in seconds (None: the zero stamp, "not yet")."""
    if seconds is None:
        return Time()
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def status_message(report: StatusReport, channel_stats: dict, header_stamp) -> AgentStatus:
    """The AgentStatus of a life-cycle report and the channel's counters."""
    msg = AgentStatus(robot=report.robot, session=channel_stats['session'], state=int(report.state),
                      task=report.task,
                      coalition_id=report.coalition_id, leader=report.leader, members=list(report.members),
                      cost=float(report.cost), search_started=stamp(report.search_started),
                      coalition_found=stamp(report.coalition_found), found_cost=float(report.found_cost),
                      coalition_formed=stamp(report.coalition_formed), task_finished=stamp(report.task_finished),
                      potential_solution=report.potential_solution, reforms=report.reforms,
                      goal_distance=float(report.goal_distance), requests_sent=report.requests_sent,
                      offers_received=report.offers_received, retries=channel_stats['resent'],
                      duplicates=channel_stats['duplicates'], dropped=channel_stats['dropped'], detail=report.detail,
                      commitments=[CoalitionCommitment(coalition_id=held.coalition_id, leader=held.leader,
                                                       members=list(held.members), cost=float(held.cost),
                                                       since=stamp(held.since), uses=list(held.uses))
                                   for held in report.commitments])
    msg.header.stamp = header_stamp
    return msg


def sensor_values(sensor: str, msg) -> tuple[list[str], dict]:
    """(detected names, values) of one bridge sensor report (values of :mod:`.core.value_fields`)."""
    if sensor == 'fiducial':
        return fiducial_values((d.name, d.x, d.y, d.yaw) for d in msg.detections)
    if sensor == 'gps':
        pose = msg.pose.pose
        q = pose.orientation
        yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        return [], {'x': float(pose.position.x), 'y': float(pose.position.y), 'yaw': yaw}
    if sensor == 'bumper':
        return [], {'pressed': 1.0 if msg.pressed else 0.0}
    ranges = [r for r in msg.ranges if math.isfinite(r)]
    return [], {'min_range': min(ranges) if ranges else float(msg.range_max)}


def main(args=None) -> int:
    return run(SchemaAgentNode, 'schema_agent', args)


if __name__ == '__main__':
    sys.exit(main())
