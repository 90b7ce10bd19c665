"""Messages judged as input: malformed-input errors, their kinds, message stamps and the simulated clock.

A node never dies on a malformed message (README "Robustness"): every conversion of a message
into core values raises :class:`MalformedInput` (or a ``ValueError`` naming the field) and the
node's guard (:mod:`collab_tools.input_guard`) drops, counts and logs it once per kind. This
module holds the pure part, without ROS:

* :func:`error_kind` -- what "the same kind" of rejection means (the field, not its value);
* :func:`stamp_nanoseconds` -- a ``builtin_interfaces/Time`` checked before rclpy sees it: rclpy's
  ``Time.from_msg`` raises ``ValueError`` for a negative ``sec`` (the callback, then the node,
  died) and silently carries a ``nanosec`` >= 1e9 into the seconds; a stamp further ahead of
  the receiving node's clock than :data:`MAX_AHEAD_SECONDS` (a forged ``sec = 2**31 - 1``) is
  from no clock the team shares and would make a node wait forever or take a forged frame as
  the newest;
* :class:`ClockFilter` -- which ``/clock`` messages a node's simulated clock follows.
"""
from __future__ import annotations

import re

NANOSECONDS = 1_000_000_000
#: s: a stamp this far ahead of the receiving node's clock (or a /clock jump this far ahead) is refused.
MAX_AHEAD_SECONDS = 86_400.0
#: Consecutive /clock messages far ahead of the clock (and consistent) after which the clock follows them:
#: the clock source really moved on (a restarted simulation with another time base), not one forged message.
CLOCK_CONFIRMATIONS = 20

_NUMBERS = re.compile(r'[-+]?[0-9][0-9.eE+-]*')


class MalformedInput(ValueError):
    """A message (or field) a node drops; ``kind`` groups rejections for counting and logging."""

    def __init__(self, message: str, kind: str | None = None):
        super().__init__(message)
        self.kind = kind


def error_kind(error: BaseException) -> str:
    """The kind of a rejection: a MalformedInput's own kind, else the error type and the field it names
    (the message up to its first ': ', numbers masked), so a flood of one bad field is one kind."""
    kind = getattr(error, 'kind', None)
    if kind:
        return str(kind)
    text = str(error)
    field = text.split(': ', 1)[0] if ': ' in text else text
    return f'{type(error).__name__}: {_NUMBERS.sub("#", field)[:80]}'


def stamp_nanoseconds(sec: int, nanosec: int, field: str = 'header.stamp', now_ns: int | None = None,
                      max_ahead: float = MAX_AHEAD_SECONDS) -> int:
    """The stamp in nanoseconds; MalformedInput naming ``field`` when it is negative, its nanosec is out
    of range, or (given the receiver's time ``now_ns``: see :func:`reference_time`) it lies more than
    ``max_ahead`` s ahead."""
    if sec < 0:
        raise MalformedInput(f'{field}.sec: must be >= 0 (got {sec})', kind=f'{field}: negative')
    if not 0 <= nanosec < NANOSECONDS:
        raise MalformedInput(f'{field}.nanosec: must be in [0, 999999999] (got {nanosec})',
                             kind=f'{field}: nanosec out of range')
    stamp = int(sec) * NANOSECONDS + int(nanosec)
    if now_ns is not None and stamp - now_ns > max_ahead * NANOSECONDS:
        raise MalformedInput(f'{field}: {stamp / NANOSECONDS:.9g} s is {(stamp - now_ns) / NANOSECONDS:.3g} s '
                             f'ahead of this node\'s clock (at most {max_ahead:g} s)', kind=f'{field}: far ahead')
    return stamp


def reference_time(clock_ns: int, wall_ns: int) -> int:
    """What a stamp is judged against: the receiving node's clock, or the wall clock while a simulated
    clock has not started (0: a latched message can come before the first /clock). Simulated time
    starts at 0 and stays far behind the wall clock, so a stamp beyond today is invalid on any clock."""
    return clock_ns if clock_ns > 0 else wall_ns


class ClockFilter:
    """The /clock messages a simulated clock follows.

    Refused: a negative or out-of-range stamp, and a jump more than ``max_ahead`` s ahead of the
    last accepted time, unless ``confirmations`` consecutive messages confirm it (each at most
    ``max_ahead`` ahead of the one before, none going back): a clock source that really moved on.
    Going back is accepted (a reset simulation restarts at 0), and so is any first message.
    """

    def __init__(self, max_ahead: float = MAX_AHEAD_SECONDS, confirmations: int = CLOCK_CONFIRMATIONS):
        self.max_ahead_ns = int(max_ahead * NANOSECONDS)
        self.confirmations = confirmations
        self.last_ns: int | None = None
        self._ahead_ns: int | None = None     # the last refused jump ahead, while more confirm it
        self._ahead_count = 0

    def accept(self, sec: int, nanosec: int) -> int:
        """The clock's new time in nanoseconds, or MalformedInput."""
        stamp = stamp_nanoseconds(sec, nanosec, 'clock')
        if self.last_ns is not None and stamp - self.last_ns > self.max_ahead_ns:
            ahead = self._ahead_ns
            consistent = ahead is not None and 0 <= stamp - ahead <= self.max_ahead_ns
            self._ahead_count = self._ahead_count + 1 if consistent else 1
            self._ahead_ns = stamp
            if self._ahead_count < self.confirmations:
                raise MalformedInput(f'clock: {stamp / NANOSECONDS:.9g} s jumps '
                                     f'{(stamp - self.last_ns) / NANOSECONDS:.3g} s ahead of the clock '
                                     f'(at most {self.max_ahead_ns / NANOSECONDS:g} s)', kind='clock: far ahead')
        self._ahead_ns, self._ahead_count = None, 0
        self.last_ns = stamp
        return stamp
