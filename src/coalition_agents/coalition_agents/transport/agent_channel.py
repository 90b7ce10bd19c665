"""The agent-to-agent channel of a coalition agent on ROS 2: batches on the team's batch topic, a
link model on the sending side, retries and commitments from :mod:`..core.transport.reliable_channel`.

Aggregation (:mod:`..core.transport.batching`): an agent does not publish its logical messages one by one.
It buffers them per recipient and sends, at the end of each processing step, ONE
``coalition_interfaces/AgentMessageBatch`` per recipient, its messages stored column-wise
(:mod:`..core.transport.batch_columns`); the process's hub publishes every batch its agents send in
one step as ONE ``coalition_interfaces/AgentMessageBundle`` on the team's bundle topic
``<team>/coalition/bundles`` (``/coalition/bundles`` with the default team namespace ``/``).
QoS: :data:`~.channel_hub.CHANNEL_QOS`, reliable like ``collab_tools.qos.RELIABLE`` so that the only
losses are the modelled ones, but with a queue of :data:`~.channel_hub.QUEUE_DEPTH` instead of 10
-- deliberately: a search burst queues hundreds of messages, and a full KEEP_LAST queue silently
replaces unread ones. ACKs are not
messages of their own: their ids ride in ``acked_ids`` of the next batch to that robot, or in an
ack-only batch after ``ack_delay_s`` (default :data:`ACK_DELAY_S`) if nothing else goes there.
Negotiation messages (COMMIT_REQUEST/ACCEPT/REJECT, RELEASE) are flushed at once and processed
first on receipt. "End of the processing step" is the process's :class:`~.channel_hub.ChannelHub`
guard condition, triggered by the first message queued: rclpy's executor runs it after the
callbacks that were ready together, so one step's messages to one robot leave as one batch.

The process's agents share one :class:`~.channel_hub.ChannelHub` (one publisher, one
subscription of the batch topic and one of the shared topic, one timer, one guard condition;
a standalone agent has its own): the hub hands each channel the batches addressed to its robot
(:meth:`AgentChannel.accept_batch`) and drives its retries (:meth:`AgentChannel.on_tick`).

Each batch goes through the sender's :class:`~..core.transport.link_model.LinkModel`: ONE loss draw and ONE
delay sample per batch (a lost batch loses every message and ack in it; the retries re-send the
unacknowledged ones, each retry only the logical messages still unanswered). So an experiment's
loss probability is per batch. Delayed batches wait in one queue per agent, drained on the
hub's timer, at each flush and whenever a batch arrives: a batch leaves at its sampled delay or
up to ``tick_s`` later.

Received batches are validated (:func:`~..core.transport.batch_columns.decode_columns`: a batch from an
unknown robot, or whose columns disagree, is logged and dropped whole; a malformed message inside
a batch is logged and dropped alone, the others are processed), run through the
:class:`~..core.transport.reliable_channel.ReliableChannel` (duplicates answered again but delivered once,
ACKs, commitment answers) and handed to ``on_message``: negotiation messages at once, requests,
offers and streamed values in slices of at most ``work_slice_s`` of the agent's processing
(steps of a :class:`~..core.cooperative_work.CooperativeWork` queue: the channel's own, or the one
a schema_agent_host shares between its agents), so the inbox is drained -- and every message acknowledged -- without
waiting for the agent's reasoning, and a COMMIT_REQUEST is never queued behind it. The channel
never raises from a ROS callback.

The shared topic ``<team>/coalition/channel`` still carries single ``AgentMessage`` s for tools and
tests (a message addressed to another robot is not handed to this one; one without receiver is
for everyone); the agents themselves only publish batches.

Streamed information (kind INFORMATION = 8, :meth:`AgentChannel.stream`) goes into the same
batches but is never acknowledged or retried (the latest value wins); its values travel in the
batch's ``value_names`` / ``values`` columns, checked by the codec like every other field.

Usage (in the schema_agent node)::

    channel = AgentChannel(node, 'robot_1', codec, LinkModel.preset('paper_fig9', loss_probability=0.2),
                           team=team, on_message=handle)
    channel.broadcast(request_message(request, channel.new_id()))
    negotiation, reason = channel.propose('robot_1/3', members, cost, hold_seconds=5.0)
"""
from __future__ import annotations

import heapq
import itertools
import re
import time
from typing import Callable, Iterable, Sequence

from rclpy.node import Node

from coalition_interfaces.msg import AgentMessage, AgentMessageBatch
from collab_tools.input_guard import InputGuard, MalformedInput

