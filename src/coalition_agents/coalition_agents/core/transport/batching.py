"""Aggregation of the agent channel: one transport message per recipient per processing step (no ROS).

Why: the IQ-ASyMTRe search is message-heavy (the Fig. 9 column of 10 robots needs ~6,000
logical messages, each acknowledged). Carried one by one, the transport's fixed cost per message
(serialisation, executor dispatch, a wait-set rebuild per callback) -- not the algorithm --
dominated the search time. The standard fix is aggregation, which leaves the algorithm and the
reliable channel (:mod:`.reliable_channel`: ids, retries, exactly-once, commitments) unchanged:

* :class:`Outbox`: an agent puts every outgoing logical message (:class:`~.codec.ChannelMessage`)
  into a per-recipient buffer and at the end of its processing step takes them out as one
  :class:`Batch` per recipient. An ACK is not a message of its own: its acknowledged id rides in
  ``acked_ids`` of the next batch to that robot (piggybacked). A recipient with only acks waiting
  gets an ack-only batch once the oldest has waited ``ack_delay_s`` (if nothing else went there
  in the meantime) -- well below the retry timeout, so piggybacking never causes a retry.
* Commitment messages (:data:`URGENT_KINDS`: COMMIT_REQUEST, COMMIT_ACCEPT, COMMIT_REJECT,
  RELEASE) make :meth:`Outbox.put` report the recipient urgent: the caller flushes it at once,
  and :func:`processing_order` puts them first in a batch, so a negotiation is never queued
  behind a burst of requests and offers.
* :func:`decode_batch` turns a received batch (dict form, as the ROS adapter builds it from
  ``coalition_interfaces/AgentMessageBatch``) into the messages to hand to
  :meth:`~.reliable_channel.ReliableChannel.receive`: the piggybacked acks as ACK messages
  first, then the messages in :func:`processing_order`. A malformed batch header raises
  :class:`~..errors.RequestError` naming the field; a malformed message inside a batch is reported
  in :attr:`DecodedBatch.rejected` and the others are still delivered.
* :func:`local_messages`: the same for a batch handed over in-process (a teammate in the same
  agent process: no wire, no codec -- the sender checked its messages).
* :class:`InboxQueue`: what the receiver's reliable channel delivers waits here for the agent,
  negotiation messages before requests, offers and streamed values. The transport's callback
  only decodes a batch, acknowledges its messages and queues them; the agent takes from this
  queue, so the COMMIT/RELEASE messages of every batch received so far are handled before the
  search traffic queued ahead of them, and a negotiation never waits behind a search burst.

The link model applies per batch (the ROS adapter samples one delay and one loss per batch): a
lost batch loses all its messages and acks, and the reliable channel's retries re-send the
unacknowledged ones (each retry re-queues only the logical messages still unanswered). With a
loss probability p per batch, an experiment's loss is therefore per batch, not per logical
message.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any, Callable, Generic, Mapping, Sequence, TypeVar

from collab_tools.core.fields import type_name as describe_type

from .codec import MAX_MESSAGE_ID, ChannelCodec, ChannelMessage, MessageKind
from ..errors import ConfigError, RequestError

#: Negotiation messages: flushed at once and processed first within a batch.
URGENT_KINDS = frozenset({MessageKind.COMMIT_REQUEST, MessageKind.COMMIT_ACCEPT, MessageKind.COMMIT_REJECT,
                          MessageKind.RELEASE})


def processing_order(messages: Sequence[ChannelMessage]) -> list[ChannelMessage]:
    """``messages`` with the negotiation messages first (stable: each group keeps its order)."""
    return sorted(messages, key=lambda message: message.kind not in URGENT_KINDS)


def piggybacked_ack(sender: str, receiver: str, acked_id: int) -> ChannelMessage:
    """The ACK a piggybacked id stands for (``sender`` acknowledges ``receiver``'s message
    ``acked_id``). It has no id of its own (0): an ACK is never acknowledged or de-duplicated."""
    return ChannelMessage(MessageKind.ACK, 0, sender, receiver, in_reply_to=acked_id)


@dataclass(frozen=True)
class Batch:
    """The logical messages ``sender`` sends ``recipient`` in one transport message."""

    sender: str
    recipient: str
    sequence: int
    messages: tuple[ChannelMessage, ...]
    acked_ids: tuple[int, ...] = ()
    #: the sender's session (:mod:`.liveness`; 0 = none)
    session: int = 0

    @property
    def logical_count(self) -> int:
        """Logical messages carried: the messages plus the piggybacked ACKs."""
        return len(self.messages) + len(self.acked_ids)


@dataclass
class _Buffer:
    messages: list[ChannelMessage] = field(default_factory=list)
    acked_ids: list[int] = field(default_factory=list)
    acks_since: float | None = None


@dataclass
class OutboxStats:
    batches: int = 0           # batches taken out of the outbox
    messages: int = 0          # logical messages (not ACKs) in them
    acks: int = 0              # ACKs piggybacked or in ack-only batches
    ack_only_batches: int = 0  # batches that carried only ACKs
    heartbeats: int = 0        # empty batches (:meth:`Outbox.heartbeat`)

    def to_dict(self) -> dict:
        return dict(self.__dict__)


class Outbox:
    """Per-recipient buffers of one robot's outgoing messages (see the module docstring)."""

    def __init__(self, robot: str, ack_delay_s: float = 0.01, session: int = 0):
        if not isinstance(robot, str) or not robot:
            raise ConfigError(f'robot: must be a robot name (got {robot!r})')
        if isinstance(ack_delay_s, bool) or not isinstance(ack_delay_s, (int, float)) or not ack_delay_s >= 0:
            raise ConfigError(f'ack_delay_s: must be a number >= 0 (got {ack_delay_s!r})')
        self.robot = robot
        self.ack_delay_s = float(ack_delay_s)
        self.session = session
        self.stats = OutboxStats()
        self._buffers: dict[str, _Buffer] = {}
        self._sequence: dict[str, int] = {}

    def put(self, message: ChannelMessage, now: float) -> bool:
        """Queue ``message`` (an ACK as a piggybacked id) for its receiver; True if it is a
        negotiation message, whose recipient the caller should :meth:`flush` now."""
        if message.sender != self.robot:
            raise RequestError(f'message.sender: the outbox of {self.robot} cannot send as {message.sender!r}')
        if not message.receiver or message.receiver == self.robot:
            raise RequestError(f'{message}: a batched message goes to one teammate (receiver {message.receiver!r})')
        buffer = self._buffers.setdefault(message.receiver, _Buffer())
        if message.kind is MessageKind.ACK:
            buffer.acked_ids.append(message.in_reply_to)
            if buffer.acks_since is None:
                buffer.acks_since = now
            return False
        buffer.messages.append(message)
        return message.kind in URGENT_KINDS

    def has_messages(self) -> bool:
        """True if some recipient has messages (not only ACKs) waiting."""
        return any(buffer.messages for buffer in self._buffers.values())

    def next_ack_due(self) -> float:
        """When the oldest ack-only buffer is due (inf: none waiting)."""
        return min((buffer.acks_since + self.ack_delay_s for buffer in self._buffers.values()
                    if buffer.acks_since is not None and not buffer.messages), default=float('inf'))

    def flush(self, now: float, recipients: Sequence[str] | None = None) -> list[Batch]:
        """The batches to send now: every recipient (of ``recipients``, default all) with
        messages, and those with only ACKs waiting for ``ack_delay_s`` or more."""
        batches = []
        for recipient in list(self._buffers if recipients is None else recipients):
            buffer = self._buffers.get(recipient)
            if buffer is None:
                continue
            if not buffer.messages and (buffer.acks_since is None or now - buffer.acks_since < self.ack_delay_s):
                continue
            del self._buffers[recipient]
            batches.append(self._batch(recipient, buffer))
        return batches

    def heartbeat(self, recipient: str) -> Batch:
        """A batch for ``recipient`` now, whatever waits for it: what is buffered, else nothing (an
        empty batch: a heartbeat, :mod:`.liveness`)."""
        return self._batch(recipient, self._buffers.pop(recipient, None) or _Buffer())

    def _batch(self, recipient: str, buffer: _Buffer) -> Batch:
        sequence = self._sequence.get(recipient, 0) + 1
        self._sequence[recipient] = sequence
        batch = Batch(self.robot, recipient, sequence, tuple(processing_order(buffer.messages)),
                      tuple(dict.fromkeys(buffer.acked_ids)), self.session)
        self.stats.batches += 1
        self.stats.messages += len(batch.messages)
        self.stats.acks += len(batch.acked_ids)
        self.stats.ack_only_batches += bool(batch.acked_ids) and not batch.messages
        self.stats.heartbeats += not batch.acked_ids and not batch.messages
        return batch


