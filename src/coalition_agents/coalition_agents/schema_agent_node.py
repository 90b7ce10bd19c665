"""schema_agent: one robot's IQ-ASyMTRe coalition agent (paper Algorithm 2, Section V).

The reasoning is :class:`~.core.agent.SchemaAgent` (pure Python); this node connects it to

The node is ``schema_agent`` in its robot's namespace (``/<robot>/schema_agent``; the robot is the
last component of the namespace, :class:`collab_tools.names.RobotNode`). Its per-robot names are
relative to that namespace; what the team shares lives under the team namespace (``team_namespace``
parameter, default: the parent of the node's namespace, ``/`` for ``/<robot>``). It connects the
reasoning to

* the bridge: ``set_sensor_active`` switches the ES-EPS pairs a potential solution needs
  (temporarily during the search; after it only the chosen coalition's stay on), and their topics
  are what the sensors retrieve (QoS SENSOR_IN, so best-effort publishers are accepted):
  ``fiducials`` (each detected team robot or library object X gives F_R(X, robot)), ``gps``,
  ``scan``, ``bumper`` (a report means the sensor's label is retrieved) -- see
  :class:`~.core.live_sensing.LiveSensing`;
* the agent channel, ``<team>/coalition/channel/<robot>`` inboxes (:class:`~.agent_channel.AgentChannel`:
  link model, retries, exactly-once delivery, commitments): requests, offers and request-and-wait
  negotiation;
* ``coalition`` (coalition_interfaces/AgentStatus, LATCHED): its state (searching,
  negotiating, committed, failed, idle), the coalition, its leader, members and cost; it reads
  teammates' statuses at ``<team>/<teammate>/coalition``.

Parameters: :mod:`.agent_parameters` (descriptors with ranges; ``max_speed``, ``goal_tolerance``,
``stream_rate`` and ``tick_period`` apply when set at run time, the others are read-only).

Life cycle (sim time, ``use_sim_time``): once every teammate's agent listens on the channel (or
after ``team_wait``) a robot with a task starts the search. The agent is event-driven: a channel
message (request, offer) wakes it through a guard condition, so it re-instantiates what the
messages changed and sends better offers as soon as the executor has delivered the messages
ready now (several at once), in slices of ``reasoning_slice`` wall seconds (steps of a
:class:`~.core.cooperative_work.CooperativeWork` queue, shared by the agents of a
schema_agent_host) so that its inbox, timers and sensor reports -- and those of the other hosted
agents -- are served in between; the ``tick_period`` timer catches changes of the sensor readings
and the deadlines. It negotiates its least-cost coalition (the cheapest per set of members, in
non-descending cost: if one helper refuses or cannot be reached, the next) once it has an
executable coalition whose cost has not improved for ``settle_time`` (no cheaper coalition came
from the offers since), or at ``search_time`` at the latest (``settle_time`` >= ``search_time``:
always the whole search time, the paper's rule). Its status reports when the first executable
coalition was found (``detail``: ``first executable coalition at <t> s (<t - start> s, cost
<c>)``, published as a ``searching`` status when it happens and kept in later details), so
"found" and "formed" are both in the bag. It keeps the sensors of that coalition active (and those of
the answers it gives itself, footnote 10) and publishes it. A helper accepts the first coalition
that asks it (CommitmentLedger: one commitment at a time) and keeps the sensors it serves its
leader with.

Execution (after the coalition is set up):

* Streaming: every ``1 / stream_rate`` s a committed helper evaluates each answer it serves a
  coalition member on its current readings and incoming streams
  (:func:`~.core.information_values.evaluate`) and sends the value as an INFORMATION message
  (loss-tolerant: no ACK, the latest value wins; stale after ``stream_timeout``,
  :class:`~.core.information_stream.InformationStream`). The leader instantiates its task's
  required information from its own readings, the streams and the a-priori values
  (``goal_position`` for F_G(goal)), e.g. F_G(local) = helper's F_G composed with the helper's
  F_R(local, helper).
* Motor schemas (``drive``: true; :mod:`~.core.motor_schema`): the leader publishes
  ``cmd_vel`` (COMMAND_OUT) -- ``navigate`` goes to the goal (heading from the GPS, or estimated from its
  motion when a teammate's fiducial localises it); ``push_box_cooperatively`` pushes the box to
  the goal and waits while the teammate's streamed bumper is not pressed. A committed helper runs
  ``maintain_relative_position`` on its fiducial view of the leader (a pushing teammate also
  creeps into contact and keeps pressing; a leader out of view is searched for by turning
  towards where it was last seen). When the MS is done the leader stops, releases its
  helpers and reports ``completed`` (``failed`` after ``task_time_limit``).
* Re-forming (``reform_timeout`` > 0; 0, the default, keeps a coalition however its information
  fares): when a source of the chosen solution -- a helper's stream or the leader's own reading --
  has had no current value for ``reform_timeout``, the leader stops, releases the coalition
  (RELEASE to every helper through the channel) and searches again without the helpers that
  stopped, at most ``max_reforms`` times, then reports ``failed``. A driving leader whose
  candidates all refuse (busy in other coalitions) also searches again.

``exit_when_done``: exit once the coalition is set up or failed (a driving leader: once its task
is completed or failed, and the robots in ``exit_after`` report theirs too) / the helper released.

Malformed channel messages and malformed sensor reports are logged and dropped; bad parameters
stop the node with exit code 2 and a message naming the parameter.

Fiducial values carry the seen entity's relative orientation (bridge ``FiducialDetection.yaw``,
:func:`~.core.live_sensing.fiducial_values`), so inverting F_R and composing through a robot
localised by a fiducial are computed on values; the heading estimator of the motor schema only
serves values that still lack a ``yaw``. The INFORMATION values travel in AgentMessage's
``values`` (``NamedValue[]``; see :mod:`.agent_channel`).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

from bridge_interfaces.msg import BumperState, FiducialDetections
from builtin_interfaces.msg import Time
from bridge_interfaces.srv import SetSensorActive
from coalition_interfaces.msg import AgentStatus
from collab_tools import qos
from collab_tools.names import RobotNode
from collab_tools.node_support import ConfigurationError, run
from collab_tools.parameters import NodeParameters
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist, Vector3
from rclpy.node import Node
from rclpy.task import Future
from sensor_msgs.msg import LaserScan

from .agent_channel import CHANNEL_TOPIC, AgentChannel
from .agent_parameters import (
    FILES, capability_source, declare_agent_parameters, link_model, load_files, retry_policy, task_named,
)
from .core.agent import FeasibleCoalition, SchemaAgent
from .core.agent_state import AgentState
from .core.channel_codec import ChannelCodec, ChannelMessage, MessageKind, offer_message, request_message
from .core.coalition_execution import CoalitionExecution
from .core.cooperative_work import CooperativeWork
from .core.errors import CoalitionError
from .core.information import Entity, InformationInstance
from .core.information_stream import InformationStream
from .core.information_values import ValueUnavailable, evaluate
from .core.motor_schema import STOP, BoxPush, GoToGoal, HeadingEstimator, MaintainRelativePosition, Velocity
from .core.live_sensing import fiducial_values
from .core.reliable_channel import Negotiation, Received
from .core.solution_space import SolutionSpaceCache

#: Bridge sensors: name -> (topic suffix, message type).
BRIDGE_SENSORS = {
    'fiducial': ('fiducials', FiducialDetections),
    'gps': ('gps', PoseWithCovarianceStamped),
    'laser': ('scan', LaserScan),
    'bumper': ('bumper', BumperState),
}


class SchemaAgentNode(Node):
    """One robot's agent, node ``schema_agent`` in its robot's namespace (``/<robot>/schema_agent``).

    ``namespace``, ``cli_args``, ``parameter_overrides``, ``context``: as for rclpy's Node (a
    schema_agent_host gives each hosted agent its namespace and its own arguments; a standalone
    node takes them from the command line). ``solution_caches`` (schemas, costs files ->
    SolutionSpaceCache) and ``work`` (a CooperativeWork queue) are shared by a host between its
    agents: robots of equal capabilities then reuse each other's generated, memoised sub-trees
    (the reasoning is deterministic, so sharing changes no result, only the CPU time), and the
    agents' deferred work runs through one queue. None: the agent's own.
    """

    def __init__(self, namespace: str | None = None, *, cli_args: list[str] | None = None,
                 parameter_overrides: list | None = None, context=None, solution_caches: dict | None = None,
                 work: CooperativeWork | None = None):
        super().__init__('schema_agent', namespace=namespace, context=context, cli_args=cli_args,
                         use_global_arguments=cli_args is None, parameter_overrides=parameter_overrides)
        self.params = NodeParameters(self)
        self.names = RobotNode(self, self.params)
        self.robot = self.names.robot
        values = declare_agent_parameters(self.params, {
            'max_speed': self._set_max_speed, 'goal_tolerance': self._set_goal_tolerance,
            'stream_rate': self._set_stream_rate, 'tick_period': self._set_tick_period})
        library, costs, tasks, capability_file = load_files(values)
        files = {name: Path(values[name]) for name in FILES}
        source = capability_source(values)
        team_of = "the capability file's" if source == 'capability_file' else "parameter capabilities'"
        team = dict(capability_file.robots)
        if self.robot not in team:
            raise ConfigurationError(f"namespace {self.get_namespace()}: robot '{self.robot}' is not in "
                                     f"{team_of} robots ({', '.join(team) or 'none'})")
        for sensor in team[self.robot].sensors:
            if sensor.sensor not in BRIDGE_SENSORS:
                raise ConfigurationError(
                    f"parameter {source}: robot {self.robot}'s sensor '{sensor.sensor}' is not a bridge sensor "
                    f"(allowed: {', '.join(BRIDGE_SENSORS)})")
        task_name = values['task']
        task = None if task_name == 'none' else task_named(tasks, task_name, 'task')
        team_task_name = values['team_task']
        team_task = task_named(tasks, team_task_name, 'team_task') if team_task_name else None
        if task is None and team_task is None:
            raise ConfigurationError("parameter team_task: required when task is 'none' (the task the team works "
                                     f"on: {', '.join(tasks)})")
        self.search_time, self.settle_time = values['search_time'], values['settle_time']
        self.hold_seconds = values['hold_seconds']
        tick_period = values['tick_period']
        self.reasoning_slice = values['reasoning_slice']
        self.team_wait = values['team_wait']
        self.exit_when_done = values['exit_when_done']
        self.stream_period = 1.0 / values['stream_rate']
        self.reform_timeout = values['reform_timeout']
        self.max_reforms = values['max_reforms']
        self.drive = values['drive']
        self.task_time_limit = values['task_time_limit']
        self.exit_after = values['exit_after']
        goal = values['goal_position']
        self.stream = InformationStream(values['stream_timeout'])
        # The ranges are checked by the descriptors, so the motor schemas' own checks cannot fail.
        self.navigate = GoToGoal(max_speed=values['max_speed'], tolerance=values['goal_tolerance'])
        self.push = BoxPush(standoff=values['box_standoff'], lateral_offset=values['push_offset'],
                            tolerance=values['goal_tolerance'])
        link = link_model(values)
        try:
            cache = None
            if solution_caches is not None:
                key = (str(files['schemas_file'].resolve()), str(files['costs_file'].resolve()))
                cache = solution_caches.setdefault(key, SolutionSpaceCache(library, costs))
            self.agent = SchemaAgent(self.robot, team, library, costs, task, self, team_task=team_task,
                                     reading_timeout_s=values['reading_timeout'], cache=cache)
            if task is not None:
                self.agent.reasoner.task_space()  # the robot must be able to run the task's MS
        except (CoalitionError, ValueError) as exc:
            raise ConfigurationError(f'parameter task: {exc}') from None
        self.task_name = task_name
        self.team_motor_schema = (task if task is not None else team_task).motor_schema
        self.team = tuple(team)
        if self.drive and task is not None and task.motor_schema not in MOTOR_SCHEMAS:
            raise ConfigurationError(f"parameter drive: task {task_name}'s motor schema {task.motor_schema} has no "
                                     f"implementation here (implemented: {', '.join(MOTOR_SCHEMAS)})")
        self.priors = {InformationInstance('F_G', (Entity('goal', robot=False),)): {'x': float(goal[0]),
                                                                                     'y': float(goal[1])},
                       InformationInstance('F_M'): {}}
        codec = ChannelCodec.for_team(library, self.team)
        self.work = work
        if self.work is None:
            trigger = self.create_guard_condition(lambda: self.work.run())
            self.work = CooperativeWork(trigger.trigger, 2 * self.reasoning_slice, self._step_failed)
        self.channel = AgentChannel(self, self.robot, codec, link, team=self.team, on_message=self._on_message,
                                    policy=retry_policy(values), work=self.work,
                                    topic=self.names.team(CHANNEL_TOPIC))
        # Per-robot names are relative (this node's namespace is its robot's).
        self.status_pub = self.create_publisher(AgentStatus, 'coalition', qos.LATCHED)
        self.sensor_client = self.create_client(SetSensorActive, 'set_sensor_active')
        for sensor in team[self.robot].sensor_names:
            topic, msg_type = BRIDGE_SENSORS[sensor]
            self.create_subscription(msg_type, topic, lambda msg, sensor=sensor: self._on_sensor(sensor, msg),
                                     qos.SENSOR_IN)
        self.cmd_pub = self.create_publisher(Twist, 'cmd_vel', qos.COMMAND_OUT) if self.drive else None
        self.execution: CoalitionExecution | None = None
        self.heading = HeadingEstimator()
        self.follow: MaintainRelativePosition | None = None
        self.ms_phase = ''
        self.task_complete = False
        self.task_started_at: float | None = None
        self._reforms = 0
        self._last_unavailable = ''
        self._tick_period = tick_period
        self.stream_timer = self.create_timer(self.stream_period, self._stream)
        unknown = [name for name in self.exit_after if name not in team]
        if unknown:
            raise ConfigurationError(f"parameter exit_after: {unknown[0]!r} is not in {team_of} robots "
                                     f"({', '.join(team)})")
        self.others_done: set[str] = set()
        for name in self.exit_after:
            self.create_subscription(AgentStatus, self.names.teammate(name, 'coalition'),
                                     lambda msg, name=name: self._on_other_status(name, msg), qos.LATCHED)
        self._own_done = False
        self.finished = Future()
        self.state = 'idle'
        self.started_at: float | None = None
        self.first_clock: float | None = None
        self.formed_at: float | None = None
        self.helping_since: float | None = None
        self.candidates: list[FeasibleCoalition] = []
        self.negotiation: Negotiation | None = None
        self.chosen: FeasibleCoalition | None = None
        self.commitment: tuple[str, str, tuple[str, ...], float] | None = None  # id, leader, members, cost
        self.detail = ''
        self._attempts = 0
        self._pending_switches: list[tuple[str, bool]] = []
        self.found_at: float | None = None
        self.found_cost = 0.0
        self.finished_at: float | None = None
        self.goal_distance = math.nan
        self._best_cost: float | None = None
        self._best_since: float | None = None
        self.tick_timer = self.create_timer(tick_period, self._tick)
        self._publish_status()
        self.get_logger().info(f"{self.robot}: task {task_name}, team {', '.join(self.team)}, link {link!r}, "
                               f'search {self.search_time:g} s, settle {self.settle_time:g} s')

    # --- dynamic parameters (agent_parameters.DYNAMIC): applied from the next use on -----------------
    def _set_max_speed(self, value: float) -> None:
        self.navigate.max_speed = value
        if self.follow is not None:
            self.follow.max_speed = value

    def _set_goal_tolerance(self, value: float) -> None:
        self.navigate.tolerance = self.push.tolerance = value

    def _set_stream_rate(self, value: float) -> None:
        self.stream_period = 1.0 / value
        self.stream_timer.timer_period_ns = int(self.stream_period * 1e9)
        self.stream_timer.reset()

    def _set_tick_period(self, value: float) -> None:
        self._tick_period = value
        self.tick_timer.timer_period_ns = int(value * 1e9)
        self.tick_timer.reset()

    # --- Outbox (what the core agent asks for) --------------------------------------------------
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

    # --- inputs -------------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_sensor(self, sensor: str, msg) -> None:
        if sensor not in self.agent.active_sensors:
            return  # a report published before we switched it off
        try:
            detected, values = sensor_values(sensor, msg)
            self.agent.sensing.report(sensor, self._now(), detected, values)
        except (CoalitionError, ValueError) as exc:
            self.get_logger().warning(f'{self.robot}: dropped a malformed {sensor} report: {exc}',
                                      throttle_duration_sec=5.0)

    def _on_message(self, message: ChannelMessage, received: Received) -> None:
        now = self._now()
        try:
            if message.kind is MessageKind.REQUEST:
                if self.helping_since is None:
                    self.helping_since = now
                    if self.state == 'idle':
                        self.state = 'helping'
                        self._publish_status()
                self.agent.on_request(message.request, message)
                self.work.request(self._reason_step)
            elif message.kind is MessageKind.OFFER:
                self.agent.on_offer(message.offer)
                self.work.request(self._reason_step)
            elif message.kind is MessageKind.INFORMATION:
                if (self.commitment is not None and message.coalition_id == self.commitment[0]
                        and message.sender in self.commitment[2]):  # only the coalition's members
                    self.stream.update(message.sender, message.instance, dict(message.values), message.message_id, now)
            elif message.kind is MessageKind.COMMIT_REQUEST and received.accepted:
                self.commitment = (message.coalition_id, message.sender, message.members, message.cost)
                self.stream.forget()
                self.follow = None
                self.state = 'committed'
                self.formed_at = now
                serving = self.agent.sensors_serving(message.sender)
                if self.drive:  # the helper MS needs the leader in view and its own contact
                    serving += tuple(s for s in ('fiducial', 'bumper') if s in self.agent.sensing.sensors)
                self.agent.keep_only(serving)
                self.get_logger().info(f'{self.robot}: committed to coalition {message.coalition_id} of '
                                       f"{message.sender} ({', '.join(message.members)}, cost {message.cost:g})")
                self._publish_status()
            elif message.kind in (MessageKind.COMMIT_ACCEPT, MessageKind.COMMIT_REJECT):
                if self.state == 'negotiating':
                    self._lead(now)  # the negotiation may be decided: do not wait for the tick
            elif message.kind is MessageKind.RELEASE and self.commitment and self.commitment[0] == message.coalition_id:
                self.get_logger().info(f'{self.robot}: released from coalition {message.coalition_id}')
                self.commitment = None
                self.state = 'idle'
                self.agent.keep_only(())
                self.follow = None
                self._command(STOP)
                self._publish_status()
                if self.exit_when_done and not self.finished.done():
                    self.finished.set_result(True)
        except (CoalitionError, ValueError) as exc:
            self.get_logger().warning(f'{self.robot}: dropped {message}: {exc}')

    # --- the search ----------------------------------------------------------------------------------
    def _reason_step(self) -> bool:
        """The agent's inputs changed: evaluate (see the module docstring), one
        ``reasoning_slice`` per step of :attr:`work`; True while work is left."""
        if self.started_at is None:
            return False  # the periodic tick starts the search
        now = self._now()
        more = self.agent.tick(now, budget_s=self.reasoning_slice)
        if self.agent.task is not None and self.state in ('searching', 'negotiating'):
            self._lead(now)
        return more

    def _step_failed(self, step, exc: Exception) -> None:
        self.get_logger().error(f'{self.robot}: {getattr(step, "__name__", step)} failed: {type(exc).__name__}: {exc}')

    def _tick(self) -> None:
        now = self._now()
        if now <= 0.0:
            return  # no /clock yet
        self._flush_switches()
        if self.started_at is None:
            if self.first_clock is None:
                self.first_clock = now
            # Start when every teammate listens on the channel (a request sent before would only
            # be retried), or after team_wait without them.
            listening = 1 + self.channel.teammates_listening(
                lambda teammate: self.names.teammate(teammate, 'coalition'))
            if listening < len(self.team) and now - self.first_clock < self.team_wait:
                return
            if listening < len(self.team):
                self.get_logger().warning(f'{self.robot}: {listening} of {len(self.team)} agents on the channel '
                                          f'after {self.team_wait:g} s; starting anyway')
            self.started_at = now
            self.task_started_at = now
            if self.agent.task is not None:
                self.state = 'searching'
                self.agent.start()
                self._publish_status()
        self.work.request(self._reason_step)  # readings and deadlines change with time
        if self.agent.task is not None:
            self._lead(now)
            if self.state == 'committed' and self.execution is not None:
                self._execute(now)
        elif self.drive and self.state == 'committed':
            self._help(now)
        elif (self.exit_when_done and self.commitment is None and self.helping_since is not None
              and now >= self.helping_since + 3 * self.search_time and not self.finished.done()):
            self.agent.keep_only(())
            self.finished.set_result(True)

    def _settled(self, now: float) -> bool:
        """Track the cheapest executable coalition; True once it is time to negotiate: it has
        not improved for settle_time, or the search time is over."""
        coalitions = self.agent.coalitions(now)
        if coalitions:
            cost = coalitions[0].cost
            if self.found_at is None:
                self.found_at, self.found_cost = now, cost
                self.detail = (f'search started at {self.started_at:.3f} s; first executable coalition at '
                               f'{now:.3f} s ({now - self.started_at:.3f} s, cost {cost:g})')
                self.get_logger().info(f'{self.robot}: {self.detail}')
                self._publish_status()
            if self._best_cost is None or cost < self._best_cost:
                self._best_cost, self._best_since = cost, now
        if now >= self.started_at + self.search_time:
            return True
        # Settled only while the coalition is executable now: readings that lapsed for a moment
        # (a busy executor) must not end the search before search_time with nothing to propose.
        return bool(coalitions) and self._best_since is not None and now - self._best_since >= self.settle_time

    def _lead(self, now: float) -> None:
        if self.state == 'searching' and self._settled(now):
            seen: set = set()
            self.candidates = []
            for coalition in self.agent.coalitions(now):
                if frozenset(coalition.members) not in seen:
                    seen.add(frozenset(coalition.members))
                    self.candidates.append(coalition)
            self.get_logger().info(f'{self.robot}: {len(self.candidates)} executable coalition(s) after '
                                   f'{now - self.started_at:.2f} s' + ''.join(f'\n{c.describe()}' for c in self.candidates[:3]))
            self._propose_next(now)
        elif self.state == 'negotiating' and self.negotiation is not None:
            state = self.negotiation.state(now)
            if state == 'established':
                self._established(now)
            elif state in ('failed', 'expired'):
                self.get_logger().warning(f'{self.robot}: coalition {self.negotiation.coalition_id} {state}: '
                                          f'{self.negotiation.rejected}')
                self.channel.release(self.negotiation.coalition_id, 'negotiation failed')
                self._propose_next(now)

    # --- execution: streaming, motor schemas, re-forming ---------------------------------------------
    def _stream(self) -> None:
        """Send the current value of every instance this robot serves its coalition (helpers; a
        leader serves itself locally)."""
        if self.commitment is None or self.started_at is None:
            return
        now = self._now()
        coalition_id, _, members, _ = self.commitment
        others = [robot for robot in members if robot != self.robot]
        for requester, answer, lcs in self.agent.served_answers(others):
            try:
                value = evaluate(lcs, lambda i: self.agent.sensing.value(i, now),
                                 lambda provider, i: self._streamed(provider, i, now), self.priors)[answer]
            except ValueUnavailable:
                continue  # not computable now (e.g. the leader out of view): the leader sees it stale
            self.channel.stream(requester, coalition_id, answer, value)

    def _execute(self, now: float) -> None:
        """The leader: re-form when the coalition's information stops flowing, else run the MS."""
        check = self.execution.check(now, lambda p, i: self._streamed(p, i, now) is not None,
                                     lambda s, i: self.agent.sensing.value(i, now) is not None)
        if check.reform:
            self._reform(now, check)
            return
        if not self.drive:
            return
        if self.task_time_limit > 0 and now - self.task_started_at > self.task_time_limit:
            self._finish_task(now, 'failed', f'time limit: {self.detail.split("; executing ")[-1]}')
            return
        try:
            command = self._motor_schema(now)
        except ValueUnavailable as exc:
            command = STOP
            if str(exc) != self._last_unavailable:
                self._last_unavailable = str(exc)
                self.get_logger().warning(f'{self.robot}: motor schema waits: {exc}')
        self._command(command)
        if self.task_complete:
            self._finish_task(now, 'completed', self.detail.split('; executing ')[-1])

    def _finish_task(self, now: float, state: str, why: str) -> None:
        """The task is over (done, or out of time): stop, release the helpers, report."""
        coalition_id = self.commitment[0]
        self._command(STOP)
        self.channel.release(coalition_id, f'task {state}')
        self.execution = None
        self.state = state
        self.finished_at = now
        self.detail = f'{self.detail.split("; executing")[0]}; task {state} at {now:.3f} s ({why})'
        log = self.get_logger().info if state == 'completed' else self.get_logger().error
        log(f'{self.robot}: task {self.task_name} {state}: {why}; coalition {coalition_id} released')
        self.agent.keep_only(())
        self._publish_status()
        self._own_done = True
        self._maybe_finish()

    def _on_other_status(self, robot: str, msg) -> None:
        if msg.state in (AgentStatus.COMPLETED, AgentStatus.FAILED):
            self.others_done.add(robot)
            self._maybe_finish()

    def _maybe_finish(self) -> None:
        if (self.exit_when_done and self._own_done and self.others_done >= set(self.exit_after)
                and not self.finished.done()):
            self.finished.set_result(True)

    def _motor_schema(self, now: float) -> Velocity:
        values = evaluate(self.chosen.lcs, lambda i: self.agent.sensing.value(i, now),
                          lambda p, i: self._streamed(p, i, now), self.priors, self._headings())
        by_label: dict[tuple[str, str], dict] = {}
        for instance, value in values.items():
            by_label[(instance.label, str(instance.referents[0]) if instance.referents else '')] = value
        me = by_label[('F_G', self.robot)]
        if 'yaw' in me:
            self.heading.measured(me['yaw'])
        heading = self.heading.fix(me['x'], me['y']) if 'yaw' not in me else self.heading.heading
        goal = by_label[('F_G', 'goal')]
        motor_schema = self.agent.task.motor_schema
        if motor_schema == 'navigate':
            distance = self.navigate.distance((me['x'], me['y']), (goal['x'], goal['y']))
            self.goal_distance = distance
            command = self.navigate.command((me['x'], me['y']), heading, (goal['x'], goal['y']))
            self._phase('done' if command == STOP and distance <= self.navigate.tolerance else 'navigate',
                        f'distance to goal {distance:.2f} m')
        else:
            box = by_label[('F_G', 'box')]
            pressed = by_label[('F_B', self.robot)]['pressed'] > 0.5
            teammates = [v['pressed'] > 0.5 for (label, who), v in by_label.items() if label == 'F_B' and who != self.robot]
            command, state = self.push.command((me['x'], me['y']), heading, (box['x'], box['y']),
                                               (goal['x'], goal['y']), pressed, all(teammates) if teammates else None)
            self.goal_distance = state.box_to_goal
            self._phase(state.phase, f'box {state.box_to_goal:.2f} m from the goal')
        self.heading.commanded(command, self._tick_period)
        return command

    def _headings(self) -> dict[str, float]:
        return {} if self.heading.heading is None else {self.robot: self.heading.heading}

    def _streamed(self, provider: str, instance: InformationInstance, now: float,
                  visiting: frozenset = frozenset()) -> dict | None:
        """The current value of a CS leaf: a teammate's stream, or for a request this robot
        answered itself (footnote 10) its own cheapest answer that can be computed now
        (``visiting``: the self-answers being computed, so an answer never feeds itself)."""
        if provider != self.robot:
            return self.stream.value(provider, instance, now)
        if instance in visiting:
            return None
        inner = visiting | {instance}
        for lcs in self.agent.own_answers(instance):
            try:
                return evaluate(lcs, lambda i: self.agent.sensing.value(i, now),
                                lambda p, i: self._streamed(p, i, now, inner), self.priors,
                                self._headings())[instance]
            except ValueUnavailable:
                continue
        return None

    def _phase(self, phase: str, detail: str) -> None:
        if phase == self.ms_phase:
            return
        self.ms_phase = phase
        self.task_complete = phase == 'done'
        self.get_logger().info(f'{self.robot}: motor schema {self.agent.task.motor_schema}: {phase} ({detail})')
        self.detail = f'{self.detail.split("; executing")[0]}; executing {phase}: {detail}'
        self._publish_status()

    def _help(self, now: float) -> None:
        """A committed helper's MS maintain_relative_position: keep the leader where it was seen."""
        leader = self.commitment[1]
        seen = None
        if 'fiducial' in self.agent.sensing.sensors:
            seen = self.agent.sensing.value(InformationInstance('F_R', (Entity(leader, robot=True),
                                                                        Entity(self.robot, robot=True))), now)
        if seen is not None and self.follow is None:
            self.follow = MaintainRelativePosition((seen['x'], seen['y']), max_speed=self.navigate.max_speed)
            self.get_logger().info(f'{self.robot}: keeping {leader} at ({seen["x"]:.2f}, {seen["y"]:.2f}) m')
        pressed = None
        if self.team_motor_schema == 'push_box_cooperatively' and 'bumper' in self.agent.sensing.sensors:
            bumper = self.agent.sensing.value(InformationInstance('F_B', (Entity(self.robot, robot=True),)), now)
            pressed = None if bumper is None else bumper['pressed'] > 0.5
        if self.follow is not None:
            self._command(self.follow.command(None if seen is None else (seen['x'], seen['y']), pressed))

    def _command(self, command: Velocity) -> None:
        if self.cmd_pub is not None:
            self.cmd_pub.publish(Twist(linear=Vector3(x=command.linear), angular=Vector3(z=command.angular)))

    def _reform(self, now: float, check) -> None:
        coalition_id = self.commitment[0]
        self._command(STOP)
        self.get_logger().warning(f'{self.robot}: coalition {coalition_id} infeasible for {check.infeasible_for:.2f} s '
                                  f"({'; '.join(check.missing)}): releasing it")
        self.channel.release(coalition_id, 'information stopped: ' + '; '.join(check.missing))
        self.commitment, self.execution, self.chosen, self.negotiation = None, None, None, None
        self.stream.forget()
        self.ms_phase = ''
        if self._reforms >= self.max_reforms:
            self.state = 'failed'
            self.detail = f'coalition {coalition_id} lost ({"; ".join(check.missing)}); {self._reforms} re-form(s) used'
            self.get_logger().error(f'{self.robot}: {self.detail}')
            self.agent.keep_only(())
            self._publish_status()
            self._own_done = True
            self._maybe_finish()
            return
        self._reforms += 1
        self.get_logger().info(f'{self.robot}: re-forming ({self._reforms}/{self.max_reforms})'
                               + (f" without {', '.join(check.lost_helpers)}" if check.lost_helpers else ''))
        self.started_at = now
        self.state = 'searching'
        self.found_at = self._best_cost = self._best_since = self.formed_at = None
        self.agent.restart(exclude=check.lost_helpers)
        self._publish_status()

    def _propose_next(self, now: float) -> None:
        if not self.candidates and self.drive and self._attempts and self._reforms < self.max_reforms:
            # A driving leader whose candidates were all refused (their robots busy) searches again:
            # robots free up when other tasks end.
            self._reforms += 1
            self.get_logger().warning(f'{self.robot}: no coalition could be set up; searching again '
                                      f'({self._reforms}/{self.max_reforms})')
            self.started_at = now
            self.state = 'searching'
            self.found_at = self._best_cost = self._best_since = self.formed_at = None
            self.agent.restart()
            self._publish_status()
            return
        while self.candidates:
            candidate = self.candidates.pop(0)
            self._attempts += 1
            coalition_id = f'{self.robot}/{self.channel.new_id()}'
            negotiation, reason = self.channel.propose(coalition_id, candidate.members, candidate.cost,
                                                       self.hold_seconds)
            if negotiation is None:
                self.get_logger().warning(f'{self.robot}: cannot lead {coalition_id}: {reason}')
                continue
            self.negotiation, self.chosen, self.state = negotiation, candidate, 'negotiating'
            self._publish_status()
            if negotiation.state(now) == 'established':  # no helpers to wait for
                self._established(now)
            return
        self.state = 'failed'
        self.detail = (f'no executable coalition could be set up after {now - self.started_at:.2f} s '
                       f'({self._attempts} negotiation(s))')
        self.get_logger().error(f'{self.robot}: {self.detail}')
        self.agent.keep_only(())
        self._publish_status()
        self._own_done = True
        self._maybe_finish()

    def _established(self, now: float) -> None:
        chosen, negotiation = self.chosen, self.negotiation
        self.formed_at = now
        self.state = 'committed'
        self.commitment = (negotiation.coalition_id, self.robot, chosen.members, chosen.cost)
        # Its own sensors, and those of the answers it gives itself (footnote 10 self-requests).
        self.agent.keep_only(chosen.sensors() + self.agent.sensors_serving(self.robot))
        self.execution = CoalitionExecution(chosen.lcs, now, self.reform_timeout or math.inf)
        found = '' if self.found_at is None else \
            f'first executable coalition at {self.found_at:.3f} s ({self.found_at - self.started_at:.3f} s); '
        self.detail = (f'search started at {self.started_at:.3f} s; {found}formed at {now:.3f} s '
                       f'({now - self.started_at:.3f} s); potential solution {chosen.potential_solution.rank + 1}')
        self.get_logger().info(f'{self.robot}: coalition {negotiation.coalition_id} established: '
                               f'{chosen.describe()}')
        self._publish_status()
        if not self.drive:  # a driving leader is done when its task is
            self._own_done = True
            self._maybe_finish()

    def _publish_status(self) -> None:
        msg = AgentStatus()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.robot = self.robot
        msg.state = int(AgentState.from_label(self.state))
        msg.task = self.task_name
        msg.search_started = stamp(self.started_at if self.agent.task is not None else None)
        msg.coalition_found = stamp(self.found_at)
        msg.found_cost = float(self.found_cost if self.found_at is not None else 0.0)
        msg.coalition_formed = stamp(self.formed_at)
        msg.task_finished = stamp(self.finished_at)
        msg.potential_solution = 0 if self.chosen is None or self.formed_at is None else self.chosen.potential_solution.rank + 1
        msg.reforms = self._reforms
        msg.goal_distance = float(self.goal_distance)
        if self.commitment is not None:
            msg.coalition_id, msg.leader, members, msg.cost = self.commitment
            msg.members = list(members)
        stats = self.channel.stats()
        msg.requests_sent = self.agent.requests_sent
        msg.offers_received = self.agent.offers_received
        msg.retries = stats['resent']
        msg.duplicates = stats['duplicates']
        msg.dropped = stats['dropped']
        msg.detail = self.detail
        self.status_pub.publish(msg)


#: Motor schemas this node can run (the task's ``motor_schema``).
MOTOR_SCHEMAS = ('navigate', 'push_box_cooperatively')


def stamp(seconds: float | None) -> Time:
    """A status stamp from the node's clock in seconds (None: the zero stamp, "not yet")."""
    if seconds is None:
        return Time()
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def sensor_values(sensor: str, msg) -> tuple[list[str], dict]:
    """(detected names, values) of one bridge sensor report (values of information_stream)."""
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