from ..core.transport.batch_columns import decode_columns
from ..core.transport.batching import Batch, InboxQueue, Outbox, local_messages
from ..core.cooperative_work import CooperativeWork
from ..core.transport.codec import ChannelCodec, ChannelMessage, MessageKind, information_message
from ..core.errors import CoalitionError
from ..core.transport.link_model import LinkModel
from ..core.transport.liveness import RESTARTED, STALE, PeerLiveness, new_session
from ..core.transport.commitments import Negotiation
from ..core.transport.reliable_channel import Received, ReliableChannel, Undelivered
from ..core.transport.retry import RetryPolicy
from .batch_wire import batch_from_ros, batch_to_ros, from_ros, to_ros
from .channel_hub import BATCH_TOPIC, BUNDLE_TOPIC, CHANNEL_QOS, CHANNEL_TOPIC, QUEUE_DEPTH, ChannelHub, bundle_topic_of

#: the channel of the default team namespace ``/``
DEFAULT_TOPIC = '/' + CHANNEL_TOPIC
#: the batch topic of the default team namespace ``/``
DEFAULT_BATCH_TOPIC = '/' + BATCH_TOPIC
#: the bundle topic of the default team namespace ``/`` (what the agents publish)
DEFAULT_BUNDLE_TOPIC = '/' + BUNDLE_TOPIC
#: s an ACK waits for a batch to the same robot to ride on before it goes in an ack-only batch:
#: a third of the Fig. 9 column's batches carried only ACKs at 10 ms; far below the retry
#: timeouts (reorder window 50 ms after a later answer, tail timeout >= 0.2 s)
ACK_DELAY_S = 0.03


def bundle_topic(channel_topic: str = DEFAULT_TOPIC) -> str:
    """The bundle topic beside a single-message channel topic (``/coalition/channel`` -> ``/coalition/bundles``)."""
    return bundle_topic_of(batch_topic(channel_topic))


def malformed(text: str) -> MalformedInput:
    """A rejection whose kind is the field it names, without indices ('batch.messages.cost'): one kind
    however many messages of a batch, or batches of a flood, have it."""
    field = text.split(': ', 1)[0] if ': ' in text else 'batch'
    return MalformedInput(text, kind='malformed ' + re.sub(r'\[\d+\]', '', field)[:80])


def batch_topic(channel_topic: str = DEFAULT_TOPIC) -> str:
    """The batch topic beside a single-message channel topic (``/coalition/channel`` -> ``/coalition/batches``)."""
    return channel_topic[:-len('channel')] + 'batches' if channel_topic.endswith('/channel') else channel_topic + '_batches'


