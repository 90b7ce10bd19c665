"""The agent-to-agent channel of a coalition agent on ROS 2: one inbox topic per robot carrying
batches, a link model on the sending side, retries and commitments from :mod:`..core.transport.reliable_channel`.

Aggregation (:mod:`..core.transport.batching`): an agent does not publish its logical messages one by one.
It buffers them per recipient and publishes, at the end of each processing step, ONE
``coalition_interfaces/AgentMessageBatch`` per recipient on that robot's inbox
``<team>/coalition/channel/<robot>`` (:func:`inbox_topic`; ``/coalition/channel/<robot>`` with the
default team namespace ``/``). QoS: :data:`CHANNEL_QOS`, reliable like ``collab_tools.qos.RELIABLE``
so that the only losses are the modelled ones, but with a queue of :data:`QUEUE_DEPTH` instead of
10 -- deliberately: a search burst queues hundreds of batches, and a full KEEP_LAST queue
silently replaces unread ones. ACKs are not messages of their own: their ids ride in ``acked_ids`` of the next
batch to that robot, or in an ack-only batch after ``ack_delay_s`` (default: the tick period)
if nothing else goes there. Negotiation messages (COMMIT_REQUEST/ACCEPT/REJECT, RELEASE) are
flushed at once and processed first on receipt. "End of the processing step" is a guard condition
triggered by the first message queued: rclpy's executor runs it after the callbacks that were
ready together (e.g. a burst of batches and the agent's re-evaluation), so one step's messages to
one robot leave as one batch. Why: one ROS message per logical message (plus one per ACK) was
~12,000-31,000 ROS messages for the Fig. 9 column of 10; their per-message cost in rclpy, not the
algorithm, starved the agents.

Each batch goes through the sender's :class:`~..core.transport.link_model.LinkModel`: ONE loss draw and ONE
delay sample per batch (a lost batch loses every message and ack in it; the retries re-send the
unacknowledged ones, each retry only the logical messages still unanswered). So an experiment's
loss probability is per batch. Delayed batches wait in one queue per agent, drained on the
channel's ``tick_s`` timer, at each flush and whenever a batch arrives: a batch leaves at its
sampled delay or up to ``tick_s`` later.

Received batches are validated (:func:`~..core.transport.batching.decode_batch`: a batch from an unknown
robot or for another robot is logged and dropped whole; a malformed message inside a batch is
logged and dropped alone, the others are processed), run through the
:class:`~..core.transport.reliable_channel.ReliableChannel` (duplicates answered again but delivered once,
ACKs, commitment answers) and handed to ``on_message``: negotiation messages at once, requests,
offers and streamed values in slices of at most ``work_slice_s`` of the agent's processing
(steps of a :class:`~..core.cooperative_work.CooperativeWork` queue: the channel's own, or the one
a schema_agent_host shares between its agents), so the inbox is drained -- and every message acknowledged -- without
waiting for the agent's reasoning, and a COMMIT_REQUEST is never queued behind it. The channel
never raises from a ROS callback.

The shared topic ``/coalition/channel`` still carries single ``AgentMessage`` s for tools and
tests (a message addressed to another robot is dropped unread; one without receiver is for
everyone); the agents themselves only publish batches.

Streamed information (kind INFORMATION = 8, :meth:`AgentChannel.stream`) goes into the same
batches but is never acknowledged or retried (the latest value wins). Its values travel in
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
from collab_tools import qos as standard_qos
from rclpy.node import Node
from rclpy.qos import QoSProfile

from coalition_interfaces.msg import AgentMessage, AgentMessageBatch, ChainLink, Information, NamedValue

from ..core.transport.batching import Batch, InboxQueue, Outbox, decode_batch
from ..core.cooperative_work import CooperativeWork
from ..core.transport.codec import KIND_FIELDS, ChannelCodec, ChannelMessage, MessageKind, information_message
from ..core.errors import CoalitionError
from ..core.transport.link_model import LinkModel
from ..core.transport.commitments import Negotiation
from ..core.transport.reliable_channel import Received, ReliableChannel, Undelivered
from ..core.transport.retry import RetryPolicy

#: the channel under the team namespace (``names.team(CHANNEL_TOPIC)``)
CHANNEL_TOPIC = 'coalition/channel'
#: the channel of the default team namespace ``/``
DEFAULT_TOPIC = '/' + CHANNEL_TOPIC
#: publisher and subscription queue depth of the channel
QUEUE_DEPTH = 5000
#: RELIABLE (reliable, volatile) with a queue deep enough for the burst of a whole search
CHANNEL_QOS = QoSProfile(history=standard_qos.RELIABLE.history, depth=QUEUE_DEPTH,
                         reliability=standard_qos.RELIABLE.reliability, durability=standard_qos.RELIABLE.durability)


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


def batch_to_ros(batch: Batch) -> AgentMessageBatch:
    """The AgentMessageBatch of a core batch."""
    return AgentMessageBatch(sender=batch.sender, recipient=batch.recipient, sequence=batch.sequence,
                             messages=[to_ros(message) for message in batch.messages],
                             acked_ids=list(batch.acked_ids))


def batch_from_ros(msg: AgentMessageBatch) -> dict:
    """The dict form :func:`~..core.transport.batching.decode_batch` reads; ``messages`` stay AgentMessages
    (converted one by one with :func:`from_ros`, so one malformed message fails alone)."""
    return {'sender': msg.sender, 'recipient': msg.recipient, 'sequence': int(msg.sequence),
            'messages': list(msg.messages), 'acked_ids': [int(acked) for acked in msg.acked_ids]}


def _information(data: dict) -> Information:
    return Information(type=data['type'], referents=list(data['referents']))


def _information_dict(info: Information) -> dict:
    return {'type': info.type, 'referents': list(info.referents)}


class AgentChannel:
    """One robot's end of the agent channel (see the module docstring).

    ``on_message(message, received)`` gets every new message for this robot (REQUEST, OFFER,
    COMMIT_REQUEST with ``received.accepted`` already decided and answered, COMMIT_ACCEPT /
    COMMIT_REJECT, RELEASE, INFORMATION); ``on_undelivered(undelivered)`` every copy given up
    after the retries. ``tick_s`` is the period of the retry timer; ``ack_delay_s`` (default
    ``tick_s``) how long an ACK waits for a batch to ride on before it goes alone.
    """

    def __init__(self, node: Node, robot: str, codec: ChannelCodec, link_model: LinkModel, *,
                 team: Sequence[str], on_message: Callable[[ChannelMessage, Received], None],
                 on_undelivered: Callable[[Undelivered], None] | None = None,
                 policy: RetryPolicy | None = None, topic: str = DEFAULT_TOPIC, tick_s: float = 0.01,
                 ack_delay_s: float | None = None, work_slice_s: float = 0.005, drain_slice_s: float = 0.01,
                 work: CooperativeWork | None = None):
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
        self.outbox = Outbox(robot, tick_s if ack_delay_s is None else ack_delay_s)
        self.dropped = 0          # logical messages in batches the link model dropped
        self.batches_dropped = 0
        self.batches_published = 0
        self.rejected = 0         # malformed messages (alone or inside a batch)
        self.rejected_batches = 0
        self._delayed: list[tuple[float, int, AgentMessageBatch]] = []  # (due, order, batch): a heap
        self._order = itertools.count()
        self._flush_scheduled = False
        #: received messages (already acknowledged) waiting for the agent, negotiation messages first
        self._deferred: InboxQueue[Received] = InboxQueue()
        self.work_slice_s = work_slice_s
        self.drain_slice_s = drain_slice_s
        qos = CHANNEL_QOS
        publisher = lambda kind, name: node.create_publisher(  # noqa: E731
            kind, name, qos, event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))
        subscribe = lambda kind, name, callback: node.create_subscription(  # noqa: E731
            kind, name, callback, qos, event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        self.subscription = subscribe(AgentMessage, topic, self._on_wire)
        # Created up front: a publisher created at the first send would publish before it matched
        # the receiver's subscription (volatile: that batch would be lost).
        self.inboxes = {teammate: publisher(AgentMessageBatch, inbox_topic(teammate, topic))
                        for teammate in self.team if teammate != robot}
        self.inbox = subscribe(AgentMessageBatch, inbox_topic(robot, topic), self._on_batch)
        self.retry_timer = node.create_timer(tick_s, self._on_tick)
        self.flush_trigger = node.create_guard_condition(self._on_flush)
        self.work_trigger = None
        if work is None:  # a channel of its own; a host shares one between its agents
            self.work_trigger = node.create_guard_condition(lambda: self.work.run())
            work = CooperativeWork(self.work_trigger.trigger, work_slice_s, self._step_failed)
        self.work = work

    # --- time ----------------------------------------------------------------------------------
    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def new_id(self) -> int:
        return self.core.new_id()

    # --- sending -----------------------------------------------------------------------------------
    def send(self, message: ChannelMessage, recipients: Iterable[str] | None = None) -> list[ChannelMessage]:
        """Send ``message`` (to its receiver, or to ``recipients`` / the team if it is a broadcast);
        returns the copies queued for the link. Our own messages are checked by the codec first:
        a bug here raises (a CoalitionError naming the field) instead of confusing the peers."""
        self.codec.check_outgoing(message)
        if not message.receiver and recipients is None:
            recipients = [robot for robot in self.team if robot != self.robot]
        copies = self.core.send(message, self.now(), recipients)
        self._queue(copies)
        return copies

    def broadcast(self, message: ChannelMessage) -> list[ChannelMessage]:
        return self.send(message)

    def propose(self, coalition_id: str, members: Sequence[str], cost: float,
                hold_seconds: float) -> tuple[Negotiation | None, str]:
        """Start request-and-wait negotiation (``ReliableChannel.propose``); follow it with
        ``negotiation.state(channel.now())``."""
        negotiation, messages, reason = self.core.propose(coalition_id, members, cost, self.now(), hold_seconds)
        self._queue(messages)
        return negotiation, reason

    def stream(self, receiver: str, coalition_id: str, instance, values) -> None:
        """Send one value of ``instance`` to ``receiver`` (loss-tolerant: no ACK, no retry)."""
        self.send(information_message(self.robot, self.new_id(), receiver, coalition_id, instance, values))

    def release(self, coalition_id: str, reason: str = '') -> None:
        self._queue(self.core.release(coalition_id, self.now(), reason))

    def admit_with(self, rule) -> None:
        """The commitment ledger's admission rule (which coalitions this robot may hold together;
        :class:`~..core.transport.commitments.CommitmentLedger`)."""
        self.core.ledger.admission = rule

    def _queue(self, messages: Iterable[ChannelMessage]) -> None:
        """Put messages into the outbox: negotiation messages leave at once (with whatever else
        waits for that robot), the rest at the end of the processing step."""
        now = self.now()
        urgent = [message.receiver for message in messages if self.outbox.put(message, now)]
        if urgent:
            self._transmit_all(self.outbox.flush(now, list(dict.fromkeys(urgent))))
        if not self._flush_scheduled and self.outbox.has_messages():
            self._flush_scheduled = True
            self.flush_trigger.trigger()

    def _on_flush(self) -> None:
        self._flush_scheduled = False
        self._release_due()
        self._transmit_all(self.outbox.flush(self.now()))

    def _transmit_all(self, batches: Iterable[Batch]) -> None:
        for batch in batches:
            self._transmit(batch)

    def _transmit(self, batch: Batch) -> None:
        """Apply the link model on the sending side, per batch: drop it, or publish it after the
        sampled delay."""
        # The copies leave now (a lost batch too: the link loses it, not the sender).
        self.core.transmitted(batch.recipient, [message.message_id for message in batch.messages], self.now())
        delivered, delay = self.link_model.sample()
        if not delivered:
            self.batches_dropped += 1
            self.dropped += batch.logical_count
            self.node.get_logger().debug(f'link model dropped batch {batch.sequence} {self.robot}->{batch.recipient} '
                                         f'({len(batch.messages)} messages, {len(batch.acked_ids)} acks)')
            return
        msg = batch_to_ros(batch)
        if delay <= 0.0:
            self._publish(msg)
            return
        heapq.heappush(self._delayed, (self.now() + delay, next(self._order), msg))

    def _release_due(self) -> None:
        """Publish the delayed batches whose time has come (see the module docstring)."""
        if not self._delayed:
            return
        now = self.now()
        while self._delayed and self._delayed[0][0] <= now:
            self._publish(heapq.heappop(self._delayed)[2])

    def _publish(self, msg: AgentMessageBatch) -> None:
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.inboxes[msg.recipient].publish(msg)
        self.batches_published += 1

    def teammates_listening(self, presence_topic: Callable[[str], str]) -> int:
        """How many teammates' agents subscribe to their inbox (their agent is up): only a
        subscription by the node publishing ``presence_topic(teammate)`` (a topic its agent
        publishes) counts -- a bag recorder subscribes to every inbox too, before the agents of
        another process are up."""
        count = 0
        for teammate, publisher in self.inboxes.items():
            if publisher.get_subscription_count() == 0:
                continue
            agents = {(info.node_namespace, info.node_name)
                      for info in self.node.get_publishers_info_by_topic(presence_topic(teammate))}
            readers = {(info.node_namespace, info.node_name)
                       for info in self.node.get_subscriptions_info_by_topic(publisher.topic_name)}
            count += bool(agents & readers)
        return count

    # --- receiving ---------------------------------------------------------------------------------
    def _on_batch(self, msg: AgentMessageBatch) -> None:
        """Drain the inbox: this batch and those queued behind it in the subscription (for at
        most ``drain_slice_s``), each decoded, acknowledged and queued for the agent; then the
        negotiation messages of all of them go to the agent. Why: the executor hands a
        subscription one message per wait cycle, and a cycle of ten hosted agents lasts tens of
        milliseconds during a search burst -- taken one per cycle, the batches queued up for
        seconds, their ACKs with them, and a COMMIT_REQUEST waited behind the whole backlog."""
        self._release_due()
        end = time.perf_counter() + self.drain_slice_s
        while msg is not None:
            self._accept_batch(msg)
            msg = self._take_queued_batch() if time.perf_counter() < end else None
        self._deliver_urgent()

    def _take_queued_batch(self) -> AgentMessageBatch | None:
        """The next batch waiting in the inbox subscription, or None (as rclpy's executor takes
        it: ``Subscription.handle.take_message``)."""
        try:
            with self.inbox.handle:
                taken = self.inbox.handle.take_message(self.inbox.msg_type, self.inbox.raw)
        except Exception as exc:  # noqa: BLE001 - an rclpy without this API: one batch per callback
            self.node.get_logger().debug(f'{self.robot}: cannot drain the inbox: {exc}')
            return None
        return None if taken is None else taken[0]

    def _accept_batch(self, msg: AgentMessageBatch) -> None:
        try:
            decoded = decode_batch(self.codec, batch_from_ros(msg), self.robot, from_ros)
        except (CoalitionError, ValueError) as exc:
            self.rejected_batches += 1
            self.node.get_logger().warning(f'{self.robot}: dropped malformed channel batch {msg.sequence} from '
                                           f'{msg.sender!r}: {exc}')
            return
        for index, why in decoded.rejected:
            self.rejected += 1
            self.node.get_logger().warning(f'{self.robot}: dropped malformed channel message from {msg.sender!r} '
                                           f'(batch {msg.sequence}, id {msg.messages[index].message_id}): {why}')
        now = self.now()
        for message in decoded.messages:
            self._receive(message, now, deliver_urgent=False)

    def _on_wire(self, msg: AgentMessage) -> None:
        """A single message on the shared topic (tools, tests)."""
        if msg.sender == self.robot or (msg.receiver and msg.receiver != self.robot):
            return  # our own copies and other robots' mail: not for us (cheap check before decoding)
        try:
            message = self.codec.decode(from_ros(msg))
        except (CoalitionError, ValueError) as exc:
            self.rejected += 1
            self.node.get_logger().warning(f'{self.robot}: dropped malformed channel message from '
                                           f'{msg.sender!r} (id {msg.message_id}): {exc}')
            return
        self._receive(message, self.now())

    def _receive(self, message: ChannelMessage, now: float, deliver_urgent: bool = True) -> None:
        """Acknowledge / answer at once and queue the message for the agent
        (:class:`~..core.transport.batching.InboxQueue`): negotiation messages are handed over at the end of
        the callback (``deliver_urgent``; a batch's all at once), the others in time slices
        (:meth:`_on_work`), so that the inbox never waits behind the agent's reasoning: a
        COMMIT_REQUEST is answered while the helper is still busy with requests and offers, and
        ACKs leave at once, in the order the batches arrived (what the sender's fast retransmit
        relies on)."""
        received = self.core.receive(message, now)
        self._queue(received.replies)
        if received.deliver is None:
            return
        self._deferred.put(received.deliver, received)
        if deliver_urgent:
            self._deliver_urgent()
        if self._deferred:
            self.work.request(self._deliver_deferred)

    def _deliver_urgent(self) -> None:
        while (entry := self._deferred.pop_urgent()) is not None:
            self._deliver(*entry)

    def _deliver_deferred(self) -> bool:
        """A step of :attr:`work`: deliver deferred messages for at most ``work_slice_s`` (wall);
        True if some are left (the executor runs the other callbacks -- inboxes, timers --
        before the next step)."""
        end = time.perf_counter() + self.work_slice_s
        while (entry := self._deferred.pop()) is not None:
            self._deliver(*entry)
            if time.perf_counter() >= end:
                break
        return bool(self._deferred)

    def _step_failed(self, step, exc: Exception) -> None:
        self.node.get_logger().error(f'{self.robot}: {getattr(step, "__name__", step)} failed: '
                                     f'{type(exc).__name__}: {exc}')

    def _deliver(self, message: ChannelMessage, received: Received) -> None:
        try:
            self.on_message(message, received)
        except Exception as exc:  # noqa: BLE001 - the agent's handler must not kill the executor
            self.node.get_logger().error(f'{self.robot}: handling {message} failed: {type(exc).__name__}: {exc}')

    def _on_tick(self) -> None:
        self._release_due()
        now = self.now()
        resend, failed = self.core.poll(now)
        self._queue(resend)
        if now >= self.outbox.next_ack_due():
            self._transmit_all(self.outbox.flush(now))  # ack-only batches (and anything else waiting)
        for undelivered in failed:
            self.node.get_logger().warning(f'{self.robot}: no answer from {undelivered.receiver} to '
                                           f'{undelivered.message} after {undelivered.attempts} sends')
            if self.on_undelivered is not None:
                try:
                    self.on_undelivered(undelivered)
                except Exception as exc:  # noqa: BLE001
                    self.node.get_logger().error(f'{self.robot}: on_undelivered failed: {exc}')

    def stats(self) -> dict:
        return {**self.core.stats.to_dict(), 'dropped': self.dropped, 'malformed': self.rejected,
                'malformed_batches': self.rejected_batches, 'batches_dropped': self.batches_dropped,
                'batches_published': self.batches_published,
                **{f'outbox_{key}': value for key, value in self.outbox.stats.to_dict().items()}}

    def destroy(self) -> None:
        self._delayed.clear()
        self.node.destroy_timer(self.retry_timer)
        self.node.destroy_guard_condition(self.flush_trigger)
        if self.work_trigger is not None:
            self.node.destroy_guard_condition(self.work_trigger)
        self._deferred.clear()
        self.node.destroy_subscription(self.subscription)
        self.node.destroy_subscription(self.inbox)
        for publisher in self.inboxes.values():
            self.node.destroy_publisher(publisher)


__all__ = ['AgentChannel', 'CHANNEL_QOS', 'CHANNEL_TOPIC', 'DEFAULT_TOPIC', 'QUEUE_DEPTH', 'batch_from_ros',
           'batch_to_ros', 'from_ros', 'inbox_topic', 'to_ros']
