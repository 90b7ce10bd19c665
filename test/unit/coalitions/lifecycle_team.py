"""An in-process team of coalition agents with their whole life cycle, no ROS: every robot's
SchemaAgent and AgentLifecycle on its own ReliableChannel (commitments, admission rule, retries)
as the schema_agent node wires them; a lossless FIFO network delivers the channel messages; the
sensors report a static scene at every tick (planar poses; a fiducial sees what ``sees`` says)."""
from __future__ import annotations

import collections
import math

from coalition_agents.core.agent import SchemaAgent
from coalition_agents.core.lifecycle import AgentLifecycle
from coalition_agents.core.settings import AgentSettings
from coalition_agents.core.transport.codec import information_message, offer_message, request_message
from coalition_agents.core.transport.reliable_channel import ReliableChannel


def capability_text(types: dict[str, tuple[str, ...]], robots: dict[str, str]) -> str:
    """A capability document: type -> sensors (bridge names), robot -> type."""
    provides = {'gps': 'F_G(local)', 'fiducial': 'F_R(X, local)', 'laser': 'F_A(local)', 'bumper': 'F_B(local)'}
    lines = ['robot_types:']
    for name, sensors in types.items():
        lines += [f'  {name}:', '    sensors:']
        lines += [f"      - {{name: {sensor}, provides: ['{provides[sensor]}']}}" for sensor in sensors]
        lines += ['    motor_schemas: [navigate, maintain_relative_position, push_box_cooperatively]']
    lines += ['robots:'] + [f'  {robot}: {kind}' for robot, kind in robots.items()]
    return '\n'.join(lines) + '\n'


def relative(pose, observer):
    (x, y, yaw), (ox, oy, oyaw) = pose, observer
    dx, dy = x - ox, y - oy
    return {'x': math.cos(-oyaw) * dx - math.sin(-oyaw) * dy, 'y': math.sin(-oyaw) * dx + math.cos(-oyaw) * dy,
            'yaw': yaw - oyaw}


class Port:
    """The node's side of one life cycle, recorded."""

    def __init__(self, team):
        self.team = team
        self.statuses, self.logs, self.commands = [], [], []
        self.finished = False

    def publish_status(self, report):
        self.statuses.append((self.team.now, report))

    def command(self, velocity):
        self.commands.append(velocity)

    def log(self, level, text):
        self.logs.append((level, text))

    def finish(self):
        self.finished = True

    def request_reasoning(self):
        pass

    def teammates_listening(self):
        return len(self.team.robots) - 1


class Channel:
    """One robot's end of the agent channel (the node's AgentChannel in process) and the
    SchemaAgent's outbox."""

    def __init__(self, robot, team, first_message_id=1):
        self.robot, self.team = robot, team
        self.core = ReliableChannel(robot, first_message_id=first_message_id)
        self.switches: list[tuple[str, bool]] = []

    # CoalitionChannel
    def new_id(self):
        return self.core.new_id()

    def propose(self, coalition_id, members, cost, hold_seconds):
        negotiation, messages, reason = self.core.propose(coalition_id, members, cost, self.team.now, hold_seconds)
        self.team.queue.extend(messages)
        return negotiation, reason

    def release(self, coalition_id, reason=''):
        self.team.queue.extend(self.core.release(coalition_id, self.team.now, reason))

    def stream(self, receiver, coalition_id, instance, values):
        message = information_message(self.robot, self.new_id(), receiver, coalition_id, instance, values)
        self.team.queue.extend(self.core.send(message, self.team.now))

    def admit_with(self, rule):
        self.core.ledger.admission = rule

    def announce(self):
        self.announced = self.team.now

    def drop_commitment(self, coalition_id, leader):
        self.core.ledger.release(coalition_id, leader, self.team.now)

    # the SchemaAgent's Outbox
    def set_sensor(self, sensor, active):
        self.switches.append((sensor, active))

    def send_request(self, request, recipients):
        self.team.queue.extend(self.core.send(request_message(request, self.new_id()), self.team.now, recipients))

    def send_offer(self, offer, reply_to):
        self.team.queue.extend(self.core.send(offer_message(offer, self.new_id(), reply_to), self.team.now))