class AgentChannel:
    """One robot's end of the agent channel (see the module docstring).

    ``on_message(message, received)`` gets every new message for this robot (REQUEST, OFFER,
    COMMIT_REQUEST with ``received.accepted`` already decided and answered, COMMIT_ACCEPT /
    COMMIT_REJECT, RELEASE, INFORMATION); ``on_undelivered(undelivered)`` every copy given up
    after the retries. ``tick_s`` is the period of the retry timer while something is pending;
    ``ack_delay_s`` (default :data:`ACK_DELAY_S`, at least ``tick_s``) how long an ACK waits for a
    batch to ride on before it goes alone. ``liveness`` (:class:`~..core.transport.liveness.PeerLiveness`;
    None: sessions only, nobody presumed dead) follows the teammates ``watched()`` names;
    ``on_teammate(event, robot, detail)`` hears 'restarted' (before that batch's messages are
    handled), 'lost' and 'back'. ``hub``: the process's shared endpoints (a schema_agent_host's); None: the
    channel creates its own (``topic``, ``tick_s``, ``drain_slice_s`` apply to it).
    """

    def __init__(self, node: Node, robot: str, codec: ChannelCodec, link_model: LinkModel, *,
                 team: Sequence[str], on_message: Callable[[ChannelMessage, Received], None],
                 on_undelivered: Callable[[Undelivered], None] | None = None,
                 policy: RetryPolicy | None = None, topic: str = DEFAULT_TOPIC, tick_s: float = 0.01,
                 ack_delay_s: float | None = None, work_slice_s: float = 0.005, drain_slice_s: float = 0.01,
                 work: CooperativeWork | None = None, hub: ChannelHub | None = None,
                 liveness: PeerLiveness | None = None, watched: Callable[[], Iterable[str]] = tuple,
                 on_teammate: Callable[[str, str, str], None] | None = None):
        if robot not in codec.catalog.robots:
            raise CoalitionError(f"robot: {robot!r} is not in the codec's team ({', '.join(codec.robots)})")
        unknown = [name for name in team if name not in codec.catalog.robots]
        if unknown:
            raise CoalitionError(f"team: unknown robot {unknown[0]!r} (codec team: {', '.join(codec.robots)})")
        self.node = node
        self._clock = node.get_clock()
        self.robot = robot
        self.codec = codec
        self.link_model = link_model
        self.team = tuple(team)
        self.on_message = on_message
        self.on_undelivered = on_undelivered
        # A restarted agent must not reuse message ids its peers still remember: start from the clock.
        self.core = ReliableChannel(robot, policy, first_message_id=time.time_ns() // 1000)
        #: this agent's session: its batches carry it, so teammates tell a restarted agent apart
        self.session = new_session()
        self.liveness = liveness or PeerLiveness(robot, 0.0, 1.0)
        self.watched, self.on_teammate = watched, on_teammate
        self._next_check = 0.0
        self.inputs = InputGuard.of(node)
        self.outbox = Outbox(robot, max(tick_s, ACK_DELAY_S) if ack_delay_s is None else ack_delay_s,
                             session=self.session)
        self.dropped = 0          # logical messages in batches the link model dropped
        self.batches_dropped = 0
        self.batches_published = 0
        self.rejected = 0         # malformed messages (alone or inside a batch)
        self.rejected_batches = 0
        self._delayed: list[tuple[float, int, Batch]] = []  # (due, order, batch): a heap
        self._order = itertools.count()
        self._flush_scheduled = False
        #: received messages (already acknowledged) waiting for the agent, negotiation messages first
        self._deferred: InboxQueue[Received] = InboxQueue()
        self.work_slice_s = work_slice_s
        self.own_hub = hub is None
        if hub is None:  # a standalone agent: endpoints of its own
            hub = ChannelHub(node, topic, batch_topic(topic), tick_s=tick_s, drain_slice_s=drain_slice_s)
        self.hub = hub
        hub.attach(self)
        self.work_trigger = None
        if work is None:  # a channel of its own; a host shares one between its agents
            self.work_trigger = node.create_guard_condition(lambda: self.work.run())
            work = CooperativeWork(self.work_trigger.trigger, work_slice_s, self._step_failed)
        self.work = work

    # --- time ----------------------------------------------------------------------------------
    def now(self) -> float:
        """The node's clock (sim time with ``use_sim_time``), s: read through the clock's handle,
        without building a Time object (called for every message)."""
        return self._clock.handle.get_now().nanoseconds * 1e-9

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

    def announce(self) -> None:
        """An empty batch (its session) to every teammate: one that knew an earlier session of this
        robot learns at once that it restarted."""
        for teammate in self.team:
            if teammate != self.robot:
                self._transmit(self.outbox.heartbeat(teammate))

    def drop_commitment(self, coalition_id: str, leader: str) -> None:
        """Forget a commitment whose leader is presumed dead (no RELEASE will come)."""
        self.core.ledger.release(coalition_id, leader, self.now())

    def _queue(self, messages: list[ChannelMessage]) -> None:
        """Put messages into the outbox: negotiation messages leave at once (with whatever else
        waits for that robot), the rest at the end of the processing step; an ACK alone waits for
        a batch to ride on (or goes alone after ack_delay_s: the hub's timer)."""
        if not messages:
            return
        now = self.now()
        urgent, buffered = [], False
        for message in messages:
            if self.outbox.put(message, now):
                urgent.append(message.receiver)
            elif message.kind is not MessageKind.ACK:
                buffered = True
        if urgent:
            self._transmit_all(self.outbox.flush(now, list(dict.fromkeys(urgent))))
        if buffered and not self._flush_scheduled:
            self._flush_scheduled = True
            self.hub.request_flush(self)
        else:
            self.hub.wake()

    def flush(self) -> None:
        """The end of a processing step (the hub's guard condition): one batch per recipient."""
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
        now = self.now()
        self.core.transmitted(batch.recipient, [message.message_id for message in batch.messages], now)
        self.liveness.sent(batch.recipient, now)
        delivered, delay = self.link_model.sample()
        if not delivered:
            self.batches_dropped += 1
            self.dropped += batch.logical_count
            self.node.get_logger().debug(f'link model dropped batch {batch.sequence} {self.robot}->{batch.recipient} '
                                         f'({len(batch.messages)} messages, {len(batch.acked_ids)} acks)')
            return
        if delay <= 0.0:
            self._publish(batch)
            return
        heapq.heappush(self._delayed, (now + delay, next(self._order), batch))
        self.hub.wake()

    def _release_due(self) -> None:
        """Publish the delayed batches whose time has come (see the module docstring)."""
        if not self._delayed:
            return
        now = self.now()
        while self._delayed and self._delayed[0][0] <= now:
            _, _, batch = heapq.heappop(self._delayed)
            self._publish(batch)

    def _publish(self, batch: Batch) -> None:
        """Stamp the batch now (when it leaves the link model) and hand it to the hub, which
        publishes it in the step's bundle (encoded there, into the bundle's bytes)."""
        self.hub.publish(batch, self._clock.handle.get_now().nanoseconds)
        self.batches_published += 1

    def teammates_listening(self, presence_topic: Callable[[str], str]) -> int:
        """How many teammates' agents are up: those whose agent publishes ``presence_topic(teammate)``
        (its latched status). An agent process creates its batch subscription before any of its
        agents' status publishers (a host its hub, then the agents; a standalone agent its channel,
        then its status), and a participant announces its endpoints in that order, so a teammate
        whose status is visible already listens on the batch topic. (A bag recorder subscribes to
        the batch topic too, so a subscription alone proves nothing.) Each subscription the graph lists
        on the bundle topic that this process's publisher has not matched yet counts one teammate less (it
        may be theirs): a search started then lost its first requests (no coalition in 3 s, in CI)."""
        visible = sum(bool(self.node.get_publishers_info_by_topic(presence_topic(teammate)))
                      for teammate in self.team if teammate != self.robot)
        return max(0, visible - self.hub.unmatched_subscriptions())

    # --- receiving (called by the hub) ---------------------------------------------------------------
    def accept_batch(self, msg: AgentMessageBatch) -> None:
        """A typed batch addressed to this robot (:meth:`accept_fields`)."""
        self.accept_fields(batch_from_ros(msg))

    def accept_fields(self, data: dict) -> None:
        """A batch addressed to this robot, as its fields (:func:`~.batch_wire.batch_from_ros`,
        :func:`~.batch_cdr.decode_cdr`): decoded, acknowledged and queued for the agent (the hub
        hands the negotiation messages over with :meth:`deliver_urgent` once it drained the
        subscription). Due delayed batches leave first."""
        self._release_due()
        sender, sequence = data['sender'], data['sequence']
        try:
            decoded = decode_columns(self.codec, data, self.robot)
        except (CoalitionError, ValueError, TypeError) as exc:
            self.rejected_batches += 1
            self.inputs.reject(self.hub.batch_topic, malformed(f'{exc} (batch {sequence} from {str(sender)[:40]!r} '
                                                              f'to {self.robot})'))
            return
        for index, why in decoded.rejected:
            self.rejected += 1
            self.inputs.reject(self.hub.batch_topic, malformed(
                f'{why} (from {sender!r} to {self.robot}, batch {sequence}, id {data["message_ids"][index]})'))
        now = self.now()
        if not self._heard(sender, decoded.session, now):
            return
        for message in decoded.messages:
            self._receive(message, now, deliver_urgent=False)

    def accept_local(self, batch: Batch) -> None:
        """A batch from a teammate in this process (the hub hands it over in-process: no wire, no
        codec; see :func:`~..core.transport.batching.local_messages`)."""
        self._release_due()
        now = self.now()
        if not self._heard(batch.sender, batch.session, now):
            return
        for message in local_messages(batch):
            self._receive(message, now, deliver_urgent=False)

    def accept_single(self, msg: AgentMessage) -> None:
        """A single message on the shared topic (tools, tests) for this robot."""
        try:
            message = self.codec.decode(from_ros(msg))
        except (CoalitionError, ValueError) as exc:
            self.rejected += 1
            self.inputs.reject(self.hub.channel_topic, malformed(
                f'{exc} (from {msg.sender[:40]!r} to {self.robot}, id {msg.message_id})'))
            return
        self._receive(message, self.now())

    def _heard(self, sender: str, session: int, now: float) -> bool:
        """A batch of ``sender``'s ``session`` arrived: False for a session it has left (dropped). A
        restarted teammate is reported before its batch is handled (its earlier self's commitments go first)."""
        heard = self.liveness.heard(sender, session, now)
        if heard == STALE:
            self.inputs.reject(self.hub.batch_topic, MalformedInput(
                f'batch.session: {session} is not the current session of {sender} '
                f'({self.liveness.sessions[sender]}) (to {self.robot})', kind='out-of-session batch'))
            return False
        if heard == RESTARTED:
            self.node.get_logger().warning(f'{self.robot}: {sender} restarted (session {session})')
            self._teammate('restarted', sender, 'restarted')
        return True

    def _teammate(self, event: str, robot: str, detail: str) -> None:
        if self.on_teammate is not None:
            try:
                self.on_teammate(event, robot, detail)
            except Exception as exc:  # noqa: BLE001 - the agent's handler must not kill the executor
                self.node.get_logger().error(f'{self.robot}: handling {robot} {event} failed: '
                                             f'{type(exc).__name__}: {exc}')

    def _follow_teammates(self, now: float) -> None:
        """Heartbeats to the watched teammates, and those presumed dead or back (a few times per
        heartbeat period, not at every tick)."""
        if now < self._next_check:
            return
        self._next_check = now + min(0.1, self.liveness.heartbeat_s / 4)
        check = self.liveness.check(now, self.watched())
        for robot in check.heartbeats:
            self._transmit(self.outbox.heartbeat(robot))
        for robot, silent in check.lost:
            self.node.get_logger().warning(f'{self.robot}: {robot} presumed dead (silent for {silent:.1f} s)')
            self._teammate('lost', robot, f'silent for {silent:.1f} s')
        for robot in check.back:
            self.node.get_logger().info(f'{self.robot}: {robot} heard again')
            self._teammate('back', robot, 'heard again')

    def _receive(self, message: ChannelMessage, now: float, deliver_urgent: bool = True) -> None:
        """Acknowledge / answer at once and queue the message for the agent
        (:class:`~..core.transport.batching.InboxQueue`): negotiation messages are handed over at the end of
        the callback (``deliver_urgent``; a batch's all at once), the others in time slices
        (:meth:`_deliver_deferred`), so that the inbox never waits behind the agent's reasoning: a
        COMMIT_REQUEST is answered while the helper is still busy with requests and offers, and
        ACKs leave at once, in the order the batches arrived (what the sender's fast retransmit
        relies on)."""
        received = self.core.receive(message, now)
        self._queue(received.replies)
        if received.deliver is None:
            return
        self._deferred.put(received.deliver, received)
        if deliver_urgent:
            self.deliver_urgent()
        if self._deferred:
            self.work.request(self._deliver_deferred, first=True)

    def deliver_urgent(self) -> None:
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

    def busy(self) -> bool:
        """Whether the hub's timer has work for this channel soon: copies awaiting an answer,
        delayed batches, ACKs waiting for a batch."""
        return bool(self._delayed) or self.core.has_pending() or \
            self.outbox.next_ack_due() < float('inf') or self._flush_scheduled

    def on_tick(self) -> bool:
        """The hub's timer: due delayed batches, retries, ack-only batches, copies given up.
        Returns :meth:`busy`."""
        self._release_due()
        now = self.now()
        failed = []
        if now < self.core.poll_due():  # nothing can be due yet: no walk over the peers
            self.core.listen(now)
        else:
            resend, failed = self.core.poll(now)
            if resend:
                self._queue(resend)
        if now >= self.outbox.next_ack_due():
            self._transmit_all(self.outbox.flush(now))  # ack-only batches (and anything else waiting)
        self._follow_teammates(now)
        for undelivered in failed:
            self.node.get_logger().warning(f'{self.robot}: no answer from {undelivered.receiver} to '
                                           f'{undelivered.message} after {undelivered.attempts} sends')
            if self.on_undelivered is not None:
                try:
                    self.on_undelivered(undelivered)
                except Exception as exc:  # noqa: BLE001
                    self.node.get_logger().error(f'{self.robot}: on_undelivered failed: {exc}')
        return self.busy()

    def stats(self) -> dict:
        return {**self.core.stats.to_dict(), 'dropped': self.dropped, 'malformed': self.rejected,
                'malformed_batches': self.rejected_batches, 'batches_dropped': self.batches_dropped,
                'batches_published': self.batches_published, 'session': self.session,
                **{f'liveness_{key}': value for key, value in self.liveness.stats.__dict__.items()},
                **{f'outbox_{key}': value for key, value in self.outbox.stats.to_dict().items()}}

    def destroy(self) -> None:
        self._delayed.clear()
        self._deferred.clear()
        self.hub.detach(self)
        if self.work_trigger is not None:
            self.node.destroy_guard_condition(self.work_trigger)
        if self.own_hub:
            self.hub.destroy()


__all__ = ['ACK_DELAY_S', 'AgentChannel', 'BATCH_TOPIC', 'BUNDLE_TOPIC', 'CHANNEL_QOS', 'CHANNEL_TOPIC', 'DEFAULT_BATCH_TOPIC',
           'DEFAULT_BUNDLE_TOPIC', 'DEFAULT_TOPIC',
           'QUEUE_DEPTH', 'batch_from_ros', 'batch_to_ros', 'batch_topic', 'bundle_topic', 'from_ros', 'to_ros']
