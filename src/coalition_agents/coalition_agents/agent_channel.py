"""The agent-to-agent channel of a coalition agent on ROS 2: one shared topic, a link model on
the sending side, retries and commitments from :mod:`.core.reliable_channel`.

Every agent publishes and subscribes ``/coalition/channel`` (``coalition_interfaces/AgentMessage``,
reliable QoS, so the only losses are the modelled ones). Each copy an agent sends (one per
recipient; a broadcast is one copy per teammate) goes through its :class:`~.core.link_model.LinkModel`
first: dropped, or published after the sampled delay by a one-shot timer on the node's clock
(sim time when ``use_sim_time`` is set). Received messages are converted to the codec's dict
form, validated (:class:`~.core.channel_codec.ChannelCodec`), run through the
:class:`~.core.reliable_channel.ReliableChannel` (duplicates answered again but delivered once,
ACKs, commitment answers) and handed to ``on_message``. A malformed message is logged and
dropped; the channel never raises from a ROS callback.

Streamed information (kind INFORMATION = 8, :meth:`AgentChannel.stream`) goes through the same
link model but is never acknowledged or retried (the latest value wins). AgentMessage has no
numeric array field, so its values travel as a JSON object in ``reason`` (e.g.
``{"x": 1.2, "y": -0.4}``), decoded and checked by the codec like every other field; a
``float64[] values`` field in the interface would be the cleaner carrier.

Usage (in the schema_agent node)::

    channel = AgentChannel(node, 'robot_1', codec, LinkModel.preset('paper_fig9', loss_probability=0.2),
                           team=team, on_message=handle)
    channel.broadcast(request_message(request, channel.new_id()))
    negotiation, reason = channel.propose('robot_1/3', members, cost, hold_seconds=5.0)
"""
from __future__ import annotations

import json
import time
from typing import Callable, Iterable, Sequence

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from coalition_interfaces.msg import AgentMessage, ChainLink, Information

from .core.channel_codec import KIND_FIELDS, ChannelCodec, ChannelMessage, MessageKind, information_message
from .core.errors import CoalitionError
from .core.link_model import LinkModel
from .core.reliable_channel import Negotiation, Received, ReliableChannel, RetryPolicy, Undelivered

DEFAULT_TOPIC = '/coalition/channel'


def to_ros(message: ChannelMessage, stamp=None) -> AgentMessage:
    """The AgentMessage of a channel message (fields unused by its kind stay empty)."""
    data = message.to_dict()
    msg = AgentMessage()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.message_id = message.message_id
    msg.sender = message.sender
    msg.receiver = message.receiver
    msg.kind = int(message.kind)
    msg.conversation_id = message.conversation_id
    msg.in_reply_to = message.in_reply_to
    if 'label' in data:
        msg.label = _information(data['label'])
    if 'chain' in data:
        msg.chain = [ChainLink(requester=link['requester'], label=_information(link['label']))
                     for link in data['chain']]
    if 'instance' in data:
        msg.instance = _information(data['instance'])
    if 'cost' in data:
        msg.cost = float(data['cost'])
    if 'members' in data:
        msg.members = list(data['members'])
    msg.coalition_id = data.get('coalition_id', '')
    msg.hold_seconds = float(data.get('hold_seconds', 0.0))
    msg.reason = data.get('reason', '')
    if 'values' in data:
        msg.reason = json.dumps(data['values'], sort_keys=True)
    return msg


