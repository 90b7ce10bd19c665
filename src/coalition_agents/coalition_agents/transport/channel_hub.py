"""ChannelHub: the ROS endpoints an agent process shares between its agents' channels.

One hub per process (a ``schema_agent_host`` with all its agents, or a standalone ``schema_agent``)
owns, on its node:

* ONE publisher and ONE subscription on the team's batch topic ``<team>/coalition/batches``
  (``coalition_interfaces/AgentMessageBatch``, columns). The subscription takes the batches
  serialized (``raw``) and reads each one's ``recipient`` from its first bytes
  (:func:`~.batch_wire.peek_recipient`): batches for robots this process does not host are
  dropped without being deserialised; the others go to their robot's channel. Why one topic and
  one subscription per process, not one inbox topic and subscription per agent: rclpy's executor
  rebuilds its wait set from every entity of every node at each wake-up, and hands a subscription
  one message per wake-up; twenty inboxes per process made the executor's bookkeeping, not the
  agents, dominate. Any process that subscribes to the topic -- another host, a standalone agent on
  a real robot, ``ros2 topic echo``, the bag recorder -- sees every batch.
* ONE subscription on the shared topic ``<team>/coalition/channel`` (single ``AgentMessage`` s
  from tools and tests), handed to the addressed hosted robot (every hosted robot but the sender
  for a message without receiver).
* ONE timer for every channel's retries, delayed batches and ack-only batches: ``tick_s`` while
  some channel has something pending (an unacknowledged copy, a delayed batch, an ACK waiting),
  ``idle_tick_s`` otherwise -- an idle team wakes up a few times a second, not a hundred times
  per agent -- and back to ``tick_s`` the moment a channel queues something (:meth:`wake`).
* ONE guard condition that ends the processing step: every channel that queued messages since
  is flushed (one batch per recipient) when the executor runs it, after the callbacks that were
  ready together. A batch between two agents of this process is published (the recorder and any
  listener see it) and handed to its recipient's channel in-process at the same callback, as
  the core batch: the subscription skips it when it comes back, so it is neither deserialised
  nor queued behind the team's traffic.

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
from coalition_interfaces.msg import AgentMessage, AgentMessageBatch

from .batch_cdr import WireCheck, decode_cdr
from .batch_wire import batch_from_ros, peek_addresses

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


def _serialize(columns: dict, stamp_ns: int) -> bytes:
    msg = AgentMessageBatch(**columns)
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    return serialize_message(msg)


def _fields(data: bytes) -> dict:
    msg = deserialize_message(data, AgentMessageBatch)
    fields = {key: value if isinstance(value, (str, int)) else list(value)
              for key, value in batch_from_ros(msg).items()}
    return {**fields, 'stamp_ns': msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec}


#: does this process's middleware agree with batch_cdr (checked at the first hub)
WIRE_CHECK = WireCheck(_serialize, _fields)


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
        inputs = self.inputs = InputGuard.of(node)  # malformed batches: dropped, counted, logged once per kind
        #: batches are published and read as serialized bytes (:mod:`.batch_cdr`), not typed messages
        self.wire_bytes, why_not = WIRE_CHECK.result()
        if not self.wire_bytes:
            node.get_logger().info(f'channel batches go through typed messages: {why_not}')
        self.publisher = node.create_publisher(AgentMessageBatch, batch_topic, CHANNEL_QOS,
                                               event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))
        events = SubscriptionEventCallbacks(use_default_callbacks=False)
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

    # --- channels ----------------------------------------------------------------------------------
    def attach(self, channel: 'AgentChannel') -> None:
        self.channels[channel.robot] = channel

    def detach(self, channel: 'AgentChannel') -> None:
        if self.channels.get(channel.robot) is channel:
            del self.channels[channel.robot]
        self._flushing.pop(channel.robot, None)

    def publish(self, msg: AgentMessageBatch | bytes, batch) -> None:
        """Publish the batch ``batch`` as ``msg`` (its serialized bytes or typed message); one for a
        robot of this process is also handed to its channel in-process (the core batch: at the next
        guard-condition callback, no deserialisation, no codec) and skipped when the subscription
        takes it back -- it is published all the same, for the recorder and any other listener."""
        self.publisher.publish(msg)
        channel = self.channels.get(batch.recipient)
        if channel is not None and batch.sender in self.channels:
            if not self._local and not self._flushing:
                self.flush_trigger.trigger()
            self._local.append((channel, batch))

    def request_flush(self, channel: 'AgentChannel') -> None:
        """End ``channel``'s processing step once the executor's ready callbacks have run."""
        if not self._flushing and not self._local:
            self.flush_trigger.trigger()
        self._flushing[channel.robot] = channel
        self.wake()

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
        flushing, self._flushing = self._flushing, {}
        for channel in flushing.values():
            channel.flush()
        local, self._local = self._local, deque()
        touched: dict[str, AgentChannel] = {}
        for channel, batch in local:
            if self.channels.get(channel.robot) is channel:
                self.batches_local += 1
                touched[channel.robot] = channel
                channel.accept_local(batch)
        for channel in touched.values():
            channel.deliver_urgent()

    def _on_tick(self) -> None:
        busy = False
        for channel in list(self.channels.values()):
            busy = channel.on_tick() or busy
        if busy != self._fast:
            self._set_period(self.tick_s if busy else self.idle_tick_s)

    def _on_batch(self, data: bytes) -> None:
        end = time.perf_counter() + self.drain_slice_s
        touched: dict[str, AgentChannel] = {}
        while data is not None:
            self._accept(data, touched)
            data = self._take_queued() if time.perf_counter() < end else None
        for channel in touched.values():
            channel.deliver_urgent()

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

    def _take_queued(self) -> bytes | None:
        """The next batch waiting in the subscription, or None (as rclpy's executor takes it)."""
        subscription = self.batch_subscription
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
        self.node.destroy_subscription(self.batch_subscription)
        self.node.destroy_subscription(self.single_subscription)
        self.node.destroy_publisher(self.publisher)


__all__ = ['BATCH_TOPIC', 'CHANNEL_QOS', 'CHANNEL_TOPIC', 'ChannelHub', 'QUEUE_DEPTH']
