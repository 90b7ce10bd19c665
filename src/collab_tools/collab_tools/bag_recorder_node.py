"""bag_recorder node: records topics to a rosbag2 directory (MCAP) as rosbag2 Jazzy writes it.

Subscribes raw (serialized CDR, never deserialized), with a QoS adapted to what the
publishers offer, like `ros2 bag record`: reliable only if every publisher is
reliable, transient-local only if every publisher is. The offered QoS profiles, the
publishers' type hash and the message definitions (custom types from their installed
.msg and .action files, so an action's feedback and status topics too) go into the bag.
New topics are picked up as they appear. On SIGINT/SIGTERM the recorder drains, then closes the
bag: it looks for no new topic and takes what its queues still hold (a recorder behind a flood
holds seconds of it) until no message published before the signal has come for
``drain_quiet_period``, at most ``drain_timeout``; what is still queued then is counted lost
(``drain_left``, core.recording_loss.DrainRule).

A topic the recorder cannot record (several types on it, a type it cannot import or
find a definition for, a definition whose hash differs from the publishers') is an
error: it is logged when found, listed again when the bag closes and in the bag's
``custom_data`` (``unrecorded_topics``), and the recorder then exits with code 1, which
an orchestration session reports as a failed node (experiment exit code 3). A requested
topic that never got a publisher is only a warning: nothing was there to record.

Nothing is lost silently (core.recording_loss): per topic the recorder counts what it received,
wrote and lost (gaps in the publishers' sequence numbers: its queue overflowed or transport
lost them; the middleware's message_lost events; failed writes), logs every loss when the bag
closes and puts the counts into ``custom_data`` and into ``recorder_status.yaml`` in the bag,
rewritten every ``chunk_flush_period`` together with the pending chunk, so a killed recorder
loses at most that period's messages and its bag is repaired with its last counts (bag_reindex).
The same counts go to ``/diagnostics`` (diagnostic_msgs, as ROS drivers report their state) at
every tick: WARN while messages are lost, ERROR for a topic it cannot record.
A topic's queue holds ``queue_seconds`` of its expected rate (``topic_rates``), at least
``queue_depth`` messages.
"""

import os
import re
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import SubscriptionEventCallbacks, UnsupportedEventTypeError
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile,
                       ReliabilityPolicy)
from std_msgs.msg import Header

from .core.bag_storage import ROS_DISTRO
from .core.bag_types import build_typestore
from .core.bag_writer import BagWriter, QosSpec
from .core.recording_loss import STATUS_FILE, DrainRule, LossLedger, queue_depth, write_status
from .core.tool_settings import RECORDER_SETTINGS, parse_topic_rates
from .node_support import ConfigurationError, run
from .parameters import NodeParameters
from .queued_messages import count_published_before, take_queued
from .ros_interfaces import import_interface
from .topic_discovery import DiscoveryTimer, topic_names_problem

EXIT_UNRECORDED = 1
QUEUE_DEPTH_MAX = 100_000
#: Seconds spent at most counting what a timed-out drain left queued (taken, not written).
LEFT_COUNT_BOUND = 1.0
#: Messages a subscription callback takes at most from its queue after its own (other topics wait meanwhile).
TAKE_BATCH = 64


def subscription_qos(offered: list[QoSProfile], depth: int) -> QoSProfile:
    """The strongest QoS every publisher is compatible with."""
    reliable = all(p.reliability == ReliabilityPolicy.RELIABLE for p in offered)
    latched = all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in offered)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=(ReliabilityPolicy.RELIABLE if reliable
                                   else ReliabilityPolicy.BEST_EFFORT),
                      durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                                  else DurabilityPolicy.VOLATILE),
                      liveliness=LivelinessPolicy.AUTOMATIC)


