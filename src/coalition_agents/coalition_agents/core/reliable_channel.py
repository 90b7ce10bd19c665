"""Reliable delivery and request-and-wait commitments over a lossy agent channel (no ROS).

The paper assumes every robot can always reach every other (Section IV-H) and its search-time
bound (1) assumes no message loss; the issue requires that "requests are retried when messages
are lost" and that "no robot commits to two conflicting coalitions". This module is the part of
an agent that makes both true, independent of the transport: every call takes the current
time ``now`` (seconds, any clock -- sim time in the node, a fake clock in tests) and returns the
messages to put on the wire; nothing here sleeps, spawns timers or draws random numbers.

Delivery (:class:`ReliableChannel`)
    * A message of a kind in :data:`~.channel_codec.ACKNOWLEDGED_KINDS` is sent as one copy per
      recipient (a broadcast REQUEST goes to every teammate; each link may lose its copy) and
      each copy is kept until that recipient answers -- with an ACK, or for a COMMIT_REQUEST with
      COMMIT_ACCEPT / COMMIT_REJECT. Without an answer the copy is re-sent after
      ``ack_timeout_s * backoff^k`` (capped at ``max_timeout_s``); after ``max_retries`` re-sends it
      is reported :class:`Undelivered`.
    * The first timeout towards a robot adapts to the measured round trip (RFC 6298: smoothed
      round-trip time plus four times its variation, from answers to messages sent once -- Karn's
      rule), between ``ack_timeout_s`` and ``max_timeout_s``; ``ack_timeout_s`` until the first
      sample; a time-out doubles it for that robot until the next sample (RFC 6298 5.5). Why: during a search burst an agent answers after its processing lag, not the link
      delay; a fixed timeout below that lag re-sent every message several times (7 copies per
      message for the column of 10), and the copies deepened the lag they were retrying.
    * A retry keeps its message id. A receiver remembers (sender, message id) of every message
      it delivered, with the answer it gave, for ``duplicate_memory_s``: a duplicate is answered
      again (the ACK or the commitment answer may have been the message that was lost) but never
      delivered to the agent twice -- so a retried request is served exactly once.

Commitments (:class:`CommitmentLedger`, :class:`Negotiation`; the paper sets coalitions up
"using the same request-and-wait negotiation protocol as used in the distributed version of
ASyMTRe"; our rendering of it):
    * A robot holds at most one commitment: to the coalition it leads or to one coalition as a
      helper. A COMMIT_REQUEST for another coalition is rejected (with the reason) until that
      commitment is released or its hold time (``hold_seconds``, from the leader; 0 = until
      released) has passed without renewal. A new COMMIT_REQUEST for the coalition already
      held renews it.
    * The leader commits itself, sends COMMIT_REQUEST to every helper and waits. All accept:
      the coalition is *established*. One rejects or cannot be reached: the negotiation *failed*
      and the leader sends RELEASE to every helper (a helper whose ACCEPT was lost holds the
      commitment otherwise until it times out) and frees itself.
    * The leader's view of a helper's commitment ends ``hold_seconds`` after the leader *first*
      sent its request; the helper's starts when it first receives it, which is later -- so the
      leader never believes in a commitment the helper has already dropped. A duplicate
      COMMIT_REQUEST whose accepted commitment is no longer held is answered with a REJECT, and a
      COMMIT_REQUEST that arrives after the RELEASE of its coalition (links reorder messages) is
      rejected. Every negotiation therefore needs a new coalition id.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

from .channel_codec import (
    COMMIT_ANSWERS, ChannelMessage, MessageKind, commit_request_message, release_message, reply_message,
)
from .errors import ConfigError, RequestError
from .validation import Section

NEVER = math.inf


@dataclass(frozen=True)
class RetryPolicy:
    """When an unanswered message is re-sent and when the sender gives up.

    The defaults suit the paper's link (delay 3.85 +- 5.05 ms): the first retry after 50 ms
    (about 9 standard deviations above the mean delay of a round trip), doubling up to 1 s,
    6 retries -- 3.15 s before giving up. ``duplicate_memory_s`` (default: twice that plus 1 s)
    must outlast every retry of a message, or a late retry would be delivered again; the
    default is twice the longest give-up time (every timeout at ``max_timeout_s``, what the
    adaptive timeout can reach) plus 1 s.
    """

    ack_timeout_s: float = 0.05
    backoff: float = 2.0
    max_timeout_s: float = 1.0
    max_retries: int = 6
    duplicate_memory_s: float | None = None

    def __post_init__(self) -> None:
        checks = (('ack_timeout_s', self.ack_timeout_s, 'a number > 0', lambda v: v > 0),
                  ('backoff', self.backoff, 'a number >= 1', lambda v: v >= 1),
                  ('max_timeout_s', self.max_timeout_s, f'a number >= ack_timeout_s = {self.ack_timeout_s!r}',
                   lambda v: v >= self.ack_timeout_s))
        for name, value, allowed, ok in checks:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not ok(value):
                raise ConfigError(f'retry.{name}: must be {allowed} (got {value!r})')
        if isinstance(self.max_retries, bool) or not isinstance(self.max_retries, int) or self.max_retries < 0:
            raise ConfigError(f'retry.max_retries: must be an integer >= 0 (got {self.max_retries!r})')
        memory = self.duplicate_memory_s
        if memory is None:
            object.__setattr__(self, 'duplicate_memory_s', 2.0 * self.longest_give_up() + 1.0)
        elif isinstance(memory, bool) or not isinstance(memory, (int, float)) or not memory >= self.longest_give_up():
            raise ConfigError(f'retry.duplicate_memory_s: must be >= the time until a sender gives up at the '
                              f'longest timeouts, {self.longest_give_up():g} s (got {memory!r})')

    @classmethod
    def from_dict(cls, data: Any, path: str = 'retry') -> 'RetryPolicy':
        section = Section(data, path, ('ack_timeout_s', 'backoff', 'max_timeout_s', 'max_retries',
                                       'duplicate_memory_s'))
        values = {key: section.get(key) for key in section.allowed if key in section.data}
        try:
            return cls(**values)
        except ConfigError as exc:
            message = str(exc)
            raise ConfigError(path + message[len('retry'):] if message.startswith('retry.') else message) from None

    def timeout(self, attempt: int, first: float | None = None) -> float:
        """How long to wait for an answer after send number ``attempt`` (0 = the first send),
        the first wait being ``first`` (default ``ack_timeout_s``; the adaptive one otherwise)."""
        base = self.ack_timeout_s if first is None else first
        return min(base * self.backoff ** attempt, self.max_timeout_s)

    def give_up_after(self) -> float:
        """Seconds from the first send until the sender gives up on an unanswered message
        (with the initial timeout ``ack_timeout_s``)."""
        return sum(self.timeout(attempt) for attempt in range(self.max_retries + 1))

    def longest_give_up(self) -> float:
        """The same when the adaptive timeout has reached ``max_timeout_s``."""
        return (self.max_retries + 1) * self.max_timeout_s


@dataclass(frozen=True)
class Undelivered:
    """A message copy that ``receiver`` never answered, after ``attempts`` sends."""

    message: ChannelMessage
    attempts: int

    @property
    def receiver(self) -> str:
        return self.message.receiver


@dataclass
class Received:
    """What :meth:`ReliableChannel.receive` makes of a message: ``deliver`` (None for an ACK,
    a duplicate or a message for another robot) and the ``replies`` to send now."""

    deliver: ChannelMessage | None = None
    replies: list[ChannelMessage] = field(default_factory=list)
    duplicate: bool = False
    #: for a delivered COMMIT_REQUEST: whether this robot accepted it
    accepted: bool | None = None


@dataclass
class ChannelStats:
    """Counters for experiments (AgentStatus)."""

    sent: int = 0           # message copies handed to the transport (first sends)
    resent: int = 0         # retries
    replies: int = 0        # ACKs and commitment answers sent
    answered: int = 0       # copies whose answer arrived
    undelivered: int = 0    # copies given up
    delivered: int = 0      # messages delivered to the agent
    duplicates: int = 0     # duplicate messages received
    ignored: int = 0        # messages for other robots, own echoes, stale answers

    def to_dict(self) -> dict:
        return dict(self.__dict__)


# --- commitments ------------------------------------------------------------------------------

@dataclass(frozen=True)
class Commitment:
    """``robot`` is part of coalition ``coalition_id`` led by ``leader`` until ``expires_at``."""

    coalition_id: str
    leader: str
    members: tuple[str, ...]
    since: float
    expires_at: float

    def conflicts_with(self, coalition_id: str, leader: str) -> bool:
        return (self.coalition_id, self.leader) != (coalition_id, leader)


class CommitmentLedger:
    """The one commitment a robot may hold; ``history`` records every change (time, event, id)."""

    def __init__(self, robot: str):
        self.robot = robot
        self._current: Commitment | None = None
        self.history: list[tuple[float, str, str]] = []

    def active(self, now: float) -> Commitment | None:
        """The commitment held at ``now`` (an expired one is dropped)."""
        current = self._current
        if current is not None and now >= current.expires_at:
            self.history.append((now, 'expired', current.coalition_id))
            self._current = None
        return self._current

    def hold(self, coalition_id: str, leader: str, members: Sequence[str], now: float,
             hold_seconds: float = 0.0) -> tuple[bool, str]:
        """Commit to ``coalition_id`` (or renew it): (True, '') or (False, why not)."""
        current = self.active(now)
        if current is not None and current.conflicts_with(coalition_id, leader):
            return False, f'{self.robot} is committed to coalition {current.coalition_id} of {current.leader}'
        expires_at = now + hold_seconds if hold_seconds > 0 else NEVER
        self._current = Commitment(coalition_id, leader, tuple(members),
                                   now if current is None else current.since, expires_at)
        self.history.append((now, 'renewed' if current is not None else 'committed', coalition_id))
        return True, ''

    def holds(self, coalition_id: str, leader: str, now: float) -> bool:
        current = self.active(now)
        return current is not None and not current.conflicts_with(coalition_id, leader)

    def release(self, coalition_id: str, leader: str, now: float) -> bool:
        """Drop the commitment to ``coalition_id`` of ``leader``; False if it was not held."""
        if not self.holds(coalition_id, leader, now):
            return False
        self._current = None
        self.history.append((now, 'released', coalition_id))
        return True


@dataclass
class Negotiation:
    """A leader's request-and-wait negotiation of one coalition (see the module docstring)."""

    coalition_id: str
    leader: str
    members: tuple[str, ...]
    cost: float
    hold_seconds: float
    started: float
    accepted: set[str] = field(default_factory=set)
    rejected: dict[str, str] = field(default_factory=dict)
    released: bool = False

    @property
    def helpers(self) -> tuple[str, ...]:
        return tuple(robot for robot in self.members if robot != self.leader)

    @property
    def expires_at(self) -> float:
        return self.started + self.hold_seconds if self.hold_seconds > 0 else NEVER

    def state(self, now: float) -> str:
        """'waiting', 'established', 'failed' (a helper rejected or was unreachable), 'expired'
        (the hold time passed before all accepted, or since) or 'released'."""
        if self.released:
            return 'released'
        if self.rejected:
            return 'failed'
        if now >= self.expires_at:
            return 'expired'
        return 'established' if self.accepted >= set(self.helpers) else 'waiting'


