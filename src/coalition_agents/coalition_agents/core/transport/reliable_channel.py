"""Reliable delivery and request-and-wait commitments over a lossy agent channel (no ROS).

The paper assumes every robot can always reach every other (Section IV-H) and its search-time
bound (1) assumes no message loss; the issue requires that "requests are retried when messages
are lost" and that "no robot commits to two conflicting coalitions". This module is the part of
an agent that makes both true, independent of the transport: every call takes the current
time ``now`` (seconds, any clock -- sim time in the node, a fake clock in tests) and returns the
messages to put on the wire; nothing here sleeps, spawns timers or draws random numbers.

Delivery (:class:`ReliableChannel`; TCP's fast retransmit and selective repeat, per peer)
    * A message of a kind in :data:`~.codec.ACKNOWLEDGED_KINDS` is sent as one copy per
      recipient (a broadcast REQUEST goes to every teammate; each link may lose its copy) and
      each copy is kept until that recipient answers -- with an ACK, or for a COMMIT_REQUEST with
      COMMIT_ACCEPT / COMMIT_REJECT.
    * A copy is re-sent only when it is *known lost* (fast retransmit): an answer has arrived
      from the same peer for a copy transmitted at least ``reorder_window_s`` after this copy's
      last transmission, and the copy is still unanswered ``reorder_window_s`` after that answer
      arrived. A receiver handles its inbox in order, so a later copy's answer means this one
      was not merely queued; the two windows absorb the link's reordering on the way there and
      back (the paper's delay N(3.85 ms, 5.05 ms) spreads batches by ~25 ms at most; default
      50 ms). A receiver that is merely busy (its answers come late but in order) is never sent
      a copy again. Why: re-sending after a timeout shorter than a busy agent's processing lag
      sent every message of the column of 10 about seven times; the copies deepened the lag they
      were retrying.
    * Tail losses (nothing later was sent to, or answered by, that peer) fall back to a timeout
      per peer (RFC 6298): ``tail_timeout_s`` until a round trip has been measured, then the
      measured one (smoothed RTT + 4 x its variation, Karn's rule: only answers to copies sent
      once; at least ``min_timeout_s``) -- a busy receiver's answers come late, so its round
      trips include its processing lag -- restarted by every answer from the peer (a peer whose answers arrive is alive and working through
      its inbox), doubled at each expiry up to ``max_timeout_s`` and reset by the next answer.
      At expiry the copies to that peer unanswered for the timeout are re-sent.
    * A peer is given up -- every copy still waiting for it is reported :class:`Undelivered` --
      only when it has answered nothing at all for ``peer_timeout_s`` while it owed an answer.
      Retries are not counted against a peer whose answers keep arriving. Time this robot did not
      listen is not counted either: when :meth:`ReliableChannel.poll` has not run for more than
      ``stall_s`` (the process was busy, e.g. one agent's long evaluation stalled every agent of a
      host process), that gap is added to every peer's silence start and every copy's first send,
      since the answers that came meanwhile are still waiting unread in the inbox.
    * A retry keeps its message id. A receiver remembers (sender, message id) of every message
      it delivered, with the answer it gave, for ``duplicate_memory_s``: a duplicate is answered
      again (the ACK or the commitment answer may have been the message that was lost) but never
      delivered to the agent twice -- so a retried request is served exactly once. So that no
      retry outlives that memory, a copy is given up ``message_lifetime_s`` after its first
      send instead of being re-sent again.
    * The transport may batch copies (:mod:`.batching`): :meth:`ReliableChannel.transmitted`
      stamps the copies of a batch with the time the batch actually left, which is what the
      reordering rule compares.
    * Polling is cheap when nothing is due (ours): :meth:`ReliableChannel.poll_due` says when a
      poll can first have work -- the earliest deadline found by the last poll, or, if something
      changed since (a send, an answer, a transmission), that moment plus the shortest delay any
      change can put before a deadline (every deadline a change creates is at least
      ``reorder_window_s``, the smallest tail timeout or ``peer_timeout_s`` after it). A transport
      that polls every few milliseconds calls :meth:`ReliableChannel.listen` instead of
      :meth:`ReliableChannel.poll` before then (the stall rule still sees every call): same
      retries at the same times, without walking every peer at every tick.

Commitments: :mod:`.commitments`; retry policy and per-peer state: :mod:`.retry`.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Iterable, Sequence

from ..errors import ConfigError, RequestError
from .codec import (
    COMMIT_ANSWERS, ChannelMessage, MessageKind, commit_request_message, release_message, reply_message,
)
from .commitments import CommitmentLedger, Negotiation
from .retry import NEVER, PendingCopy, Peer, RetryPolicy, SeenMessage


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
    #: for a delivered COMMIT_REQUEST: whether this robot accepted it, and why not
    accepted: bool | None = None
    reason: str = ''


@dataclass
class ChannelStats:
    """Counters for experiments (AgentStatus)."""

    sent: int = 0           # message copies handed to the transport (first sends)
    resent: int = 0         # retries (fast_resent + tail_resent)
    fast_resent: int = 0    # retries of copies known lost (a later copy to the same peer was answered)
    tail_resent: int = 0    # retries after the tail-loss timeout
    replies: int = 0        # ACKs and commitment answers sent
    answered: int = 0       # copies whose answer arrived
    undelivered: int = 0    # copies given up
    delivered: int = 0      # messages delivered to the agent
    duplicates: int = 0     # duplicate messages received
    ignored: int = 0        # messages for other robots, own echoes, stale answers
    stalls: int = 0         # polls after a gap longer than stall_s (time not counted against peers)

    def to_dict(self) -> dict:
        return dict(self.__dict__)


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
        self._peers: dict[str, Peer] = {}
        self._seen: dict[tuple[str, int], SeenMessage] = {}
        self._answers_seen: set[tuple[str, int]] = set()
        #: (coalition id, leader) -> when its RELEASE arrived: a COMMIT_REQUEST delayed past its
        #: RELEASE must not commit this robot to a coalition its leader has given up
        self._released: dict[tuple[str, str], float] = {}
        self._last_poll: float | None = None
        #: no poll has work before this (see poll_due); a change since the last poll brings it forward
        self._due = -NEVER
        policy = self.policy
        #: the shortest time from a change to a deadline it creates (see the module docstring)
        self._change_gap = min(policy.reorder_window_s, policy.min_timeout_s, policy.tail_timeout_s,
                               policy.peer_timeout_s)

    def new_id(self) -> int:
        return next(self._ids)

    def _peer(self, robot: str) -> Peer:
        peer = self._peers.get(robot)
        if peer is None:
            peer = self._peers[robot] = Peer()
        return peer

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
                self._peer(copy.receiver).add(PendingCopy(copy, now, now, now), now)
        if message.needs_ack:
            self._changed(now)
        self.stats.sent += len(copies)
        return copies

    def transmitted(self, receiver: str, message_ids: Iterable[int], now: float) -> None:
        """The transport put these copies to ``receiver`` on the wire at ``now`` (one batch): the
        reordering rule compares transmission times, not the times the agent queued them."""
        peer = self._peers.get(receiver)
        if peer is None:
            return
        self._changed(now)
        for message_id in message_ids:
            pending = peer.pending.get(message_id)
            if pending is None or pending.last_sent >= now:
                continue
            if pending.sends == 1:
                pending.first_transmitted = now
            pending.last_sent = now
            peer.touch(pending)

    def tail_timeout(self, robot: str) -> float:
        """The current tail-loss timeout towards ``robot`` (module docstring)."""
        peer = self._peers.get(robot)
        if peer is None:
            return self.policy.tail_timeout(0.0, 0)
        return self.policy.tail_timeout(peer.round_trip.timeout(), peer.expiries)

    def round_trip(self, robot: str) -> float | None:
        """The smoothed round-trip time to ``robot`` (None before the first sample)."""
        peer = self._peers.get(robot)
        return None if peer is None else peer.round_trip.smoothed

    def awaiting(self, message_id: int) -> tuple[str, ...]:
        """The recipients of ``message_id`` that have not answered yet."""
        return tuple(robot for robot, peer in self._peers.items() if message_id in peer.pending)

    def cancel(self, message_id: int) -> int:
        """Stop retrying ``message_id`` (e.g. a request whose search time is over); copies dropped."""
        return sum(peer.remove(message_id) is not None for peer in self._peers.values())

    def _changed(self, now: float) -> None:
        """Something a deadline depends on changed at ``now`` (see :meth:`poll_due`)."""
        if now + self._change_gap < self._due:
            self._due = now + self._change_gap

    def poll_due(self) -> float:
        """When :meth:`poll` can first have something to do: :meth:`poll` before then returns
        nothing (so :meth:`listen` does instead). Never later than :meth:`next_deadline`."""
        return self._due

    def has_pending(self) -> bool:
        """Whether some copy waits for its answer (:meth:`next_deadline` is finite)."""
        return any(peer.pending for peer in self._peers.values())

    def listen(self, now: float) -> None:
        """A poll with nothing due (``now`` before :meth:`poll_due`): only the stall rule, which
        must see every call of a transport that polls regularly."""
        if self._last_poll is not None and now - self._last_poll > self.policy.stall_s:
            self._discount_stall(now - self._last_poll)
        self._last_poll = now

    def _discount_stall(self, gap: float) -> None:
        """This robot did not poll for ``gap`` s: shift what judges its peers by that much."""
        self.stats.stalls += 1
        for peer in self._peers.values():
            if math.isfinite(peer.last_answer_at):
                peer.last_answer_at += gap
            if peer.owing_since is not None:
                peer.owing_since += gap
            for pending in peer.pending.values():
                pending.first_sent += gap

    def _tail_deadline(self, peer: Peer) -> float:
        if not peer.pending:
            return NEVER
        oldest = next(iter(peer.pending.values())).last_sent
        return max(oldest, peer.last_answer_at) + self.policy.tail_timeout(peer.round_trip.timeout(), peer.expiries)

    def next_deadline(self) -> float:
        """When :meth:`poll` has something to do next (inf: nothing pending)."""
        deadlines = [NEVER]
        for peer in self._peers.values():
            if not peer.pending:
                continue
            deadlines.append(self._tail_deadline(peer))
            deadlines.append(peer.silent_since() + self.policy.peer_timeout_s)
            deadlines.extend(peer.pending[mid].lost_at + self.policy.reorder_window_s for mid in peer.suspects)
        return min(deadlines)

    def poll(self, now: float) -> tuple[list[ChannelMessage], list[Undelivered]]:
        """(copies to re-send now, copies given up). Failed commit requests fail their
        negotiation (:meth:`release` then frees the helpers)."""
        resend: list[ChannelMessage] = []
        failed: list[Undelivered] = []
        policy = self.policy
        self.listen(now)
        for robot, peer in self._peers.items():
            if not peer.pending:
                continue
            if now - peer.silent_since() >= policy.peer_timeout_s:
                # Silent for peer_timeout while it owed answers: the peer is gone.
                for message_id in list(peer.pending):
                    pending = peer.remove(message_id)
                    failed.append(Undelivered(pending.message, pending.sends))
                continue
            due: list[PendingCopy] = []
            for message_id in list(peer.suspects):
                pending = peer.pending[message_id]
                if now >= pending.lost_at + policy.reorder_window_s:
                    due.append(pending)
            self.stats.fast_resent += len(due)
            if now >= self._tail_deadline(peer):
                timeout = policy.tail_timeout(peer.round_trip.timeout(), peer.expiries)
                tail = []
                for pending in peer.pending.values():   # ordered by last transmission
                    if pending.last_sent > now - timeout:
                        break
                    if pending.lost_at is None:
                        tail.append(pending)
                # Nothing answered for a whole timeout: back off until the next answer (RFC 6298 5.5).
                peer.expiries += 1
                self.stats.tail_resent += len(tail)
                due.extend(tail)
            for pending in due:
                if now - pending.first_sent >= policy.message_lifetime_s:
                    peer.remove(pending.message.message_id)   # a later retry could outlive the receiver's memory
                    failed.append(Undelivered(pending.message, pending.sends))
                    continue
                pending.sends += 1
                pending.last_sent = now
                pending.lost_at = None
                peer.suspects.discard(pending.message.message_id)
                peer.touch(pending)
                resend.append(pending.message)
        self.stats.resent += len(resend)
        self.stats.undelivered += len(failed)
        for undelivered in failed:
            message = undelivered.message
            negotiation = self.negotiations.get(message.coalition_id)
            if message.kind is MessageKind.COMMIT_REQUEST and negotiation is not None:
                negotiation.rejected.setdefault(message.receiver, 'no answer')
        horizon = now - (self.policy.duplicate_memory_s or 0.0)
        if self._seen and next(iter(self._seen.values())).time < horizon:
            for key in [key for key, seen in self._seen.items() if seen.time < horizon]:
                del self._seen[key]
        for key in [key for key, time in self._released.items() if time < horizon]:
            del self._released[key]
        self._due = self.next_deadline()
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
            received.accepted, received.reason = accepted, reason
            reply = reply_message(MessageKind.COMMIT_ACCEPT if accepted else MessageKind.COMMIT_REJECT,
                                  self.new_id(), self.robot, message, coalition_id=message.coalition_id,
                                  reason=reason)
        else:
            if message.kind is MessageKind.RELEASE:
                self.ledger.release(message.coalition_id, message.sender, now)
                self._released[(message.coalition_id, message.sender)] = now
            if message.needs_ack:
                reply = reply_message(MessageKind.ACK, self.new_id(), self.robot, message)
        self._seen[message.key] = SeenMessage(now, reply)
        if reply is not None:
            received.replies.append(reply)
            self.stats.replies += 1
        self.stats.delivered += 1
        return received

    def _answer_duplicate(self, message: ChannelMessage, seen: SeenMessage, now: float) -> ChannelMessage | None:
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
        peer = self._peer(message.sender)
        pending = peer.remove(message.in_reply_to)
        self._changed(now)
        # The peer is alive and working through its inbox: restart its tail timer, end the back-off.
        peer.last_answer_at = now
        peer.expiries = 0
        if pending is not None:
            self.stats.answered += 1
            if pending.sends == 1:  # Karn: an answer to a re-sent message is ambiguous, no sample
                peer.round_trip.add(max(now - pending.last_sent, 0.0))
            # Fast retransmit: copies transmitted reorder_window before the answered one are lost
            # (confirmed if still unanswered reorder_window from now; see the module docstring).
            proof = pending.first_transmitted - self.policy.reorder_window_s
            for earlier in peer.pending.values():   # ordered by last transmission
                if earlier.last_sent > proof:
                    break
                if earlier.lost_at is None:
                    earlier.lost_at = now
                    peer.suspects.add(earlier.message.message_id)
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
        (negotiation, COMMIT_REQUEST copies to send, '') or (None, [], why not) when this robot's
        commitments do not admit it (:class:`~.commitments.CommitmentLedger`)."""
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
        for peer in self._peers.values():
            for message_id, pending in list(peer.pending.items()):
                if pending.message.kind is MessageKind.COMMIT_REQUEST and pending.message.coalition_id == coalition_id:
                    peer.remove(message_id)
        self.ledger.release(coalition_id, self.robot, now)
        messages = []
        for helper in negotiation.helpers:
            messages.extend(self.send(release_message(self.robot, self.new_id(), helper, coalition_id, reason), now))
        return messages


__all__ = ['ChannelStats', 'Received', 'ReliableChannel', 'Undelivered']
