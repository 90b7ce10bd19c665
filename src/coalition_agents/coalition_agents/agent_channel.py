"""The agent-to-agent channel of a coalition agent on ROS 2: one inbox topic per robot, a link
model on the sending side, retries and commitments from :mod:`.core.reliable_channel`.

Every copy an agent sends is addressed to one robot (a broadcast is one copy per teammate) and
is published on that robot's inbox ``/coalition/channel/<robot>`` (:func:`inbox_topic`;
``coalition_interfaces/AgentMessage``, reliable QoS, so the only losses are the modelled ones).
Why not one shared topic: a search of the Fig. 9 column of 10 robots puts ~12,000 copies on the
channel in a few seconds; on one topic every agent would receive (and rclpy deserialise and
dispatch) every copy -- ten times the traffic, which is what made the agents fall behind. An
agent still listens on the shared ``/coalition/channel`` too (messages addressed to another robot
are dropped unread; a message without receiver is for everyone), which tools and tests may use,
and whose subscriber count tells that the team is up. Each copy goes through the sender's
:class:`~.core.link_model.LinkModel` first: dropped, or published after the sampled delay by a
delay queue on the node's clock (sim time when ``use_sim_time`` is set).

Cost per message matters (rclpy's executor rebuilds its wait set on every wait, so every entity
costs on every callback): the channel has no QoS event handlers on its endpoints, and delayed
copies wait in one queue per agent instead of a one-shot timer each. The queue is drained on the
channel's ``tick_s`` timer and whenever the agent handles a channel message, so a copy leaves at
its sampled delay or up to ``tick_s`` later (the link model's delay plus at most 10 ms by default;
during a search the agent handles messages every few ms, so usually much less). Received messages are converted to the codec's dict
form, validated (:class:`~.core.channel_codec.ChannelCodec`), run through the
:class:`~.core.reliable_channel.ReliableChannel` (duplicates answered again but delivered once,
ACKs, commitment answers) and handed to ``on_message``. A malformed message is logged and
dropped; the channel never raises from a ROS callback.

Streamed information (kind INFORMATION = 8, :meth:`AgentChannel.stream`) goes through the same
link model but is never acknowledged or retried (the latest value wins). Its values travel in
AgentMessage's ``values`` (``NamedValue[]``: ``{name: x, value: 1.2}, ...``), checked by the
codec like every other field.

Usage (in the schema_agent node)::

    channel = AgentChannel(node, 'robot_1', codec, LinkModel.preset('paper_fig9', loss_probability=0.2),
                           team=team, on_message=handle)
    channel.broadcast(request_message(request, channel.new_id()))
    negotiation, reason = channel.propose('robot_1/3', members, cost, hold_seconds=5.0)
"""
from __future__ import annotations

import heapq
import itertools
import time
from typing import Callable, Iterable, Sequence

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from coalition_interfaces.msg import AgentMessage, ChainLink, Information, NamedValue

from .core.channel_codec import KIND_FIELDS, ChannelCodec, ChannelMessage, MessageKind, information_message
from .core.errors import CoalitionError
from .core.link_model import LinkModel
from .core.reliable_channel import Negotiation, Received, ReliableChannel, RetryPolicy, Undelivered

DEFAULT_TOPIC = '/coalition/channel'
#: publisher and subscription queue depth of the channel
QUEUE_DEPTH = 5000


def inbox_topic(robot: str, topic: str = DEFAULT_TOPIC) -> str:
    """The topic on which ``robot``'s agent receives the copies addressed to it."""
    return f'{topic}/{robot}'


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
        msg.values = [NamedValue(name=entry['name'], value=entry['value']) for entry in data['values']]
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
        'values': lambda: [{'name': entry.name, 'value': float(entry.value)} for entry in msg.values],
    }
    for name in fields:
        data[name] = readers[name]()
    return data


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
        self._delayed: list[tuple[float, int, AgentMessage]] = []  # (due, order, message): a heap
        self._order = itertools.count()
        # Deep enough for the burst of a whole search (the Fig. 9 column of 10 sends ~12,000 copies
        # in a few seconds): a full KEEP_LAST queue silently replaces unread messages.
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=QUEUE_DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
        publisher = lambda name: node.create_publisher(  # noqa: E731
            AgentMessage, name, qos, event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))
        subscribe = lambda name: node.create_subscription(  # noqa: E731
            AgentMessage, name, self._on_wire, qos,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        self.publisher = publisher(topic)
        self.subscription = subscribe(topic)
        # Created up front: a publisher created at the first send would publish before it matched
        # the receiver's subscription (volatile: that copy would be lost).
        self.inboxes = {teammate: publisher(inbox_topic(teammate, topic)) for teammate in self.team if teammate != robot}
        self.inbox = subscribe(inbox_topic(robot, topic))
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
        heapq.heappush(self._delayed, (self.now() + delay, next(self._order), msg))

    def _release_due(self) -> None:
        """Publish the delayed copies whose time has come (see the module docstring)."""
        if not self._delayed:
            return
        now = self.now()
        while self._delayed and self._delayed[0][0] <= now:
            self._publish(heapq.heappop(self._delayed)[2])

    def _publish(self, msg: AgentMessage) -> None:
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.inboxes.get(msg.receiver, self.publisher).publish(msg)

    def teammates_listening(self) -> int:
        """How many teammates' agents subscribe to their inbox (their agent is up)."""
        return sum(1 for publisher in self.inboxes.values() if publisher.get_subscription_count() > 0)

    # --- receiving ---------------------------------------------------------------------------------
    def _on_wire(self, msg: AgentMessage) -> None:
        self._release_due()
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
        self._release_due()
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
        self._delayed.clear()
        self.node.destroy_timer(self.retry_timer)
        self.node.destroy_subscription(self.subscription)
        self.node.destroy_subscription(self.inbox)
        self.node.destroy_publisher(self.publisher)
        for publisher in self.inboxes.values():
            self.node.destroy_publisher(publisher)


__all__ = ['AgentChannel', 'DEFAULT_TOPIC', 'QUEUE_DEPTH', 'from_ros', 'inbox_topic', 'to_ros']
