"""What the recorder and the live view share to follow the graph: the check of the topic names a
user asks for, and the wall-clock timer that looks for new topics (its period can change at run time)."""
from __future__ import annotations

from collections.abc import Callable

from rclpy.clock import Clock, ClockType
from rclpy.node import Node


def topic_names_problem(node: Node, topics: list[str]) -> str | None:
    """The first name ``node`` cannot resolve (rclpy's rules, its namespace), or None."""
    for topic in topics:
        if topic:
            try:
                node.resolve_topic_name(topic)
            except Exception as error:  # rclpy's InvalidTopicNameException and kin
                return f'invalid topic name {topic!r} ({error})'
    return None


class DiscoveryTimer:
    """Calls ``discover`` every period on the wall clock: discovery must go on while simulated time
    is paused."""

    def __init__(self, node: Node, discover: Callable[[], None], period: float):
        self.node, self.discover, self.timer = node, discover, None
        self.set_period(period)

    def set_period(self, period: float) -> None:
        self.stop()
        self.timer = self.node.create_timer(period, self.discover, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def stop(self) -> None:
        if self.timer is not None:
            self.node.destroy_timer(self.timer)
            self.timer = None
