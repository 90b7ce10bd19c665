"""bag_recorder node: records topics to a rosbag2 directory (MCAP) with `rosbags`.

Subscribes raw (serialized CDR, never deserialized), with a QoS adapted to what the
publishers offer, like `ros2 bag record`: reliable only if every publisher is
reliable, transient-local only if every publisher is. The offered QoS profiles and
message definitions (custom types from their installed .msg files) go into the bag.
New topics are picked up as they appear. The bag is closed on shutdown (SIGINT).
"""

import re
import sys

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile,
                       ReliabilityPolicy)

from rosbags.typesys.base import TypesysError

from .core.bag_types import build_typestore
from .core.bag_writer import BagWriter, QosSpec
from .node_support import ConfigurationError, run
from .ros_interfaces import import_interface

RECORD_DEPTH = 100
DEFAULT_EXCLUDE = ['/rosout', '/parameter_events']
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
        self.declare_parameter('output', '')
        self.declare_parameter('topics', [''])
        self.declare_parameter('exclude', DEFAULT_EXCLUDE)
        self.declare_parameter('discovery_period', 0.5)
        output = self.get_parameter('output').value
        if not output:
            raise ConfigurationError('parameter output: required (directory of the new bag)')
        self.topics = [t for t in self.get_parameter('topics').value if t]
        try:
            self.exclude = [re.compile(p) for p in self.get_parameter('exclude').value if p]
        except re.error as error:
            raise ConfigurationError(f'parameter exclude: invalid regular expression ({error})')
        period = self.get_parameter('discovery_period').value
        if not 0.01 <= period <= 60.0:
            raise ConfigurationError(f'parameter discovery_period: must be in [0.01, 60] s (got {period})')

        self.type_names: set[str] = set()
        try:
            self.writer = BagWriter(output, build_typestore(()))
        except (OSError, ValueError) as error:
            raise ConfigurationError(f'parameter output: {error}') from None
        self.subscriptions_by_topic = {}
        # Discovery runs on the wall clock: it must not stall while simulated time is paused.
        self.discovery_timer = self.create_timer(period, self._discover,
                                                 clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(
            f'recording {"topics " + ", ".join(self.topics) if self.topics else "all topics"} '
            f'to {output}')
        self._discover()

    def _wanted(self, topic: str) -> bool:
        if self.topics:
            return topic in self.topics
        return not any(pattern.fullmatch(topic) for pattern in self.exclude)

    def _discover(self) -> None:
        for topic, type_names in self.get_topic_names_and_types():
            if topic in self.subscriptions_by_topic or not self._wanted(topic):
                continue
            if len(type_names) != 1:
                self.get_logger().warn(f'{topic}: not recorded, it carries several types '
                                       f'{type_names}', throttle_duration_sec=10.0)
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            if not publishers:
                continue  # only subscribers so far; wait for an offered QoS
            self._record(topic, type_names[0], [info.qos_profile for info in publishers])

    def _record(self, topic: str, type_name: str, offered: list[QoSProfile]) -> None:
        try:
            msg_type = import_interface(type_name)
            if type_name not in self.type_names:
                self.writer.typestore = build_typestore(self.type_names | {type_name})
                self.type_names.add(type_name)
            self.writer.add_topic(topic, type_name, [QosSpec.from_profile(q) for q in offered])
        except (ValueError, TypesysError) as error:
            self.get_logger().error(f'{topic}: cannot record, not recording it ({error})')
            self.subscriptions_by_topic[topic] = None  # do not retry every period
            return

        def on_message(data: bytes, topic=topic) -> None:
            self.writer.write(topic, self.get_clock().now().nanoseconds, data)

        self.subscriptions_by_topic[topic] = self.create_subscription(
            msg_type, topic, on_message, subscription_qos(offered), raw=True)
        self.get_logger().info(f'recording {topic} [{type_name}]')

    def destroy_node(self):
        # Close the bag on every way out (shutdown, error), before the node goes.
        counts = self.writer.counts()
        self.writer.close()
        self.get_logger().info(
            f'bag closed: {sum(counts.values())} messages on {len(counts)} topics')
        super().destroy_node()


def main(args=None) -> int:
    return run(BagRecorder, 'bag_recorder', args)


if __name__ == '__main__':
    sys.exit(main())
