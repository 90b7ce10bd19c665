"""The one guarded path from a message to a node's callback: malformed input is dropped, counted, logged.

Every subscription and service of the workspace's nodes is created through a node's
:class:`InputGuard`::

    inputs = InputGuard.of(self)
    inputs.subscribe(Guidance, topic, self._on_guidance, RELIABLE)
    inputs.serve(StepSimulation, '~/step', self._on_step)

A callback converts its message (``inputs.stamp`` for header stamps, the packages' conversions for
the rest) and raises :class:`~collab_tools.core.input_checks.MalformedInput` or a ``ValueError``
naming the field; the guard catches these conversion errors (and ``TypeError``, ``KeyError``,
``IndexError``, ``ArithmeticError``), drops the message, counts it per (topic, kind) and logs the
first of each kind with the topic, then once at 10, 100, 1000... of that kind: a flood costs a
few log lines, and nothing is lost silently. A service answers a dropped request with
``success = false`` and the error when its response has those fields.

``fatal`` error types pass through (a role player's robot missing from the team description
stops the node with exit code 2, as at start). A ``ConfigurationError`` raised by a conversion is
a ``ValueError`` like the others, so only a callback that names it in ``fatal`` ends the node.
The simulated clock's guard (:mod:`collab_tools.sim_clock`) counts its refusals here too.
"""
from __future__ import annotations

import functools
import time
from collections import Counter
from collections.abc import Callable
from typing import Any

from rclpy.node import Node
from rclpy.time import Time

from .core.input_checks import MalformedInput, error_kind, reference_time, stamp_nanoseconds

#: What a conversion raises for a malformed message (ValueError includes MalformedInput and ConfigurationError).
CONVERSION_ERRORS = (ValueError, TypeError, KeyError, IndexError, ArithmeticError)
#: Characters of an error message a log line echoes (a forged field can be megabytes long).
ECHO_LIMIT = 300

_ATTRIBUTE = '_collab_input_guard'


class InputGuard:
    """A node's malformed-input accounting; see the module docstring. One per node: :meth:`of`."""

    def __init__(self, node: Node):
        self.node = node
        #: dropped messages per (topic, kind)
        self.counts: Counter[tuple[str, str]] = Counter()
        #: called with (topic, error) for every rejection (the bridge counts them in its status)
        self.on_reject: Callable[[str, BaseException], None] | None = None

    @classmethod
    def of(cls, node: Node) -> InputGuard:
        guard = getattr(node, _ATTRIBUTE, None)
        if guard is None:
            guard = cls(node)
            setattr(node, _ATTRIBUTE, guard)
        return guard

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def dropped(self, topic: str | None = None) -> int:
        """Messages dropped on ``topic`` (all topics: None)."""
        return sum(n for (t, _), n in self.counts.items() if topic is None or t == topic)

    # --- rejecting ---------------------------------------------------------------------------
    def reject(self, topic: str, error: BaseException) -> None:
        """Count a dropped message and log it once per (topic, kind) (and at 10, 100, ... of its kind)."""
        kind = error_kind(error)
        key = (topic, kind)
        self.counts[key] += 1
        count = self.counts[key]
        text = str(error)
        if len(text) > ECHO_LIMIT:
            text = text[:ECHO_LIMIT] + '...'
        if count == 1:
            self.node.get_logger().warning(
                f'dropped a malformed message on {topic}: {text} [{kind}; further ones of this kind are '
                'counted, not logged]')
        elif _power_of_ten(count):
            self.node.get_logger().warning(f'{topic}: {count} malformed messages dropped so far [{kind}]')
        if self.on_reject is not None:
            self.on_reject(topic, error)

    # --- guarded callbacks ---------------------------------------------------------------------
    def guard(self, topic: str, callback: Callable[[Any], None],
              fatal: tuple[type[BaseException], ...] = ()) -> Callable[[Any], None]:
        """``callback(msg)`` that drops what it cannot convert (see the module docstring)."""
        @functools.wraps(callback)
        def guarded(msg):
            try:
                return callback(msg)
            except fatal:
                raise
            except CONVERSION_ERRORS as error:
                self.reject(topic, error)
                return None
        return guarded

    def guard_service(self, name: str, callback: Callable[[Any, Any], Any],
                      fatal: tuple[type[BaseException], ...] = ()) -> Callable[[Any, Any], Any]:
        """``callback(request, response)`` that answers a request it cannot convert with success false."""
        @functools.wraps(callback)
        def guarded(request, response):
            try:
                return callback(request, response)
            except fatal:
                raise
            except CONVERSION_ERRORS as error:
                self.reject(name, error)
                if hasattr(response, 'success'):
                    response.success = False
                if hasattr(response, 'message'):
                    response.message = f'refused: {str(error)[:ECHO_LIMIT]}'
                return response
        return guarded

    def subscribe(self, msg_type, topic: str, callback: Callable[[Any], None], qos, *,
                  fatal: tuple[type[BaseException], ...] = (), **kwargs):
        """``node.create_subscription`` through the guard (the resolved topic name in its log lines)."""
        name = self._resolved(topic)
        return self.node.create_subscription(msg_type, topic, self.guard(name, callback, fatal), qos, **kwargs)

    def serve(self, srv_type, name: str, callback: Callable[[Any, Any], Any], **kwargs):
        """``node.create_service`` through the guard."""
        return self.node.create_service(srv_type, name, self.guard_service(self._resolved(name), callback),
                                        **kwargs)

    # --- conversions ---------------------------------------------------------------------------
    def stamp(self, stamp, field: str = 'header.stamp') -> Time:
        """A message stamp as the node's clock type; MalformedInput when it is invalid (negative, nanosec
        out of range, far ahead of this node's clock, or of the wall clock before simulated time started)."""
        clock = self.node.get_clock()
        now = reference_time(clock.now().nanoseconds, time.time_ns())
        nanoseconds = stamp_nanoseconds(stamp.sec, stamp.nanosec, field, now)
        return Time(nanoseconds=nanoseconds, clock_type=clock.clock_type)

    def _resolved(self, name: str) -> str:
        try:
            return self.node.resolve_service_name(name, only_expand=True) if name.startswith('~') \
                else self.node.resolve_topic_name(name, only_expand=True)
        except Exception:  # noqa: BLE001 - a label for log lines; rclpy refuses the name itself later
            return name


def _power_of_ten(count: int) -> bool:
    return count >= 10 and str(count).rstrip('0') == '1'


def check_stamp(stamp, field: str = 'header.stamp') -> None:
    """MalformedInput for a stamp no clock can hold (negative, nanosec out of range); no clock needed."""
    stamp_nanoseconds(stamp.sec, stamp.nanosec, field)


__all__ = ['CONVERSION_ERRORS', 'InputGuard', 'MalformedInput', 'check_stamp']
