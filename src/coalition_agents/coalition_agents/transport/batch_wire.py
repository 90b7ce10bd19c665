"""Channel messages <-> coalition_interfaces messages (the agent channel's ROS adapter, no node).

* :func:`to_ros` / :func:`from_ros` -- one ``AgentMessage`` (the shared topic's single messages,
  for tools and tests) and the codec's dict form;
* :func:`batch_to_ros` / :func:`batch_from_ros` -- a core batch and the columnar
  ``AgentMessageBatch`` (:mod:`..core.transport.batch_columns`: one array per field, so a batch
  converts in one step instead of one Python object per nested message);
* :func:`peek_addresses` (:mod:`.batch_cdr`) -- the ``sender`` and ``recipient`` of a serialized
  ``AgentMessageBatch`` read from its first bytes (CDR), so that an agent process drops the batches for robots it does
  not host (and those it delivered in-process) without deserialising them (every process
  subscribes to the one team topic).
"""
from __future__ import annotations

from coalition_interfaces.msg import AgentMessage, AgentMessageBatch, ChainLink, Information, NamedValue

from ..core.transport.batch_columns import COLUMNS, encode_batch
from .batch_cdr import peek_addresses
from ..core.transport.batching import Batch
from ..core.transport.codec import KIND_FIELDS, ChannelMessage, MessageKind


def to_ros(message: ChannelMessage, stamp=None) -> AgentMessage:
    """The AgentMessage of a channel message (fields unused by its kind stay empty)."""
    data = message.to_dict()
    msg = AgentMessage()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.message_id = message.message_id
    msg.sender = message.sender
    msg.receiver = message.receiver
    msg.kind = int(message.kind)
    msg.conversation_id = message.conversation_id
    msg.in_reply_to = message.in_reply_to
    if 'label' in data:
        msg.label = _information(data['label'])
    if 'chain' in data:
        msg.chain = [ChainLink(requester=link['requester'], label=_information(link['label']))
                     for link in data['chain']]
    if 'instance' in data:
        msg.instance = _information(data['instance'])
    if 'cost' in data:
        msg.cost = float(data['cost'])
    if 'members' in data:
        msg.members = list(data['members'])
    msg.coalition_id = data.get('coalition_id', '')
    msg.hold_seconds = float(data.get('hold_seconds', 0.0))
    msg.reason = data.get('reason', '')
    if 'values' in data:
        msg.values = [NamedValue(name=entry['name'], value=entry['value']) for entry in data['values']]
    return msg


def from_ros(msg: AgentMessage) -> dict:
    """The codec's dict form of an AgentMessage: the common fields and those of its kind. An
    unknown kind keeps only the common fields (the codec rejects it, naming the kind)."""
    data = {'kind': int(msg.kind), 'message_id': int(msg.message_id), 'sender': msg.sender,
            'receiver': msg.receiver, 'conversation_id': int(msg.conversation_id),
            'in_reply_to': int(msg.in_reply_to)}
    try:
        fields = KIND_FIELDS[MessageKind(msg.kind)]
    except ValueError:
        return data
    readers = {
        'label': lambda: _information_dict(msg.label),
        'chain': lambda: [{'requester': link.requester, 'label': _information_dict(link.label)} for link in msg.chain],
        'instance': lambda: _information_dict(msg.instance),
        'cost': lambda: float(msg.cost),
        'members': lambda: list(msg.members),
        'coalition_id': lambda: msg.coalition_id,
        'hold_seconds': lambda: float(msg.hold_seconds),
        'reason': lambda: msg.reason,
        'values': lambda: [{'name': entry.name, 'value': float(entry.value)} for entry in msg.values],
    }
    for name in fields:
        data[name] = readers[name]()
    return data


def _information(data: dict) -> Information:
    return Information(type=data['type'], referents=list(data['referents']))


def _information_dict(info: Information) -> dict:
    return {'type': info.type, 'referents': list(info.referents)}


def batch_to_ros(batch: Batch) -> AgentMessageBatch:
    """The AgentMessageBatch (columns) of a core batch."""
    return AgentMessageBatch(**encode_batch(batch))


def batch_from_ros(msg: AgentMessageBatch) -> dict:
    """The dict form :func:`~..core.transport.batch_columns.decode_columns` reads."""
    data = {name: getattr(msg, name) for name in COLUMNS}
    data.update(sender=msg.sender, recipient=msg.recipient, sequence=int(msg.sequence), session=int(msg.session),
                acked_ids=msg.acked_ids)
    return data


def peek_recipient(data: bytes) -> str | None:
    """The recipient of a serialized AgentMessageBatch (:func:`peek_addresses`), or None."""
    addresses = peek_addresses(data)
    return None if addresses is None else addresses[1]


__all__ = ['batch_from_ros', 'batch_to_ros', 'from_ros', 'peek_addresses', 'peek_recipient', 'to_ros']