class Team:
    """``tasks``: robot -> task name or 'none'; ``poses``: robot -> (x, y, yaw); ``sees``: robot ->
    the robots its fiducial sees; ``values``: per-robot settings overrides (e.g. drive)."""

    def __init__(self, files, capabilities, tasks, poses, sees, team_task='navigation', values=None, **common):
        self.now = 0.0
        self.queue: collections.deque = collections.deque()
        self.poses, self.sees = poses, sees
        self.robots = list(tasks)
        self.lives, self.ports, self.channels, self.settings = {}, {}, {}, {}
        self.starts: collections.Counter = collections.Counter()
        self._values = lambda robot: {**files, 'capabilities': capabilities, 'task': tasks[robot],
                                      'team_task': team_task, **common, **(values or {}).get(robot, {})}
        for robot in tasks:
            self.start(robot)

    def start(self, robot):
        """Start ``robot``'s agent (again: a restarted agent knows nothing of its earlier self)."""
        settings = self.settings[robot] = AgentSettings.build(self._values(robot), robot)
        self.starts[robot] += 1  # a restarted agent's message ids are new ones (the node takes them from the clock)
        channel, port = Channel(robot, self, 1 + 10 ** 9 * (self.starts[robot] - 1)), Port(self)
        agent = SchemaAgent(robot, settings.team, settings.library, settings.costs, settings.task, channel,
                            team_task=settings.team_task)
        self.lives[robot] = AgentLifecycle(agent, settings, port, channel)
        self.ports[robot], self.channels[robot] = port, channel

    def observe(self):
        for robot, life in self.lives.items():
            sensing = life.agent.sensing
            for sensor in sensing.sensors:
                if sensor not in life.agent.active_sensors:
                    continue
                if sensor == 'fiducial':
                    seen = list(self.sees.get(robot, ()))
                    sensing.report(sensor, self.now, seen,
                                   {name: relative(self.poses[name], self.poses[robot]) for name in seen})
                elif sensor == 'gps':
                    sensing.report(sensor, self.now, (), dict(zip(('x', 'y', 'yaw'), self.poses[robot])))
                elif sensor == 'bumper':
                    sensing.report(sensor, self.now, (), {'pressed': 0.0})
                else:
                    sensing.report(sensor, self.now, (), {'min_range': 3.0})

    def accepts(self, message) -> bool:
        """Whether ``message`` reaches its receiver (every one here; a subclass may drop some)."""
        return True

    def running(self) -> dict:
        """The life cycles that reason, tick and stream this step (all of them here)."""
        return self.lives

    def after_step(self, now, running) -> None:
        """What a subclass does at the end of a step (nothing here)."""

    def deliver(self, limit=100000):
        count = 0
        while self.queue:
            count += 1
            assert count < limit, 'the channel did not go quiet'
            message = self.queue.popleft()
            if not self.accepts(message):
                continue
            channel = self.channels[message.receiver]
            received = channel.core.receive(message, self.now)
            self.queue.extend(received.replies)
            if received.deliver is not None:
                self.lives[message.receiver].on_message(received.deliver, received, self.now)
        return count

    def step(self, now, stream=True):
        self.now = now
        self.observe()
        self.deliver()
        running = self.running()
        for life in running.values():
            for _ in range(1000):
                more = life.reasoning_step(now)
                self.deliver()
                if not more:
                    break
        for life in running.values():
            life.on_tick(now)
            self.deliver()
        if stream:
            for life in running.values():
                life.on_stream_timer(now)
            self.deliver()
        self.after_step(now, running)

    def run(self, start, end, dt=0.1, until=None):
        now = start
        while now <= end + 1e-9:
            self.step(now)
            if until is not None and until(self):
                return now
            now = round(now + dt, 6)
        return now

    def state(self, robot):
        return self.lives[robot].state

    def report(self, robot):
        return self.ports[robot].statuses[-1][1]
