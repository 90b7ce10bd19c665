"""schema_agent: one robot's IQ-ASyMTRe coalition agent (paper Algorithm 2, Section V).

The reasoning is :class:`~.core.agent.SchemaAgent` (pure Python); this node connects it to

* the bridge: ``/<robot>/set_sensor_active`` switches the ES-EPS pairs a potential solution needs
  (temporarily during the search; after it only the chosen coalition's stay on), and their topics
  are what the sensors retrieve: ``/<robot>/fiducials`` (each detected team robot or library
  object X gives F_R(X, robot)), ``/<robot>/gps``, ``/<robot>/scan``, ``/<robot>/bumper`` (a report
  means the sensor's label is retrieved) -- see :class:`~.core.live_sensing.LiveSensing`;
* the agent channel ``/coalition/channel`` (:class:`~.agent_channel.AgentChannel`: link model,
  retries, exactly-once delivery, commitments): requests, offers and request-and-wait
  negotiation;
* ``/<robot>/coalition`` (coalition_interfaces/AgentStatus, latched): its state (searching,
  negotiating, committed, failed, idle), the coalition, its leader, members and cost.

Life cycle (sim time, ``use_sim_time``): once every teammate's agent listens on the channel (or
after ``team_wait``) a robot with a task starts the search; every ``tick_period`` it re-instantiates its reply spaces and sends better offers. After
``search_time`` it negotiates its least-cost coalition (the cheapest per set of members, in
non-descending cost: if one helper refuses or cannot be reached, the next), keeps the sensors
of that coalition active and publishes it. A helper accepts the first coalition that asks it
(CommitmentLedger: one commitment at a time) and keeps the sensors it serves its leader with.

Not done yet: the motor schema (driving), re-forming when the coalition stops being feasible,
and streaming the helpers' information to the leader after the coalition is set up.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

from bridge_interfaces.msg import BumperState, FiducialDetections
from bridge_interfaces.srv import SetSensorActive
from coalition_interfaces.msg import AgentStatus
from collab_tools.node_support import ConfigurationError, declare as declare_parameter, run
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from sensor_msgs.msg import LaserScan

from .agent_channel import AgentChannel
from .core.agent import FeasibleCoalition, SchemaAgent
from .core.capabilities import load_capability_file
from .core.channel_codec import ChannelCodec, ChannelMessage, MessageKind, offer_message, request_message
from .core.errors import CoalitionError
from .core.link_model import LinkModel
from .core.reliable_channel import Negotiation, Received
from .core.schemas import load_costs, load_library
from .core.tasks import load_tasks

#: Bridge sensors: name -> (topic suffix, message type).
BRIDGE_SENSORS = {
    'fiducial': ('fiducials', FiducialDetections),
    'gps': ('gps', PoseWithCovarianceStamped),
    'laser': ('scan', LaserScan),
    'bumper': ('bumper', BumperState),
}


class SchemaAgentNode(Node):
    def __init__(self):
        super().__init__('schema_agent')
        for name, default, description in (
                ('robot', '', 'robot this agent reasons for (a robot of the capability file)'),
                ('capability_file', '', 'team capability YAML (config/coalitions/capabilities/*.yaml)'),
                ('schemas_file', '', 'schema library YAML (config/coalitions/schemas.yaml)'),
                ('costs_file', '', 'schema costs YAML (config/coalitions/costs.yaml)'),
                ('tasks_file', '', 'tasks YAML (config/coalitions/tasks.yaml)'),
                ('task', 'none', "task name from tasks_file, or 'none' (a pure helper)"),
                ('team_task', '', "for task 'none': the task the team works on (its priors, helper MS)"),
                ('link_preset', 'paper_fig9', 'link model preset (paper_fig9 | ideal)'),
                ('link_delay_mean', -1.0, 'one-way delay mean, s (normal, truncated at 0); < 0 = preset'),
                ('link_delay_std', -1.0, 'one-way delay std, s; < 0 = preset'),
                ('loss_probability', 0.0, 'probability that a message copy is lost, [0, 1]'),
                ('seed', -1, 'link model seed; -1 = fresh'),
                ('search_time', 3.0, 'sim s of search before negotiating the least-cost coalition, > 0'),
                ('hold_seconds', 0.0, 'commitment hold time sent to helpers, s; 0 = until released'),
                ('reading_timeout', 1.0, 'sim s a sensor report stays current, > 0'),
                ('tick_period', 0.1, 'sim s between re-evaluations, > 0'),
                ('team_wait', 10.0, 'sim s to wait for every teammate on the channel before searching, > 0'),
                ('exit_when_done', False, 'exit once the coalition is set up (or failed) / the helper released')):
            declare_parameter(self, name, default, description)
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        self.robot = self._text(p, 'robot')
        files = {name: self._path(p, name) for name in ('capability_file', 'schemas_file', 'costs_file', 'tasks_file')}
        try:
            library = load_library(files['schemas_file'])
        except (CoalitionError, ValueError, OSError) as exc:
            raise ConfigurationError(f'parameter schemas_file: {exc}') from None
        loaded = {}
        for name, loader in (('costs_file', lambda f: load_costs(f)), ('tasks_file', lambda f: load_tasks(f, library)),
                             ('capability_file', lambda f: load_capability_file(f, library))):
            try:
                loaded[name] = loader(files[name])
            except (CoalitionError, ValueError, OSError) as exc:
                raise ConfigurationError(f'parameter {name}: {exc}') from None
        costs, tasks, capability_file = loaded['costs_file'], loaded['tasks_file'], loaded['capability_file']
        team = dict(capability_file.robots)
        if self.robot not in team:
            raise ConfigurationError(f"parameter robot: '{self.robot}' is not in the capability file's robots "
                                     f"({', '.join(team) or 'none'})")
        for sensor in team[self.robot].sensors:
            if sensor.sensor not in BRIDGE_SENSORS:
                raise ConfigurationError(
                    f"parameter capability_file: robot {self.robot}'s sensor '{sensor.sensor}' is not a bridge sensor "
                    f"(allowed: {', '.join(BRIDGE_SENSORS)})")
        task_name = self._text(p, 'task')
        task = None if task_name == 'none' else self._task(tasks, task_name, 'task')
        team_task_name = str(p('team_task') or '')
        team_task = self._task(tasks, team_task_name, 'team_task') if team_task_name else None
        if task is None and team_task is None:
            raise ConfigurationError("parameter team_task: required when task is 'none' (the task the team works "
                                     f"on: {', '.join(tasks)})")
        self.search_time = self._positive(p, 'search_time')
        self.hold_seconds = self._number(p, 'hold_seconds', 0.0, 'a number >= 0')
        reading_timeout = self._positive(p, 'reading_timeout')
        tick_period = self._positive(p, 'tick_period')
        self.team_wait = self._positive(p, 'team_wait')
        self.exit_when_done = bool(p('exit_when_done'))
        link = self._link_model(p)
        try:
            self.agent = SchemaAgent(self.robot, team, library, costs, task, self, team_task=team_task,
                                     reading_timeout_s=reading_timeout)
            if task is not None:
                self.agent.reasoner.task_space()  # the robot must be able to run the task's MS
        except (CoalitionError, ValueError) as exc:
            raise ConfigurationError(f'parameter task: {exc}') from None
        self.task_name = task_name
        self.team = tuple(team)
        codec = ChannelCodec.for_team(library, self.team)
        self.channel = AgentChannel(self, self.robot, codec, link, team=self.team, on_message=self._on_message)
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.status_pub = self.create_publisher(AgentStatus, f'/{self.robot}/coalition', latched)
        self.sensor_client = self.create_client(SetSensorActive, f'/{self.robot}/set_sensor_active')
        for sensor in team[self.robot].sensor_names:
            topic, msg_type = BRIDGE_SENSORS[sensor]
            self.create_subscription(msg_type, f'/{self.robot}/{topic}',
                                     lambda msg, sensor=sensor: self._on_sensor(sensor, msg), 10)
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
        self.create_timer(tick_period, self._tick)
        self._publish_status()
        self.get_logger().info(f"{self.robot}: task {task_name}, team {', '.join(self.team)}, link {link!r}, "
                               f'search {self.search_time:g} s')

    # --- parameters ----------------------------------------------------------------------------
    @staticmethod
    def _text(p, name: str) -> str:
        value = p(name)
        if not isinstance(value, str) or not value:
            raise ConfigurationError(f'parameter {name}: required (got {value!r})')
        return value

    def _path(self, p, name: str) -> Path:
        path = Path(self._text(p, name))
        if not path.is_file():
            raise ConfigurationError(f'parameter {name}: no such file {path}')
        return path

    @staticmethod
    def _task(tasks, name: str, parameter: str):
        if name not in tasks:
            raise ConfigurationError(f"parameter {parameter}: unknown task '{name}' (known: {', '.join(tasks)}"
                                     + (", or 'none'" if parameter == 'task' else '') + ')')
        return tasks[name]

    @staticmethod
    def _number(p, name: str, lowest: float, allowed: str, strict: bool = False) -> float:
        value = p(name)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                or value < lowest or (strict and value == lowest):
            raise ConfigurationError(f'parameter {name}: must be {allowed} (got {value!r})')
        return float(value)

    def _positive(self, p, name: str) -> float:
        return self._number(p, name, 0.0, 'a number > 0', strict=True)

    def _link_model(self, p) -> LinkModel:
        loss = self._number(p, 'loss_probability', 0.0, 'a number in [0, 1]')
        if loss > 1.0:
            raise ConfigurationError(f'parameter loss_probability: must be a number in [0, 1] (got {loss!r})')
        seed = p('seed')
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < -1:
            raise ConfigurationError(f'parameter seed: must be an integer >= 0, or -1 (got {seed!r})')
        data: dict = {'preset': p('link_preset'), 'loss_probability': loss, 'seed': None if seed == -1 else seed}
        mean, std = p('link_delay_mean'), p('link_delay_std')
        try:
            if any(isinstance(v, (int, float)) and not isinstance(v, bool) and v >= 0 for v in (mean, std)):
                base = LinkModel.from_dict({'preset': data['preset']}).delay
                data['delay'] = {'distribution': 'normal',
                                 'mean_s': float(mean) if mean >= 0 else base.mean_s,
                                 'std_s': float(std) if std >= 0 else base.std_s}
            return LinkModel.from_dict(data)
        except (CoalitionError, ValueError, TypeError) as exc:
            raise ConfigurationError(f'parameter {str(exc).replace("link.", "link_", 1)}') from None

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
        detected = [d.name for d in msg.detections] if sensor == 'fiducial' else ()
        self.agent.observe(sensor, self._now(), detected)

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
            elif message.kind is MessageKind.OFFER:
                self.agent.on_offer(message.offer)
            elif message.kind is MessageKind.COMMIT_REQUEST and received.accepted:
                self.commitment = (message.coalition_id, message.sender, message.members, message.cost)
                self.state = 'committed'
                self.agent.keep_only(self.agent.sensors_serving(message.sender))
                self.get_logger().info(f'{self.robot}: committed to coalition {message.coalition_id} of '
                                       f"{message.sender} ({', '.join(message.members)}, cost {message.cost:g})")
                self._publish_status()
            elif message.kind is MessageKind.RELEASE and self.commitment and self.commitment[0] == message.coalition_id:
                self.get_logger().info(f'{self.robot}: released from coalition {message.coalition_id}')
                self.commitment = None
                self.state = 'idle'
                self.agent.keep_only(())
                self._publish_status()
                if self.exit_when_done and not self.finished.done():
                    self.finished.set_result(True)
        except (CoalitionError, ValueError) as exc:
            self.get_logger().warning(f'{self.robot}: dropped {message}: {exc}')

    # --- the search ----------------------------------------------------------------------------------
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
            listening = self.channel.publisher.get_subscription_count()
            if listening < len(self.team) and now - self.first_clock < self.team_wait:
                return
            if listening < len(self.team):
                self.get_logger().warning(f'{self.robot}: {listening} of {len(self.team)} agents on the channel '
                                          f'after {self.team_wait:g} s; starting anyway')
            self.started_at = now
            if self.agent.task is not None:
                self.state = 'searching'
                self.agent.start()
                self._publish_status()
        self.agent.tick(now)
        if self.agent.task is not None:
            self._lead(now)
        elif (self.exit_when_done and self.commitment is None and self.helping_since is not None
              and now >= self.helping_since + 3 * self.search_time and not self.finished.done()):
            self.agent.keep_only(())
            self.finished.set_result(True)

    def _lead(self, now: float) -> None:
        if self.state == 'searching' and now >= self.started_at + self.search_time:
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

    def _propose_next(self, now: float) -> None:
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
        if self.exit_when_done and not self.finished.done():
            self.finished.set_result(True)

    def _established(self, now: float) -> None:
        chosen, negotiation = self.chosen, self.negotiation
        self.formed_at = now
        self.state = 'committed'
        self.commitment = (negotiation.coalition_id, self.robot, chosen.members, chosen.cost)
        self.agent.keep_only(chosen.sensors())
        self.detail = (f'search started at {self.started_at:.3f} s; formed at {now:.3f} s '
                       f'({now - self.started_at:.3f} s); potential solution {chosen.potential_solution.rank + 1}')
        self.get_logger().info(f'{self.robot}: coalition {negotiation.coalition_id} established: '
                               f'{chosen.describe()}')
        self._publish_status()
        if self.exit_when_done and not self.finished.done():
            self.finished.set_result(True)

    def _publish_status(self) -> None:
        msg = AgentStatus()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.robot = self.robot
        msg.state = self.state
        msg.task = self.task_name
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


def main(args=None) -> int:
    return run(SchemaAgentNode, 'schema_agent', args)


if __name__ == '__main__':
    sys.exit(main())