# --- the channel --------------------------------------------------------------------------------

@dataclass
class _Pending:
    message: ChannelMessage
    attempts: int
    deadline: float
    sent_at: float = 0.0
    first_timeout: float = 0.0


class RoundTripEstimate:
    """Smoothed round-trip time to one robot and its variation (RFC 6298, alpha 1/8, beta 1/4)."""

    def __init__(self, sample: float | None = None):
        self.smoothed = self.variation = None if sample is None else sample
        if sample is not None:
            self.variation = sample / 2.0
        #: the timeout backed off by a time-out (RFC 6298 5.5), kept until the next valid sample
        self.backed_off = 0.0

    def add(self, sample: float) -> None:
        if self.smoothed is None:
            self.smoothed, self.variation = sample, sample / 2.0
        else:
            self.variation = 0.75 * self.variation + 0.25 * abs(self.smoothed - sample)
            self.smoothed = 0.875 * self.smoothed + 0.125 * sample
        self.backed_off = 0.0

    def timeout(self) -> float:
        measured = 0.0 if self.smoothed is None else self.smoothed + 4.0 * self.variation
        return max(measured, self.backed_off)


@dataclass
class _Seen:
    time: float
    reply: ChannelMessage | None


class ReliableChannel:
    """One robot's end of the agent channel: numbering, retries, duplicates and commitments.

    ``first_message_id`` lets an agent that restarts avoid the ids it used before (the node
    derives it from the clock), since receivers drop what they have seen from (sender, id).
    """

    def __init__(self, robot: str, policy: RetryPolicy | None = None, *, first_message_id: int = 1):
        if not isinstance(robot, str) or not robot:
            raise ConfigError(f'robot: must be a robot name (got {robot!r})')
        if isinstance(first_message_id, bool) or not isinstance(first_message_id, int) or first_message_id < 1:
            raise ConfigError(f'first_message_id: must be an integer >= 1 (got {first_message_id!r})')
        self.robot = robot
        self.policy = policy if policy is not None else RetryPolicy()
        self.ledger = CommitmentLedger(robot)
        self.stats = ChannelStats()
        self.negotiations: dict[str, Negotiation] = {}
        self._ids = itertools.count(first_message_id)
        self._pending: dict[tuple[int, str], _Pending] = {}
        self._seen: dict[tuple[str, int], _Seen] = {}
        self._answers_seen: set[tuple[str, int]] = set()
        self._round_trips: dict[str, RoundTripEstimate] = {}
        #: (coalition id, leader) -> when its RELEASE arrived: a COMMIT_REQUEST delayed past its
        #: RELEASE must not commit this robot to a coalition its leader has given up
        self._released: dict[tuple[str, str], float] = {}

    def new_id(self) -> int:
        return next(self._ids)

    # --- sending ---------------------------------------------------------------------------
    def send(self, message: ChannelMessage, now: float, recipients: Iterable[str] | None = None) -> list[ChannelMessage]:
        """The copies of ``message`` to put on the wire now, one per recipient (``recipients``
        for a broadcast: '' receiver; the message's receiver otherwise). Copies that need an
        answer are kept for retries. Sending to oneself is not the channel's job (footnote 10
        self-requests are answered locally) and is refused."""
        if message.sender != self.robot:
            raise RequestError(f'message.sender: {self.robot} cannot send as {message.sender!r}')
        if message.receiver:
            targets = [message.receiver]
        else:
            if recipients is None:
                raise RequestError(f'{message}: a broadcast needs its recipients (the team)')
            targets = list(dict.fromkeys(recipients))
        if self.robot in targets:
            raise RequestError(f'{message}: {self.robot} cannot send to itself over the channel')
        copies = [message.addressed_to(robot) for robot in targets]
        for copy in copies:
            if copy.needs_ack:
                first = self.first_timeout(copy.receiver)
                self._pending[(copy.message_id, copy.receiver)] = _Pending(copy, 1, now + first, now, first)
        self.stats.sent += len(copies)
        return copies

    def first_timeout(self, robot: str) -> float:
        """The wait for an answer from ``robot`` after a first send: adapted to the measured round
        trips (see the module docstring), within [ack_timeout_s, max_timeout_s]."""
        estimate = self._round_trips.get(robot)
        if estimate is None:
            return self.policy.ack_timeout_s
        return min(max(estimate.timeout(), self.policy.ack_timeout_s), self.policy.max_timeout_s)

    def round_trip(self, robot: str) -> float | None:
        """The smoothed round-trip time to ``robot`` (None before the first answer)."""
        estimate = self._round_trips.get(robot)
        return None if estimate is None else estimate.smoothed

    def awaiting(self, message_id: int) -> tuple[str, ...]:
        """The recipients of ``message_id`` that have not answered yet."""
        return tuple(receiver for (mid, receiver) in self._pending if mid == message_id)

    def cancel(self, message_id: int) -> int:
        """Stop retrying ``message_id`` (e.g. a request whose search time is over); copies dropped."""
        keys = [key for key in self._pending if key[0] == message_id]
        for key in keys:
            del self._pending[key]
        return len(keys)

    def next_deadline(self) -> float:
        """When :meth:`poll` has something to do next (inf: nothing pending)."""
        deadlines = [pending.deadline for pending in self._pending.values()]
        return min(deadlines, default=NEVER)

    def poll(self, now: float) -> tuple[list[ChannelMessage], list[Undelivered]]:
        """(copies to re-send now, copies given up). Failed commit requests fail their
        negotiation (:meth:`release` then frees the helpers)."""
        resend: list[ChannelMessage] = []
        failed: list[Undelivered] = []
        for key, pending in list(self._pending.items()):
            if now < pending.deadline:
                continue
            if pending.attempts > self.policy.max_retries:
                del self._pending[key]
                failed.append(Undelivered(pending.message, pending.attempts))
                self.stats.undelivered += 1
                continue
            pending.deadline = now + self.policy.timeout(pending.attempts, pending.first_timeout)
            # RFC 6298 5.5: the next first sends to this robot wait longer too, until an answer
            # to a message sent once gives a new sample (a busy receiver is not re-flooded).
            estimate = self._round_trips.setdefault(pending.message.receiver, RoundTripEstimate())
            estimate.backed_off = min(max(estimate.backed_off, pending.first_timeout) * self.policy.backoff,
                                      self.policy.max_timeout_s)
            pending.attempts += 1
            resend.append(pending.message)
        self.stats.resent += len(resend)
        for undelivered in failed:
            message = undelivered.message
            negotiation = self.negotiations.get(message.coalition_id)
            if message.kind is MessageKind.COMMIT_REQUEST and negotiation is not None:
                negotiation.rejected.setdefault(message.receiver, 'no answer')
        horizon = now - (self.policy.duplicate_memory_s or 0.0)
        for key in [key for key, seen in self._seen.items() if seen.time < horizon]:
            del self._seen[key]
        for key in [key for key, time in self._released.items() if time < horizon]:
            del self._released[key]
        return resend, failed

    # --- receiving ---------------------------------------------------------------------------
    def receive(self, message: ChannelMessage, now: float) -> Received:
        """Handle a decoded message from the wire (see :class:`Received`)."""
        if message.sender == self.robot or (message.receiver and message.receiver != self.robot):
            self.stats.ignored += 1
            return Received()
        if message.kind is MessageKind.ACK or message.kind in COMMIT_ANSWERS:
            return self._on_answer(message, now)
        if message.kind is MessageKind.INFORMATION:
            # Streamed values are never retried, so never duplicated: no memory of them is kept.
            self.stats.delivered += 1
            return Received(message)
        seen = self._seen.get(message.key)
        if seen is not None:
            self.stats.duplicates += 1
            reply = self._answer_duplicate(message, seen, now)
            if reply is not None:
                self.stats.replies += 1
            return Received(None, [reply] if reply is not None else [], duplicate=True)
        received = Received(message)
        reply: ChannelMessage | None = None
        if message.kind is MessageKind.COMMIT_REQUEST:
            if (message.coalition_id, message.sender) in self._released:
                accepted, reason = False, f'coalition {message.coalition_id} was released by {message.sender}'
            else:
                accepted, reason = self.ledger.hold(message.coalition_id, message.sender, message.members, now,
                                                    message.hold_seconds)
            received.accepted = accepted
            reply = reply_message(MessageKind.COMMIT_ACCEPT if accepted else MessageKind.COMMIT_REJECT,
                                  self.new_id(), self.robot, message, coalition_id=message.coalition_id,
                                  reason=reason)
        else:
            if message.kind is MessageKind.RELEASE:
                self.ledger.release(message.coalition_id, message.sender, now)
                self._released[(message.coalition_id, message.sender)] = now
            if message.needs_ack:
                reply = reply_message(MessageKind.ACK, self.new_id(), self.robot, message)
        self._seen[message.key] = _Seen(now, reply)
        if reply is not None:
            received.replies.append(reply)
            self.stats.replies += 1
        self.stats.delivered += 1
        return received

    def _answer_duplicate(self, message: ChannelMessage, seen: _Seen, now: float) -> ChannelMessage | None:
        reply = seen.reply
        if (reply is not None and reply.kind is MessageKind.COMMIT_ACCEPT
                and not self.ledger.holds(message.coalition_id, message.sender, now)):
            # The accepted commitment was released or expired since: do not confirm it again.
            reply = reply_message(MessageKind.COMMIT_REJECT, reply.message_id, self.robot, message,
                                  coalition_id=message.coalition_id,
                                  reason=f'{self.robot} no longer holds coalition {message.coalition_id}')
            seen.reply = reply
        return reply

    def _on_answer(self, message: ChannelMessage, now: float) -> Received:
        pending = self._pending.pop((message.in_reply_to, message.sender), None)
        if pending is not None:
            self.stats.answered += 1
            if pending.attempts == 1:  # Karn: an answer to a re-sent message is ambiguous, no sample
                sample = max(now - pending.sent_at, 0.0)
                self._round_trips.setdefault(message.sender, RoundTripEstimate()).add(sample)
        if message.kind is MessageKind.ACK:
            if pending is None:
                self.stats.ignored += 1
            return Received()
        # A commitment answer: deliver the first one per request (later ones answer retries).
        key = (message.sender, message.in_reply_to)
        if key in self._answers_seen:
            self.stats.duplicates += 1
            return Received(duplicate=True)
        self._answers_seen.add(key)
        negotiation = self.negotiations.get(message.coalition_id)
        if negotiation is not None and message.sender in negotiation.helpers and not negotiation.released:
            if message.kind is MessageKind.COMMIT_ACCEPT:
                negotiation.accepted.add(message.sender)
            else:
                negotiation.rejected[message.sender] = message.reason or 'rejected'
        self.stats.delivered += 1
        return Received(message)

    # --- request-and-wait ----------------------------------------------------------------------
    def propose(self, coalition_id: str, members: Sequence[str], cost: float, now: float,
                hold_seconds: float) -> tuple[Negotiation | None, list[ChannelMessage], str]:
        """Start negotiating coalition ``coalition_id`` (this robot leads, ``members`` include it):
        (negotiation, COMMIT_REQUEST copies to send, '') or (None, [], why not) when this robot
        holds another commitment."""
        if self.robot not in members:
            raise RequestError(f'members: the leader {self.robot} must be a member (got {list(members)})')
        if coalition_id in self.negotiations:
            # Helpers remember released ids; a reused id could be rejected as released.
            raise RequestError(f'coalition_id: {coalition_id!r} was already used by {self.robot} (use a new id '
                               f'for every negotiation)')
        accepted, reason = self.ledger.hold(coalition_id, self.robot, members, now, hold_seconds)
        if not accepted:
            return None, [], reason
        negotiation = Negotiation(coalition_id, self.robot, tuple(members), cost, hold_seconds, now)
        self.negotiations[coalition_id] = negotiation
        messages = []
        for helper in negotiation.helpers:
            request = commit_request_message(self.robot, self.new_id(), helper, coalition_id, members, cost,
                                             hold_seconds)
            messages.extend(self.send(request, now))
        return negotiation, messages, ''

    def release(self, coalition_id: str, now: float, reason: str = '') -> list[ChannelMessage]:
        """End the negotiation or coalition ``coalition_id``: RELEASE copies for every helper
        (each is retried until acknowledged) and this robot's own commitment dropped."""
        negotiation = self.negotiations.get(coalition_id)
        if negotiation is None or negotiation.released:
            return []
        negotiation.released = True
        for key, pending in list(self._pending.items()):
            if pending.message.kind is MessageKind.COMMIT_REQUEST and pending.message.coalition_id == coalition_id:
                del self._pending[key]
        self.ledger.release(coalition_id, self.robot, now)
        messages = []
        for helper in negotiation.helpers:
            messages.extend(self.send(release_message(self.robot, self.new_id(), helper, coalition_id, reason), now))
        return messages


__all__ = [
    'ChannelStats', 'Commitment', 'CommitmentLedger', 'Negotiation', 'Received', 'ReliableChannel', 'RetryPolicy',
    'RoundTripEstimate',
    'Undelivered',
]