Item = TypeVar('Item')


class InboxQueue(Generic[Item]):
    """Received messages waiting for the agent, each with what the caller keeps beside it
    (e.g. the :class:`~.reliable_channel.Received`): :data:`URGENT_KINDS` first, then the rest,
    each group in arrival order."""

    def __init__(self) -> None:
        self._urgent: deque[tuple[ChannelMessage, Item]] = deque()
        self._other: deque[tuple[ChannelMessage, Item]] = deque()

    def put(self, message: ChannelMessage, item: Item) -> None:
        (self._urgent if message.kind in URGENT_KINDS else self._other).append((message, item))

    def pop(self) -> tuple[ChannelMessage, Item] | None:
        """The next message for the agent (None: empty)."""
        if self._urgent:
            return self._urgent.popleft()
        return self._other.popleft() if self._other else None

    def pop_urgent(self) -> tuple[ChannelMessage, Item] | None:
        """The next negotiation message (None: none waiting)."""
        return self._urgent.popleft() if self._urgent else None

    def __len__(self) -> int:
        return len(self._urgent) + len(self._other)

    def clear(self) -> None:
        self._urgent.clear()
        self._other.clear()


@dataclass
class DecodedBatch:
    """A received batch: ``messages`` to hand to the reliable channel in this order (the
    piggybacked ACKs first) and the ``rejected`` messages (their index and why)."""

    sender: str
    recipient: str
    sequence: int
    messages: list[ChannelMessage]
    rejected: list[tuple[int, str]]
    session: int = 0


