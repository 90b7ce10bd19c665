"""ChannelHub: the ROS endpoints an agent process shares between its agents' channels.

One hub per process (a ``schema_agent_host`` with all its agents, or a standalone ``schema_agent``)
owns, on its node:

* ONE publisher and ONE subscription on the team's bundle topic ``<team>/coalition/bundles``
  (``coalition_interfaces/AgentMessageBundle``): every batch (``AgentMessageBatch``, columns) the
  process's agents send in one processing step leaves in ONE bundle, published at the end of the
  callback that released them (:meth:`ChannelHub.publish` queues, :meth:`_send_bundle` publishes;
  the guard condition below ends a step that has no callback of its own). Why: the hosts of a
  20-robot column published ~9,000 batches each per search, 36 per step, and every one was copied
  to each reader, taken by every host and written by the recorder (the message's comment has the
  figures). The subscription takes bundles serialized (``raw``) and decodes only the batches
  addressed to robots this process hosts (:func:`~.batch_cdr.decode_bundle` skips the others
  unread); they go to their robot's channel. Why one topic and one subscription per process, not
  one inbox topic and subscription per agent: rclpy's executor rebuilds its wait set from every
  entity of every node at each wake-up, and hands a subscription one message per wake-up; twenty
  inboxes per process made the executor's bookkeeping, not the agents, dominate. Any process that
  subscribes to the topic -- another host, a standalone agent on a real robot, ``ros2 topic
  echo``, the bag recorder -- sees every batch.
* ONE subscription on the batch topic ``<team>/coalition/batches``: single batches from tools
  and tests (the agents publish bundles), handled like a bundle's batches; a batch's
  ``recipient`` is read from its first bytes (:func:`~.batch_cdr.peek_addresses`) and batches for
  robots this process does not host are dropped without being deserialised.
* ONE subscription on the shared topic ``<team>/coalition/channel`` (single ``AgentMessage`` s
  from tools and tests), handed to the addressed hosted robot (every hosted robot but the sender
  for a message without receiver).
* ONE timer for every channel's retries, delayed batches and ack-only batches: ``tick_s`` while
  some channel has something pending (an unacknowledged copy, a delayed batch, an ACK waiting),
  ``idle_tick_s`` otherwise -- an idle team wakes up a few times a second, not a hundred times
  per agent -- and back to ``tick_s`` the moment a channel queues something (:meth:`wake`).
* ONE guard condition that ends the processing step: every channel that queued messages since
  is flushed (one batch per recipient) when the executor runs it, after the callbacks that were
  ready together, and the step's bundle leaves. A batch between two agents of this process is in
  the bundle (the recorder and any listener see it) and handed to its recipient's channel
  in-process at the same callback, as the core batch: the subscription skips it when it comes
  back, so it is neither decoded nor queued behind the team's traffic.

The reception loop drains the subscription for at most ``drain_slice_s`` per callback (the
executor hands a subscription one message per wake-up; a search burst queues hundreds), then
hands each touched channel's negotiation messages to its agent.

Batches travel as serialized bytes both ways (:mod:`.batch_cdr`: written and read without the
message object; :attr:`ChannelHub.wire_bytes`), unless the middleware serializes the type
differently (checked once per process, :class:`~.batch_cdr.WireCheck`): then as typed messages.
"""
from __future__ import annotations

import time
from collections import deque
from typing import TYPE_CHECKING

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message, serialize_message

from collab_tools import qos as standard_qos
from collab_tools.input_guard import InputGuard, MalformedInput
from coalition_interfaces.msg import AgentMessage, AgentMessageBatch, AgentMessageBundle

from ..core.transport.batch_columns import encode_batch
from .batch_cdr import WireCheck, decode_bundle, decode_cdr, encode_bundle
from .batch_wire import batch_from_ros, batch_to_ros, peek_addresses

if TYPE_CHECKING:
    from .agent_channel import AgentChannel

#: publisher and subscription queue depth of the channel topics
QUEUE_DEPTH = 5000
#: RELIABLE (reliable, volatile) with a queue deep enough for the burst of a whole search
CHANNEL_QOS = QoSProfile(history=standard_qos.RELIABLE.history, depth=QUEUE_DEPTH,
                         reliability=standard_qos.RELIABLE.reliability, durability=standard_qos.RELIABLE.durability)
