"""When an unanswered message copy is re-sent and when its sender gives up (no ROS): the
retry policy and what a sender tracks per recipient (see :mod:`.reliable_channel` for the rules).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from collab_tools.core.fields import Fields

from ..errors import ConfigError
from .codec import ChannelMessage

#: a deadline that never comes
NEVER = math.inf


@dataclass(frozen=True)
class RetryPolicy:
    """When an unanswered message is re-sent and when the sender gives up (module docstring).

    Defaults: ``reorder_window_s`` 50 ms, well above the paper's delay spread (3.85 +- 5.05 ms:
    two batches overtake each other by ~25 ms at most); ``tail_timeout_s`` 1.5 s before the
    first round trip is measured (above the ~1 s processing lag of a busy agent in the column
    of 10, so that only a loss makes it expire), then the measured timeout, at least
    ``min_timeout_s`` 0.2 s; doubling up to ``max_timeout_s`` 8 s; ``peer_timeout_s`` 10 s of
    silence before a peer is given up; ``stall_s`` 0.5 s: a longer gap between two polls is time
    this robot did not listen, not counted against peers; ``message_lifetime_s`` 30 s; ``duplicate_memory_s``
    (default: the lifetime plus 1 s for the last retry in flight) must outlast every retry of
    a message, or a late retry would be delivered again.
    """

    reorder_window_s: float = 0.05
    tail_timeout_s: float = 1.5
    min_timeout_s: float = 0.2
    backoff: float = 2.0
    max_timeout_s: float = 8.0
    peer_timeout_s: float = 10.0
    message_lifetime_s: float = 30.0
    duplicate_memory_s: float | None = None
    stall_s: float = 0.5

    FIELDS = ('reorder_window_s', 'tail_timeout_s', 'min_timeout_s', 'backoff', 'max_timeout_s', 'peer_timeout_s',
              'message_lifetime_s', 'duplicate_memory_s', 'stall_s')

    def __post_init__(self) -> None:
        checks = (('reorder_window_s', self.reorder_window_s, 'a number >= 0', lambda v: v >= 0),
                  ('tail_timeout_s', self.tail_timeout_s, 'a number > 0', lambda v: v > 0),
                  ('min_timeout_s', self.min_timeout_s, 'a number > 0', lambda v: v > 0),
                  ('backoff', self.backoff, 'a number >= 1', lambda v: v >= 1),
                  ('max_timeout_s', self.max_timeout_s,
                   f'a number >= tail_timeout_s = {self.tail_timeout_s!r} and >= min_timeout_s = {self.min_timeout_s!r}',
                   lambda v: v >= max(self.tail_timeout_s, self.min_timeout_s)),
                  ('peer_timeout_s', self.peer_timeout_s, 'a number > 0', lambda v: v > 0),
                  ('stall_s', self.stall_s, 'a number > 0', lambda v: v > 0),
                  ('message_lifetime_s', self.message_lifetime_s,
                   f'a number >= peer_timeout_s = {self.peer_timeout_s!r}', lambda v: v >= self.peer_timeout_s))
        for name, value, allowed, ok in checks:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not ok(value):
                raise ConfigError(f'retry.{name}: must be {allowed} (got {value!r})')
        memory = self.duplicate_memory_s
        if memory is None:
            object.__setattr__(self, 'duplicate_memory_s', self.message_lifetime_s + 1.0)
        elif isinstance(memory, bool) or not isinstance(memory, (int, float)) or not memory >= self.message_lifetime_s:
            raise ConfigError(f'retry.duplicate_memory_s: must be >= message_lifetime_s = '
                              f'{self.message_lifetime_s:g} s, the longest a message is retried (got {memory!r})')

    @classmethod
    def from_dict(cls, data: Any, path: str = 'retry') -> 'RetryPolicy':
        fields = Fields(data, path, cls.FIELDS, error=ConfigError)
        values = {key: fields.raw(key) for key in fields.allowed if fields.has(key)}
        try:
            return cls(**values)
        except ConfigError as exc:
            message = str(exc)
            raise ConfigError(path + message[len('retry'):] if message.startswith('retry.') else message) from None

    def tail_timeout(self, measured: float, expiries: int) -> float:
        """The tail-loss timeout after ``expiries`` expiries without an answer, the measured
        round-trip timeout being ``measured`` (0: no sample yet)."""
        base = self.tail_timeout_s if measured <= 0 else max(self.min_timeout_s, measured)
        return min(base * self.backoff ** expiries, self.max_timeout_s)


@dataclass
class PendingCopy:
    message: ChannelMessage
    first_sent: float
    last_sent: float
    #: when the first copy actually left (batches: :meth:`ReliableChannel.transmitted`); what an
    #: answer to it proves about copies sent before
    first_transmitted: float
    sends: int = 1
    #: when an answer proved this copy lost (fast retransmit after ``reorder_window_s`` more)
    lost_at: float | None = None


class RoundTripEstimate:
    """Smoothed round-trip time to one robot and its variation (RFC 6298, alpha 1/8, beta 1/4)."""

    def __init__(self) -> None:
        self.smoothed: float | None = None
        self.variation: float | None = None

    def add(self, sample: float) -> None:
        if self.smoothed is None:
            self.smoothed, self.variation = sample, sample / 2.0
        else:
            self.variation = 0.75 * self.variation + 0.25 * abs(self.smoothed - sample)
            self.smoothed = 0.875 * self.smoothed + 0.125 * sample

    def timeout(self) -> float:
        """SRTT + 4 RTTVAR (0 before the first sample)."""
        return 0.0 if self.smoothed is None else self.smoothed + 4.0 * self.variation


class Peer:
    """What a sender knows about one recipient: its unanswered copies (ordered by their last
    transmission), when it last answered, since when it owes an answer, the round trip and the
    tail-timeout back-off."""

    def __init__(self) -> None:
        self.pending: dict[int, PendingCopy] = {}
        self.suspects: set[int] = set()
        self.last_answer_at = -NEVER
        self.owing_since: float | None = None
        self.round_trip = RoundTripEstimate()
        self.expiries = 0

    def add(self, pending: PendingCopy, now: float) -> None:
        if not self.pending:
            self.owing_since = now
        self.pending[pending.message.message_id] = pending

    def remove(self, message_id: int) -> PendingCopy | None:
        pending = self.pending.pop(message_id, None)
        self.suspects.discard(message_id)
        if not self.pending:
            self.owing_since = None
        return pending

    def touch(self, pending: PendingCopy) -> None:
        """Move ``pending`` behind the others (it was just transmitted)."""
        self.pending[pending.message.message_id] = self.pending.pop(pending.message.message_id)

    def silent_since(self) -> float:
        """Since when the peer has owed an answer and given none."""
        return max(self.last_answer_at, self.owing_since if self.owing_since is not None else NEVER)


@dataclass
class SeenMessage:
    time: float
    reply: ChannelMessage | None


__all__ = ['NEVER', 'Peer', 'PendingCopy', 'RetryPolicy', 'RoundTripEstimate', 'SeenMessage']