def local_messages(batch: Batch) -> list[ChannelMessage]:
    """What the recipient's reliable channel gets from a batch delivered in-process (a teammate in
    the same agent process; no wire, no codec: the sender checked its messages): the piggybacked
    ACKs first, then the messages in processing order -- as :func:`decode_batch` returns them."""
    return [*(piggybacked_ack(batch.sender, batch.recipient, acked) for acked in batch.acked_ids),
            *processing_order(batch.messages)]


def decode_batch(codec: ChannelCodec, data: Any, robot: str,
                 message_reader: Callable[[Any], Any] = lambda item: item, path: str = 'batch') -> DecodedBatch:
    """Validate a received batch for ``robot`` (dict form: sender, recipient, sequence, messages,
    acked_ids). ``message_reader`` turns one item of ``messages`` into the codec's dict form (the
    ROS adapter's AgentMessage conversion). Raises RequestError for a malformed batch (unknown
    sender, another recipient, a bad acked id); a malformed message is rejected alone."""
    if not isinstance(data, Mapping):
        raise RequestError(f'{path}: must be a mapping (got {describe_type(data)})')
    for key in ('sender', 'recipient', 'sequence', 'messages', 'acked_ids'):
        if key not in data:
            raise RequestError(f'{path}.{key}: missing required field of a batch')
    sender = data['sender']
    if not isinstance(sender, str) or sender not in codec.catalog.robots or sender == robot:
        raise RequestError(f"{path}.sender: must be a teammate of {robot} (got {sender!r}; team: "
                           f"{', '.join(codec.robots)})")
    if data['recipient'] != robot:
        raise RequestError(f'{path}.recipient: this inbox is {robot}\'s (got {data["recipient"]!r})')
    sequence = data['sequence']
    if isinstance(sequence, bool) or not isinstance(sequence, int) or not 1 <= sequence <= MAX_MESSAGE_ID:
        raise RequestError(f'{path}.sequence: must be an integer in [1, 2^64 - 1] (got {sequence!r})')
    session = data.get('session', 0)
    if isinstance(session, bool) or not isinstance(session, int) or not 0 <= session <= MAX_MESSAGE_ID:
        raise RequestError(f'{path}.session: must be an integer in [0, 2^64 - 1] (got {session!r})')
    acked = list(data['acked_ids'])
    for index, acked_id in enumerate(acked):
        if isinstance(acked_id, bool) or not isinstance(acked_id, int) or not 1 <= acked_id <= MAX_MESSAGE_ID:
            raise RequestError(f'{path}.acked_ids[{index}]: must be a message id in [1, 2^64 - 1] (got {acked_id!r})')
    decoded = DecodedBatch(sender, robot, sequence, [piggybacked_ack(sender, robot, acked_id) for acked_id in acked], [],
                           session)
    messages = []
    for index, item in enumerate(data['messages']):
        item_path = f'{path}.messages[{index}]'
        try:
            message = codec.decode(message_reader(item), item_path)
        except (RequestError, ValueError, TypeError, KeyError) as exc:
            decoded.rejected.append((index, str(exc)))
            continue
        if message.sender != sender or message.receiver != robot:
            decoded.rejected.append((index, f'{item_path}: a message from {message.sender} to '
                                            f'{message.receiver or "everyone"} in the batch from {sender} to {robot}'))
            continue
        messages.append(message)
    decoded.messages.extend(processing_order(messages))
    return decoded


__all__ = ['Batch', 'DecodedBatch', 'InboxQueue', 'Outbox', 'OutboxStats', 'URGENT_KINDS', 'decode_batch', 'local_messages',
           'piggybacked_ack', 'processing_order']