#: the single-message channel and the batch topic under the team namespace (``names.team(...)``)
CHANNEL_TOPIC = 'coalition/channel'
BATCH_TOPIC = 'coalition/batches'
BUNDLE_TOPIC = 'coalition/bundles'


def bundle_topic_of(batch_topic: str) -> str:
    """The bundle topic beside a batch topic (``/coalition/batches`` -> ``/coalition/bundles``)."""
    return batch_topic[:-len('batches')] + 'bundles' if batch_topic.endswith('batches') else batch_topic + '_bundles'


def _serialize(columns: dict, stamp_ns: int) -> bytes:
    msg = AgentMessageBatch(**columns)
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    return serialize_message(msg)


def _stamped_fields(msg: AgentMessageBatch) -> dict:
    fields = {key: value if isinstance(value, (str, int)) else list(value)
              for key, value in batch_from_ros(msg).items()}
    return {**fields, 'stamp_ns': _stamp_ns(msg.header)}


def _stamp_ns(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def _fields(data: bytes) -> dict:
    return _stamped_fields(deserialize_message(data, AgentMessageBatch))


def _typed_bundle(batches, stamp_ns: int) -> AgentMessageBundle:
    """``batches``: (AgentMessageBatch or columns, stamp_ns) each."""
    msg = AgentMessageBundle()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    for batch, batch_stamp in batches:
        typed = batch if isinstance(batch, AgentMessageBatch) else AgentMessageBatch(**batch)
        typed.header.stamp.sec, typed.header.stamp.nanosec = divmod(batch_stamp, 1_000_000_000)
        msg.batches.append(typed)
    return msg


def _bundle_fields(data: bytes) -> tuple[int, list[dict]]:
    msg = deserialize_message(data, AgentMessageBundle)
    return _stamp_ns(msg.header), [_stamped_fields(batch) for batch in msg.batches]


#: does this process's middleware agree with batch_cdr (checked at the first hub)
WIRE_CHECK = WireCheck(_serialize, _fields, lambda batches, stamp: serialize_message(_typed_bundle(batches, stamp)),
                       _bundle_fields)


class ChannelHub:
    """The shared endpoints of one process's agent channels (see the module docstring)."""

    def __init__(self, node: Node, channel_topic: str, batch_topic: str, *, tick_s: float = 0.01,
                 idle_tick_s: float = 0.25, drain_slice_s: float = 0.03):
        self.node = node
        self.tick_s = tick_s
        self.idle_tick_s = max(idle_tick_s, tick_s)
        self.drain_slice_s = drain_slice_s
        self.channels: dict[str, AgentChannel] = {}
        self.batches_received = 0      # batches for a hosted robot
        self.batches_skipped = 0       # batches for robots hosted elsewhere (not deserialised)
        self.batch_topic, self.channel_topic = batch_topic, channel_topic
        self.bundle_topic = bundle_topic_of(batch_topic)
        self.bundles_published = 0
        self.batches_published = 0
        self._outgoing: list = []      # (core batch, stamp_ns): this step's bundle, not yet published
        self._triggered = False        # the guard condition is triggered and has not run yet
        inputs = self.inputs = InputGuard.of(node)  # malformed batches: dropped, counted, logged once per kind
        #: batches are published and read as serialized bytes (:mod:`.batch_cdr`), not typed messages
        self.wire_bytes, why_not = WIRE_CHECK.result()
        if not self.wire_bytes:
            node.get_logger().info(f'channel batches go through typed messages: {why_not}')
        self.publisher = node.create_publisher(AgentMessageBundle, self.bundle_topic, CHANNEL_QOS,
                                               event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))
        events = SubscriptionEventCallbacks(use_default_callbacks=False)
        self.bundle_subscription = inputs.subscribe(AgentMessageBundle, self.bundle_topic, self._on_bundle, CHANNEL_QOS,
                                                    raw=True, event_callbacks=events)
        self.batch_subscription = inputs.subscribe(AgentMessageBatch, batch_topic, self._on_batch, CHANNEL_QOS,
                                                   raw=True, event_callbacks=events)
        self.single_subscription = inputs.subscribe(AgentMessage, channel_topic, self._on_single, CHANNEL_QOS,
                                                    event_callbacks=events)
        self.timer = node.create_timer(tick_s, self._on_tick)
        self._fast = True
        self._flushing: dict[str, AgentChannel] = {}
        self._local: deque = deque()   # (channel, batch) handed over in-process, not yet received
        self.batches_local = 0         # batches between this process's own agents (not taken back)
        self.flush_trigger = node.create_guard_condition(self._on_flush)

    def unmatched_subscriptions(self) -> int:
        """Subscriptions the graph lists on the bundle topic that this hub's publisher has not matched yet.
        The graph learns a process's endpoints from its ros_discovery_info, which can run seconds ahead of
        DDS matching them on a loaded machine; a bundle published to an unmatched reader is lost."""
        listed = len(self.node.get_subscriptions_info_by_topic(self.bundle_topic))
        return max(0, listed - self.publisher.get_subscription_count())

    # --- channels ----------------------------------------------------------------------------------
    def attach(self, channel: 'AgentChannel') -> None:
        self.channels[channel.robot] = channel

    def detach(self, channel: 'AgentChannel') -> None:
        if self.channels.get(channel.robot) is channel:
            del self.channels[channel.robot]
        self._flushing.pop(channel.robot, None)

    def publish(self, batch, stamp_ns: int) -> None:
        """Send the core batch ``batch`` (stamped when it left the link model) in this step's bundle,
        published at the end of the current callback (or by the guard condition); one for a robot
        of this process is also handed to its channel in-process (at the next guard-condition
        callback, no decoding, no codec) and skipped when the subscription takes it back -- it is
        in the bundle all the same, for the recorder and any other listener."""
        self._outgoing.append((batch, stamp_ns))
        channel = self.channels.get(batch.recipient)
        if channel is not None and batch.sender in self.channels:
            self._local.append((channel, batch))
        self._trigger()

    def request_flush(self, channel: 'AgentChannel') -> None:
        """End ``channel``'s processing step once the executor's ready callbacks have run."""
        self._trigger()
        self._flushing[channel.robot] = channel
        self.wake()

    def _trigger(self) -> None:
        if not self._triggered:
            self._triggered = True
            self.flush_trigger.trigger()

    def _send_bundle(self) -> None:
        """Publish the batches released since the last bundle as one bundle (none: nothing)."""
        if not self._outgoing:
            return
        outgoing, self._outgoing = self._outgoing, []
        stamp_ns = max(stamp for _, stamp in outgoing)
        if self.wire_bytes:
            msg = bytes(encode_bundle([(encode_batch(batch), stamp) for batch, stamp in outgoing], stamp_ns))
        else:
            msg = _typed_bundle([(batch_to_ros(batch), stamp) for batch, stamp in outgoing], stamp_ns)
        self.publisher.publish(msg)
        self.bundles_published += 1
        self.batches_published += len(outgoing)

    def wake(self) -> None:
        """Something is pending: poll every ``tick_s`` from now on (until every channel is idle)."""
        if not self._fast:
            self._set_period(self.tick_s)

    def _set_period(self, period: float) -> None:
        self._fast = period == self.tick_s
        self.timer.timer_period_ns = int(period * 1e9)
        self.timer.reset()

    # --- callbacks ---------------------------------------------------------------------------------
    def _on_flush(self) -> None:
        """End the processing step of every channel that queued messages, then hand over the
        batches between this process's agents (what they answer goes out at the next call)."""
        self._triggered = False
        flushing, self._flushing = self._flushing, {}
        for channel in flushing.values():
            channel.flush()
        self._send_bundle()  # the step's batches
        local, self._local = self._local, deque()
        touched: dict[str, AgentChannel] = {}
        for channel, batch in local:
            if self.channels.get(channel.robot) is channel:
                self.batches_local += 1
                touched[channel.robot] = channel
                channel.accept_local(batch)
        for channel in touched.values():
            channel.deliver_urgent()
        self._send_bundle()  # what the agents answered at once (negotiation)

    def _on_tick(self) -> None:
        busy = False
        for channel in list(self.channels.values()):
            busy = channel.on_tick() or busy
        self._send_bundle()  # retries, delayed batches and ACKs due now
        if busy != self._fast:
            self._set_period(self.tick_s if busy else self.idle_tick_s)

    def _on_bundle(self, data: bytes) -> None:
        self._drain(data, self.bundle_subscription, self._accept_bundle)

    def _on_batch(self, data: bytes) -> None:
        self._drain(data, self.batch_subscription, self._accept)

    def _drain(self, data: bytes | None, subscription, accept) -> None:
        """Take what ``subscription`` holds for at most ``drain_slice_s``, then hand the touched
        channels their negotiation messages and publish what they answered at once."""
        end = time.perf_counter() + self.drain_slice_s
        touched: dict[str, AgentChannel] = {}
        while data is not None:
            accept(data, touched)
            data = self._take_queued(subscription) if time.perf_counter() < end else None
        for channel in touched.values():
            channel.deliver_urgent()
        self._send_bundle()

    def _accept_bundle(self, data: bytes, touched: dict) -> None:
        skipped = 0

        def wanted(sender: str, recipient: str) -> bool:
            nonlocal skipped
            if recipient in self.channels and sender not in self.channels:
                return True
            skipped += 1  # another process's robot, or handed over in-process already
            return False
        batches = None
        if self.wire_bytes:
            try:
                batches = decode_bundle(data, wanted)[1]
            except ValueError:
                batches, skipped = None, 0  # rclpy reads it, or names what is wrong
        if batches is None:
            try:
                msg = deserialize_message(data, AgentMessageBundle)
                batches = [batch_from_ros(batch) for batch in msg.batches if wanted(batch.sender, batch.recipient)]
            except Exception as exc:  # noqa: BLE001 - a malformed sample must not stop the executor
                self.inputs.reject(self.bundle_topic, MalformedInput(
                    f'bundle: undecodable ({type(exc).__name__}: {exc})', kind='undecodable bundle'))
                return
        self.batches_skipped += skipped
        for fields in batches:
            channel = self.channels.get(fields['recipient'])
            if channel is None:
                continue
            self.batches_received += 1
            touched[channel.robot] = channel
            channel.accept_fields(fields)

    def _accept(self, data: bytes, touched: dict) -> None:
        addresses = peek_addresses(data)
        if addresses is not None and (addresses[1] not in self.channels or addresses[0] in self.channels):
            self.batches_skipped += 1  # another process's robot, or handed over in-process already
            return
        fields = None
        if self.wire_bytes:
            try:
                fields = decode_cdr(data)
            except ValueError:
                fields = None  # rclpy reads it, or names what is wrong
        if fields is None:
            try:
                fields = batch_from_ros(deserialize_message(data, AgentMessageBatch))
            except Exception as exc:  # noqa: BLE001 - a malformed sample must not stop the executor
                self.inputs.reject(self.batch_topic, MalformedInput(f'batch: undecodable ({type(exc).__name__}: {exc})',
                                                                    kind='undecodable batch'))
                return
        channel = self.channels.get(fields['recipient'])
        if channel is None or fields['sender'] in self.channels:
            self.batches_skipped += 1
            return
        self.batches_received += 1
        touched[channel.robot] = channel
        channel.accept_fields(fields)

    def _take_queued(self, subscription) -> bytes | None:
        """The next message waiting in ``subscription``, or None (as rclpy's executor takes it)."""
        try:
            with subscription.handle:
                taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
        except Exception as exc:  # noqa: BLE001 - an rclpy without this API: one batch per callback
            self.node.get_logger().debug(f'cannot drain the channel subscription: {exc}')
            return None
        return None if taken is None else taken[0]

    def _on_single(self, msg: AgentMessage) -> None:
        """A single message on the shared topic (tools, tests)."""
        if msg.receiver:
            channel = self.channels.get(msg.receiver)
            if channel is not None and msg.sender != msg.receiver:
                channel.accept_single(msg)
            return
        for robot, channel in list(self.channels.items()):
            if robot != msg.sender:
                channel.accept_single(msg)

    def destroy(self) -> None:
        self.channels.clear()
        self._flushing.clear()
        self._local.clear()
        self.node.destroy_timer(self.timer)
        self.node.destroy_guard_condition(self.flush_trigger)
        self.node.destroy_subscription(self.bundle_subscription)
        self.node.destroy_subscription(self.batch_subscription)
        self.node.destroy_subscription(self.single_subscription)
        self.node.destroy_publisher(self.publisher)


__all__ = ['BATCH_TOPIC', 'CHANNEL_QOS', 'CHANNEL_TOPIC', 'ChannelHub', 'QUEUE_DEPTH']