def from_ros(msg: AgentMessage) -> dict:
    """The codec's dict form of an AgentMessage: the common fields and those of its kind. An
    unknown kind keeps only the common fields (the codec rejects it, naming the kind)."""
    data = {'kind': int(msg.kind), 'message_id': int(msg.message_id), 'sender': msg.sender,
            'receiver': msg.receiver, 'conversation_id': int(msg.conversation_id),
            'in_reply_to': int(msg.in_reply_to)}
    try:
        fields = KIND_FIELDS[MessageKind(msg.kind)]
    except ValueError:
        return data
    readers = {
        'label': lambda: _information_dict(msg.label),
        'chain': lambda: [{'requester': link.requester, 'label': _information_dict(link.label)} for link in msg.chain],
        'instance': lambda: _information_dict(msg.instance),
        'cost': lambda: float(msg.cost),
        'members': lambda: list(msg.members),
        'coalition_id': lambda: msg.coalition_id,
        'hold_seconds': lambda: float(msg.hold_seconds),
        'reason': lambda: msg.reason,
        'values': lambda: _values_from_text(msg.reason),
    }
    for name in fields:
        data[name] = readers[name]()
    return data


def _values_from_text(text: str) -> object:
    """An INFORMATION message's values from its ``reason`` field (see the module docstring);
    the codec checks what they contain."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise CoalitionError(f'message.values: not a JSON object of numbers in the reason field ({exc})') from None


def _information(data: dict) -> Information:
    return Information(type=data['type'], referents=list(data['referents']))


def _information_dict(info: Information) -> dict:
    return {'type': info.type, 'referents': list(info.referents)}


class AgentChannel:
    """One robot's end of the shared agent channel (see the module docstring).

    ``on_message(message, received)`` gets every new message for this robot (REQUEST, OFFER,
    COMMIT_REQUEST with ``received.accepted`` already decided and answered, COMMIT_ACCEPT /
    COMMIT_REJECT, RELEASE); ``on_undelivered(undelivered)`` every copy given up after the
    retries. ``tick_s`` is the period of the retry timer.
    """

    def __init__(self, node: Node, robot: str, codec: ChannelCodec, link_model: LinkModel, *,
                 team: Sequence[str], on_message: Callable[[ChannelMessage, Received], None],
                 on_undelivered: Callable[[Undelivered], None] | None = None,
                 policy: RetryPolicy | None = None, topic: str = DEFAULT_TOPIC, tick_s: float = 0.01):
        if robot not in codec.catalog.robots:
            raise CoalitionError(f"robot: {robot!r} is not in the codec's team ({', '.join(codec.robots)})")
        unknown = [name for name in team if name not in codec.catalog.robots]
        if unknown:
            raise CoalitionError(f"team: unknown robot {unknown[0]!r} (codec team: {', '.join(codec.robots)})")
        self.node = node
        self.robot = robot
        self.codec = codec
        self.link_model = link_model
        self.team = tuple(team)
        self.on_message = on_message
        self.on_undelivered = on_undelivered
        # A restarted agent must not reuse message ids its peers still remember: start from the clock.
        self.core = ReliableChannel(robot, policy, first_message_id=time.time_ns() // 1000)
        self.dropped = 0
        self.rejected = 0
        self._delay_timers: set = set()
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=200, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
        self.publisher = node.create_publisher(AgentMessage, topic, qos)
        self.subscription = node.create_subscription(AgentMessage, topic, self._on_wire, qos)
        self.retry_timer = node.create_timer(tick_s, self._on_tick)

    # --- time ----------------------------------------------------------------------------------
    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def new_id(self) -> int:
        return self.core.new_id()

    # --- sending -----------------------------------------------------------------------------------
    def send(self, message: ChannelMessage, recipients: Iterable[str] | None = None) -> list[ChannelMessage]:
        """Send ``message`` (to its receiver, or to ``recipients`` / the team if it is a broadcast);
        returns the copies handed to the link. Our own messages are checked by the codec first:
        a bug here raises (a CoalitionError naming the field) instead of confusing the peers."""
        self.codec.check_outgoing(message)
        if not message.receiver and recipients is None:
            recipients = [robot for robot in self.team if robot != self.robot]
        copies = self.core.send(message, self.now(), recipients)
        for copy in copies:
            self._transmit(copy)
        return copies

    def broadcast(self, message: ChannelMessage) -> list[ChannelMessage]:
        return self.send(message)

    def propose(self, coalition_id: str, members: Sequence[str], cost: float,
                hold_seconds: float) -> tuple[Negotiation | None, str]:
        """Start request-and-wait negotiation (``ReliableChannel.propose``); follow it with
        ``negotiation.state(channel.now())``."""
        negotiation, messages, reason = self.core.propose(coalition_id, members, cost, self.now(), hold_seconds)
        for message in messages:
            self._transmit(message)
        return negotiation, reason

    def stream(self, receiver: str, coalition_id: str, instance, values) -> None:
        """Send one value of ``instance`` to ``receiver`` (loss-tolerant: no ACK, no retry)."""
        self.send(information_message(self.robot, self.new_id(), receiver, coalition_id, instance, values))

    def release(self, coalition_id: str, reason: str = '') -> None:
        for message in self.core.release(coalition_id, self.now(), reason):
            self._transmit(message)

    def _transmit(self, message: ChannelMessage) -> None:
        """Apply the link model on the sending side: drop, or publish after the sampled delay."""
        delivered, delay = self.link_model.sample()
        if not delivered:
            self.dropped += 1
            self.node.get_logger().debug(f'link model dropped {message}')
            return
        msg = to_ros(message)
        if delay <= 0.0:
            self._publish(msg)
            return
        holder: list = []

        def fire() -> None:
            timer = holder[0]
            timer.cancel()
            self.node.destroy_timer(timer)
            self._delay_timers.discard(timer)
            self._publish(msg)

        timer = self.node.create_timer(delay, fire, clock=self.node.get_clock())
        holder.append(timer)
        self._delay_timers.add(timer)

    def _publish(self, msg: AgentMessage) -> None:
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.publisher.publish(msg)

    # --- receiving ---------------------------------------------------------------------------------
    def _on_wire(self, msg: AgentMessage) -> None:
        if msg.sender == self.robot or (msg.receiver and msg.receiver != self.robot):
            return  # our own copies and other robots' mail: not for us (cheap check before decoding)
        try:
            message = self.codec.decode(from_ros(msg))
        except (CoalitionError, ValueError) as exc:
            self.rejected += 1
            self.node.get_logger().warning(f'{self.robot}: dropped malformed channel message from '
                                           f'{msg.sender!r} (id {msg.message_id}): {exc}')
            return
        received = self.core.receive(message, self.now())
        for reply in received.replies:
            self._transmit(reply)
        if received.deliver is not None:
            self._deliver(received.deliver, received)

    def _deliver(self, message: ChannelMessage, received: Received) -> None:
        try:
            self.on_message(message, received)
        except Exception as exc:  # noqa: BLE001 - the agent's handler must not kill the executor
            self.node.get_logger().error(f'{self.robot}: handling {message} failed: {type(exc).__name__}: {exc}')

    def _on_tick(self) -> None:
        resend, failed = self.core.poll(self.now())
        for message in resend:
            self._transmit(message)
        for undelivered in failed:
            self.node.get_logger().warning(f'{self.robot}: no answer from {undelivered.receiver} to '
                                           f'{undelivered.message} after {undelivered.attempts} sends')
            if self.on_undelivered is not None:
                try:
                    self.on_undelivered(undelivered)
                except Exception as exc:  # noqa: BLE001
                    self.node.get_logger().error(f'{self.robot}: on_undelivered failed: {exc}')

    def stats(self) -> dict:
        return {**self.core.stats.to_dict(), 'dropped': self.dropped, 'malformed': self.rejected}

    def destroy(self) -> None:
        for timer in list(self._delay_timers):
            self.node.destroy_timer(timer)
        self._delay_timers.clear()
        self.node.destroy_timer(self.retry_timer)
        self.node.destroy_subscription(self.subscription)
        self.node.destroy_publisher(self.publisher)


__all__ = ['AgentChannel', 'DEFAULT_TOPIC', 'from_ros', 'to_ros']
