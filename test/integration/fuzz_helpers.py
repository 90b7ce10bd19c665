"""Hostile input for the fuzz tests (issue 16): invalid stamps, a bad /clock, floods, and the checks that a
node dropped, counted and logged each kind of rejection once (collab_tools.input_guard)."""

import re
import time
from pathlib import Path

from builtin_interfaces.msg import Time
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from bridge_helpers import wait_for_subscriber

RELIABLE = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
LATCHED = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)

#: Stamps no clock can hold (rclpy raised for the first; the second kind was folded into seconds) and one
#: 68 years ahead of any simulated clock.
NEGATIVE = Time(sec=-1, nanosec=0)
MOST_NEGATIVE = Time(sec=-2**31, nanosec=0)
NANOSEC_OUT_OF_RANGE = Time(sec=1, nanosec=2**32 - 1)
HUGE = Time(sec=2**31 - 1, nanosec=999_999_999)
BAD_STAMPS = (NEGATIVE, MOST_NEGATIVE, NANOSEC_OUT_OF_RANGE, HUGE)


def publish_all(ros_node, msg_type, topic, messages, qos=RELIABLE, subscribers=1, pause=0.01):
    """Publish ``messages`` once the topic has ``subscribers``; returns the publisher."""
    publisher = ros_node.create_publisher(msg_type, topic, qos)
    deadline = time.monotonic() + 20.0
    while publisher.get_subscription_count() < subscribers and time.monotonic() < deadline:
        time.sleep(0.05)
    wait_for_subscriber(publisher)
    for msg in messages:
        publisher.publish(msg)
        time.sleep(pause)
    return publisher


def flood(publisher, msg, count, seconds=1.0):
    """``count`` copies of ``msg`` within about ``seconds`` (a short flood)."""
    pause = seconds / count
    for _ in range(count):
        publisher.publish(msg)
        time.sleep(pause)


def bad_clock(ros_node, subscribers=1, repeat=3):
    """/clock messages a simulated clock must not follow: negative, nanosec out of range, 68 years ahead."""
    messages = [Clock(clock=stamp) for stamp in BAD_STAMPS] * repeat
    # Best effort, as rclpy's time source subscribes (depth 1): a short pause lets each one arrive.
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    return publish_all(ros_node, Clock, '/clock', messages, qos=qos, subscribers=subscribers, pause=0.05)


def rejections(log_text: str, topic: str) -> dict[str, int]:
    """Kind -> how many times the node logged its first rejection on ``topic`` (must be 1 each)."""
    pattern = re.compile(rf'dropped a malformed message on {re.escape(topic)}: .*?\[([^;\]]+); further')
    kinds: dict[str, int] = {}
    for kind in pattern.findall(log_text):
        kinds[kind] = kinds.get(kind, 0) + 1
    return kinds


def republish_until_rejected(publisher, messages, topic: str, expected: dict, timeout: float = 30.0,
                             pause: float = 0.2):
    """Publish ``messages`` again every few seconds until each log in ``expected`` (path -> kinds) shows each
    kind rejected on ``topic``. A node busy for seconds keeps only its subscription's newest messages (depth 10
    on a topic its peers also publish on), so one pass need not reach it; a repeat is counted, not logged again.
    """
    deadline = time.monotonic() + timeout
    while True:
        missing = {str(path): [k for k in kinds if k not in rejections(Path(path).read_text(), topic)]
                   for path, kinds in expected.items()}
        missing = {path: kinds for path, kinds in missing.items() if kinds}
        if not missing or time.monotonic() > deadline:
            return missing
        time.sleep(2.0)
        for msg in messages:
            publisher.publish(msg)
            time.sleep(pause)


def assert_rejected_once_per_kind(log_text: str, topic: str, expected_kinds, at_least: bool = True):
    """Each expected kind was logged exactly once on ``topic`` (at_least: other kinds may be there too)."""
    kinds = rejections(log_text, topic)
    missing = [k for k in expected_kinds if k not in kinds]
    assert not missing, f'{topic}: no rejection logged for {missing}; logged: {kinds}'
    repeated = {k: n for k, n in kinds.items() if n != 1}
    assert not repeated, f'{topic}: kinds logged more than once: {repeated}'
    if not at_least:
        assert set(kinds) == set(expected_kinds), kinds


def clock_rejections_ok(log_text: str):
    """The three kinds of bad /clock were each dropped and logged once."""
    assert_rejected_once_per_kind(log_text, '/clock', ['clock: negative', 'clock: nanosec out of range',
                                                       'clock: far ahead'])
    assert 'Traceback' not in log_text
