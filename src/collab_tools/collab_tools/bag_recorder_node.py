"""bag_recorder node: records topics to a rosbag2 directory (MCAP) as rosbag2 Jazzy writes it.

Subscribes raw (serialized CDR, never deserialized), with a QoS adapted to what the
publishers offer, like `ros2 bag record`: reliable only if every publisher is
reliable, transient-local only if every publisher is. The offered QoS profiles, the
publishers' type hash and the message definitions (custom types from their installed
.msg and .action files, so an action's feedback and status topics too) go into the bag.
New topics are picked up as they appear. The bag is closed on shutdown (SIGINT).

A topic the recorder cannot record (several types on it, a type it cannot import or
find a definition for, a definition whose hash differs from the publishers') is an
error: it is logged when found, listed again when the bag closes and in the bag's
``custom_data`` (``unrecorded_topics``), and the recorder then exits with code 1, which
an orchestration session reports as a failed node (experiment exit code 3). A requested
topic that never got a publisher is only a warning: nothing was there to record.
"""

import os
import re
import sys

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile,
                       ReliabilityPolicy)

from .core.bag_storage import ROS_DISTRO
from .core.bag_types import build_typestore
from .core.bag_writer import BagWriter, QosSpec
from .core.tool_settings import RECORDER_SETTINGS
from .node_support import ConfigurationError, run
from .parameters import NodeParameters
from .ros_interfaces import import_interface

RECORD_DEPTH = 100
EXIT_UNRECORDED = 1


def subscription_qos(offered: list[QoSProfile]) -> QoSProfile:
    """The strongest QoS every publisher is compatible with."""
    reliable = all(p.reliability == ReliabilityPolicy.RELIABLE for p in offered)
    latched = all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in offered)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=RECORD_DEPTH,
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
        schema = RECORDER_SETTINGS.replaced('topics', check=self._topics_problem)
        values = self.params.declare_schema(schema, on_change={'discovery_period': self._set_discovery_period})
        output, topics, exclude = values['output'], values['topics'], values['exclude']
        period, preset = values['discovery_period'], values['storage_preset']
        self.topics = [self.resolve_topic_name(t) for t in topics if t]
        self.exclude = [re.compile(p) for p in exclude if p]

        self.type_names: set[str] = set()
        self.failures: dict[str, str] = {}
        try:
            self.writer = BagWriter(output, build_typestore(()), storage_preset=preset,
                                    ros_distro=os.environ.get('ROS_DISTRO') or ROS_DISTRO)
        except (OSError, ValueError) as error:
            raise ConfigurationError(f'parameter output: {error}') from None
        self.subscriptions_by_topic = {}
        self.discovery_timer = None
        self._set_discovery_period(period)
        self.get_logger().info(
            f'recording {"topics " + ", ".join(self.topics) if self.topics else "all topics"} '
            f'to {output} (storage preset {preset})')
        self._discover()

    def _topics_problem(self, topics: list[str]) -> str | None:
        for topic in topics:
            if topic:
                try:
                    self.resolve_topic_name(topic)
                except Exception as error:  # rclpy's InvalidTopicNameException and kin
                    return f'invalid topic name {topic!r} ({error})'
        return None

    def _set_discovery_period(self, period: float) -> None:
        if self.discovery_timer is not None:
            self.destroy_timer(self.discovery_timer)
        # Discovery runs on the wall clock: it must not stall while simulated time is paused.
        self.discovery_timer = self.create_timer(period, self._discover,
                                                 clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _wanted(self, topic: str) -> bool:
        if self.topics:
            return topic in self.topics
        return not any(pattern.fullmatch(topic) for pattern in self.exclude)

    def _discover(self) -> None:
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
            subscription = self.create_subscription(
                msg_type, topic, lambda data, topic=topic: self._write(topic, data),
                subscription_qos(offered), raw=True)
        except Exception as error:  # whatever it is, the topic is missing from the bag: fail the run
            self._fail(topic, f'{type(error).__name__}: {error}')
            return
        self.subscriptions_by_topic[topic] = subscription
        self.get_logger().info(f'recording {topic} [{type_name}]')

    def _write(self, topic: str, data: bytes) -> None:
        try:
            self.writer.write(topic, self.get_clock().now().nanoseconds, data)
        except RuntimeError:
            if not self.writer.closed:  # a message arriving while the bag closes is expected
                raise

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
        self.writer.close()
        self.get_logger().info(
            f'bag closed: {sum(counts.values())} messages on {len(counts)} topics')
        super().destroy_node()


def main(args=None) -> int:
    recorders: list[BagRecorder] = []

    def make() -> BagRecorder:
        recorders.append(BagRecorder())
        return recorders[-1]

    code = run(make, 'bag_recorder', args)
    if code == 0 and recorders and recorders[0].failures:
        return EXIT_UNRECORDED
    return code


if __name__ == '__main__':
    sys.exit(main())