class BagRecorder(Node):

    def __init__(self):
        super().__init__('bag_recorder')
        self.params = NodeParameters(self)
        # Topic names are checked the way this node will resolve them (rclpy's rules, its namespace).
        schema = RECORDER_SETTINGS.replaced('topics', check=lambda topics: topic_names_problem(self, topics))
        values = self.params.declare_schema(schema, on_change={'discovery_period': lambda p: self.discovery.set_period(p)})
        output, topics, exclude = values['output'], values['topics'], values['exclude']
        period, preset = values['discovery_period'], values['storage_preset']
        self.topics = [self.resolve_topic_name(t) for t in topics if t]
        self.exclude = [re.compile(p) for p in exclude if p]
        try:
            self.rates = {self.resolve_topic_name(t): hz for t, hz in parse_topic_rates(values['topic_rates']).items()}
        except Exception as error:  # an invalid topic name (rclpy's exception kin)
            raise ConfigurationError(f'parameter topic_rates: {error}') from None
        self.queue_seconds, self.queue_depth = values['queue_seconds'], values['queue_depth']
        self.loss = LossLedger()
        self.drain_quiet_period, self.drain_timeout = values['drain_quiet_period'], values['drain_timeout']
        self._stop_ns: int | None = None  # wall-clock time of the stop signal, once draining
        self._drain: DrainRule | None = None
        self.publisher_counts: dict[str, int] = {}

        self.type_names: set[str] = set()
        self.failures: dict[str, str] = {}
        try:
            self.writer = BagWriter(output, build_typestore(()), storage_preset=preset,
                                    ros_distro=os.environ.get('ROS_DISTRO') or ROS_DISTRO)
        except (OSError, ValueError) as error:
            raise ConfigurationError(f'parameter output: {error}') from None
        self.status_path = self.writer.path / STATUS_FILE
        self.diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._written_status = None
        self.flush_timer = self.create_timer(values['chunk_flush_period'], self._flush,
                                             clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.subscriptions_by_topic = {}
        self.discovery = DiscoveryTimer(self, self._discover, period)
        self.get_logger().info(
            f'recording {"topics " + ", ".join(self.topics) if self.topics else "all topics"} '
            f'to {output} (storage preset {preset})')
        self._discover()

    def _wanted(self, topic: str) -> bool:
        if self.topics:
            return topic in self.topics
        return not any(pattern.fullmatch(topic) for pattern in self.exclude)

    def _discover(self) -> None:
        for topic, subscription in self.subscriptions_by_topic.items():
            if subscription is not None:  # each publisher numbers its own messages (recording_loss)
                self.publisher_counts[topic] = subscription.get_publisher_count()
        for topic, type_names in self.get_topic_names_and_types():
            if not self._wanted(topic) or topic in self.failures:
                continue
            if len(type_names) != 1:
                # Also once recorded: a second type that appears later is not in the bag.
                self._fail(topic, f'it carries several types {type_names}')
                continue
            if topic in self.subscriptions_by_topic:
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            if not publishers:
                continue  # only subscribers so far; wait for an offered QoS
            self._record(topic, type_names[0], publishers)

    def _fail(self, topic: str, reason: str) -> None:
        self.failures[topic] = reason
        self.subscriptions_by_topic.setdefault(topic, None)  # do not retry every period
        self.get_logger().error(f'{topic}: CANNOT RECORD, {reason}; the recorder will exit with code '
                                f'{EXIT_UNRECORDED} (the run fails)')

    def _record(self, topic: str, type_name: str, publishers) -> None:
        # The graph's topic list can lag its endpoint list: name the second type when a publisher has it.
        types = sorted({info.topic_type for info in publishers} | {type_name})
        if len(types) > 1:
            self._fail(topic, f'it carries several types {types}')
            return
        offered = [info.qos_profile for info in publishers]
        # The hash the publishers' type support reports, as rosbag2 stores it ('INVALID' when unknown).
        hashes = {str(info.topic_type_hash) for info in publishers} - {'INVALID'}
        if len(hashes) > 1:
            self._fail(topic, f'its publishers disagree on the definition of {type_name} '
                       f'(type hashes {", ".join(sorted(hashes))})')
            return
        try:
            msg_type = import_interface(type_name)
            if type_name not in self.type_names:
                self.writer.typestore = build_typestore(self.type_names | {type_name})
                self.type_names.add(type_name)
            self.writer.add_topic(topic, type_name, [QosSpec.from_profile(q) for q in offered],
                                  type_hash=next(iter(hashes), None))
            # Discovery does not carry a writer's depth: transient local is ROS's "latched" state.
            self.loss.add_topic(topic, latest_only=all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered))
            self.publisher_counts[topic] = len(publishers)
            depth = queue_depth(self.rates.get(topic, 0.0), self.queue_seconds, self.queue_depth, QUEUE_DEPTH_MAX)
            events = SubscriptionEventCallbacks(
                message_lost=lambda info, topic=topic: self.loss.reported_lost(topic, info.total_count))
            callback, qos = (lambda data, info, topic=topic: self._take(topic, data, info)), \
                subscription_qos(offered, depth)
            try:
                subscription = self.create_subscription(msg_type, topic, callback, qos, raw=True,
                                                        event_callbacks=events)
            except UnsupportedEventTypeError:  # an rmw without message_lost: the sequence gaps still count
                subscription = self.create_subscription(msg_type, topic, callback, qos, raw=True)
        except Exception as error:  # whatever it is, the topic is missing from the bag: fail the run
            self._fail(topic, f'{type(error).__name__}: {error}')
            return
        self.subscriptions_by_topic[topic] = subscription
        self.get_logger().info(f'recording {topic} [{type_name}] (queue depth {depth})')

    def _take(self, topic: str, data: bytes, info: dict) -> None:
        """The executor's message, then up to TAKE_BATCH more straight from the queue: the executor's own
        path (wait set, task, coroutine per message) costs several times the write."""
        self._write(topic, data, info)
        subscription = self.subscriptions_by_topic.get(topic)
        for more in take_queued(subscription, TAKE_BATCH) if subscription is not None else ():
            self._write(topic, *more)

    def _write(self, topic: str, data: bytes, info: dict) -> None:
        self.loss.received(topic, info.get('publication_sequence_number'), self.publisher_counts.get(topic, 1))
        if self._stop_ns is not None and info.get('source_timestamp', 0) <= self._stop_ns:
            self._drain.took(time.monotonic())
        try:
            self.writer.write(topic, self.get_clock().now().nanoseconds, data)
        except Exception:
            if self.writer.closed:  # a message arriving while the bag closes is expected
                return
            self.loss.write_failed(topic)
            raise  # a storage error: the recorder stops, its bag is repaired (bag_reindex)
        self.loss.written(topic)

    def drain(self, executor, stop_ns: int) -> None:
        """After SIGINT/SIGTERM (node_support.run drain_on_stop): take what the queues hold (module docstring)."""
        self.discovery.stop()  # no new topic from now on
        self.loss.drain_started()
        self._drain = rule = DrainRule(self.drain_quiet_period, self.drain_timeout, time.monotonic())
        self._stop_ns = stop_ns
        while not rule.done(now := time.monotonic()):
            executor.spin_once(timeout_sec=rule.wait(now))
        timed_out, seconds = rule.timed_out(now), now - rule.started
        # What is still queued is lost: counted (taken, not written), for at most LEFT_COUNT_BOUND.
        queued = {t: s for t, s in self.subscriptions_by_topic.items() if s is not None}
        self.loss.drain_ended(count_published_before(queued, stop_ns, self.drain_quiet_period, LEFT_COUNT_BOUND)
                              if timed_out else {})
        drained = sum(c.drained for c in self.loss.topics.values())
        self.get_logger().info(f'drained {drained} queued message(s) in {seconds:.2f} s'
                               + (' (drain_timeout reached)' if timed_out else ''))

    def _flush(self) -> None:
        """Put the pending chunk into the file and the counts into the status file (module docstring)."""
        self.writer.flush()  # every period: a kill loses at most one period's messages
        custom = self.loss.custom_data()
        if custom != self._written_status:
            self._write_status(custom, 'recording')
        self._publish_diagnostics()

    def _publish_diagnostics(self) -> None:
        lost = self.loss.total_lost
        level, text = ((DiagnosticStatus.ERROR, f'{len(self.failures)} topic(s) cannot be recorded') if self.failures
                       else (DiagnosticStatus.WARN, f'{lost} message(s) lost') if lost
                       else (DiagnosticStatus.OK, 'recording, nothing lost'))
        values = [KeyValue(key=topic, value=f'received {c.received}, written {c.written}, lost {c.lost}')
                  for topic, c in sorted(self.loss.topics.items())]
        status = DiagnosticStatus(level=level, name=self.get_fully_qualified_name(), message=text,
                                  hardware_id=str(self.writer.path), values=values)
        self.diagnostics.publish(DiagnosticArray(header=Header(stamp=self.get_clock().now().to_msg()),
                                                 status=[status]))

    def _write_status(self, custom: dict, state: str) -> None:
        try:
            write_status(self.status_path, custom, state)
            self._written_status = custom
        except OSError as error:
            self.get_logger().warn(f'cannot write {self.status_path}: {error}', throttle_duration_sec=30.0)

    def destroy_node(self):
        # Close the bag on every way out (shutdown, error), before the node goes.
        counts = self.writer.counts()
        never = [t for t in self.topics if t not in self.subscriptions_by_topic]
        if never:
            self.get_logger().warn(f'requested topics that never had a publisher: {", ".join(never)}')
        if self.failures:
            listing = '; '.join(f'{topic}: {reason}' for topic, reason in sorted(self.failures.items()))
            self.writer.set_custom_data('unrecorded_topics', listing)
            self.get_logger().error(f'{len(self.failures)} topic(s) NOT recorded: {listing}')
        custom = self.loss.custom_data()
        for key, value in custom.items():
            self.writer.set_custom_data(key, value)
        for line in self.loss.loss_lines(self.drain_timeout):
            self.get_logger().error(line)
        self.writer.close()
        self._write_status(custom, 'closed')
        self.get_logger().info(
            f'bag closed: {sum(counts.values())} messages on {len(counts)} topics, {self.loss.total_lost} lost')
        super().destroy_node()


def main(args=None) -> int:
    recorders: list[BagRecorder] = []

    def make() -> BagRecorder:
        recorders.append(BagRecorder())
        return recorders[-1]

    code = run(make, 'bag_recorder', args, drain_on_stop=True)
    if code == 0 and recorders and recorders[0].failures:
        return EXIT_UNRECORDED
    return code


if __name__ == '__main__':
    sys.exit(main())
