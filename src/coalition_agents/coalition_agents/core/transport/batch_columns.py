"""A batch as columns: the wire form of ``coalition_interfaces/AgentMessageBatch`` (no ROS).

Why: a batch of nested messages (one ``AgentMessage`` per logical message, each with a header,
labels and chain links) cost 71 us per typical batch to convert, serialise and deserialise, three
times an opaque byte payload -- most of it building and walking one Python object per nested
message. Stored column-wise (one array per field; entry i of every per-message column belongs to
logical message i, variable-length parts flattened in message order with a count per message) a
batch converts in one step and still reads as typed fields in ``ros2 topic echo`` and rosbag.
The layout is documented in ``AgentMessageBatch.msg``; :data:`COLUMNS` names the fields.

* :func:`encode_batch` -- a core :class:`~.batching.Batch` as a dict of columns (the message's
  field names; lists of numbers and strings);
* :func:`decode_columns` -- a received batch's columns validated for one robot: the header and the
  column lengths (a batch whose columns disagree is refused whole, :class:`~..errors.RequestError`
  naming the column), then each message through the codec (:func:`~.batching.decode_batch`: a
  malformed message is rejected alone, named ``batch.messages[i].<field>``);
* :func:`message_rows` -- (kind, members, cost) per message, as the bag analysis reads them.
"""
from __future__ import annotations

from typing import Any, Iterator, Mapping, Sequence

from collab_tools.core.fields import type_name as describe_type

from .batching import Batch, DecodedBatch, decode_batch
from .codec import KIND_FIELDS, ChannelCodec, ChannelMessage, MessageKind
from ..errors import RequestError

#: Per-message columns (one entry per logical message).
MESSAGE_COLUMNS = ('kinds', 'message_ids', 'conversation_ids', 'in_reply_to', 'costs', 'hold_seconds',
                   'coalition_ids', 'reasons', 'information_counts', 'chain_lengths', 'member_counts',
                   'value_counts')
#: Flattened columns, and the per-message (or per-entry) count column that sizes each.
FLAT_COLUMNS = {'information_types': 'information_counts', 'referent_counts': 'information_counts',
                'referents': 'referent_counts', 'chain_requesters': 'chain_lengths', 'members': 'member_counts',
                'value_names': 'value_counts', 'values': 'value_counts'}
#: Every column of the batch besides the header fields (sender, recipient, sequence, acked_ids).
COLUMNS = MESSAGE_COLUMNS + tuple(FLAT_COLUMNS)
#: Largest count a uint8 count column holds.
MAX_COUNT = 255


def _information(columns: dict, instance) -> None:
    referents = [str(r) for r in instance.referents]
    columns['information_types'].append(instance.label)
    columns['referent_counts'].append(len(referents))
    columns['referents'].extend(referents)


def encode_batch(batch: Batch) -> dict[str, Any]:
    """The columns of ``batch`` (plus sender, recipient, sequence, session, acked_ids) as lists."""
    columns: dict[str, Any] = {name: [] for name in COLUMNS}
    for message in batch.messages:
        _encode_message(columns, message)
    columns.update(sender=batch.sender, recipient=batch.recipient, sequence=batch.sequence, session=batch.session,
                   acked_ids=list(batch.acked_ids))
    return columns


def _encode_message(columns: dict, message: ChannelMessage) -> None:
    kind = message.kind
    infos: list = []
    chain: Sequence = ()
    members: Sequence[str] = ()
    cost = message.cost
    values: Sequence = ()
    if kind is MessageKind.REQUEST:
        infos = [message.request.label, *(label for _, label in message.request.chain)]  # type: ignore[union-attr]
        chain = [robot for robot, _ in message.request.chain]  # type: ignore[union-attr]
    elif kind is MessageKind.OFFER:
        offer = message.offer
        infos = [offer.request, offer.instance]  # type: ignore[union-attr]
        members, cost = offer.members, offer.cost  # type: ignore[union-attr]
    elif kind is MessageKind.COMMIT_REQUEST:
        members = message.members
    elif kind is MessageKind.INFORMATION:
        infos = [message.instance]
        values = message.values
    if max(len(infos), len(chain), len(members), len(values)) > MAX_COUNT:
        raise RequestError(f'{message}: more than {MAX_COUNT} entries in one field do not fit a batch')
    columns['kinds'].append(int(kind))
    columns['message_ids'].append(message.message_id)
    columns['conversation_ids'].append(message.conversation_id)
    columns['in_reply_to'].append(message.in_reply_to)
    columns['costs'].append(float(cost))
    columns['hold_seconds'].append(float(message.hold_seconds))
    columns['coalition_ids'].append(message.coalition_id)
    columns['reasons'].append(message.reason)
    columns['information_counts'].append(len(infos))
    columns['chain_lengths'].append(len(chain))
    columns['member_counts'].append(len(members))
    columns['value_counts'].append(len(values))
    for instance in infos:
        _information(columns, instance)
    columns['chain_requesters'].extend(chain)
    columns['members'].extend(members)
    columns['value_names'].extend(name for name, _ in values)
    columns['values'].extend(float(number) for _, number in values)


def check_columns(data: Mapping[str, Any], path: str = 'batch') -> None:
    """Refuse a batch whose columns disagree in length (RequestError naming the column)."""
    missing = [name for name in COLUMNS if name not in data]
    if missing:
        raise RequestError(f'{path}.{missing[0]}: missing column of a batch')
    count = len(data['kinds'])
    for name in MESSAGE_COLUMNS:
        if len(data[name]) != count:
            raise RequestError(f'{path}.{name}: {len(data[name])} entries for {count} messages (kinds)')
    for name, sized_by in FLAT_COLUMNS.items():
        expected = sum(data[sized_by])
        if len(data[name]) != expected:
            raise RequestError(f'{path}.{name}: {len(data[name])} entries, {sized_by} adds up to {expected}')


class _Malformed:
    __slots__ = ('reason',)

    def __init__(self, reason: str):
        self.reason = reason


def _message_dicts(data: Mapping[str, Any], sender: str, recipient: str, path: str) -> Iterator[Any]:
    """Each message's dict form for the codec (only its kind's fields), or a _Malformed."""
    info = referent = requester = member = value = 0
    types, counts, referents = data['information_types'], data['referent_counts'], data['referents']
    for index, kind_value in enumerate(data['kinds']):
        n_info, n_chain = data['information_counts'][index], data['chain_lengths'][index]
        n_members, n_values = data['member_counts'][index], data['value_counts'][index]
        entries = []
        for position in range(info, info + n_info):
            entries.append({'type': types[position], 'referents': list(referents[referent:referent + counts[position]])})
            referent += counts[position]
        info += n_info
        requesters = data['chain_requesters'][requester:requester + n_chain]
        requester += n_chain
        members = data['members'][member:member + n_members]
        member += n_members
        names, numbers = data['value_names'][value:value + n_values], data['values'][value:value + n_values]
        value += n_values
        item = {'kind': int(kind_value), 'message_id': int(data['message_ids'][index]), 'sender': sender,
                'receiver': recipient, 'conversation_id': int(data['conversation_ids'][index]),
                'in_reply_to': int(data['in_reply_to'][index])}
        try:
            kind = MessageKind(item['kind'])
        except ValueError:
            yield item  # the codec names the unknown kind
            continue
        where = f'{path}.messages[{index}]'
        wanted = {MessageKind.REQUEST: 1 + n_chain, MessageKind.OFFER: 2, MessageKind.INFORMATION: 1}.get(kind, 0)
        if n_info != wanted:
            yield _Malformed(f'{where}.information_counts: a {kind.text} message carries {wanted} information '
                             f'entries (got {n_info})')
            continue
        for name in KIND_FIELDS[kind]:
            if name == 'label':
                item['label'] = entries[0]
            elif name == 'chain':
                item['chain'] = [{'requester': robot, 'label': label} for robot, label in zip(requesters, entries[1:])]
            elif name == 'instance':
                item['instance'] = entries[-1]
            elif name == 'members':
                item['members'] = list(members)
            elif name == 'cost':
                item['cost'] = float(data['costs'][index])
            elif name == 'hold_seconds':
                item['hold_seconds'] = float(data['hold_seconds'][index])
            elif name == 'coalition_id':
                item['coalition_id'] = data['coalition_ids'][index]
            elif name == 'reason':
                item['reason'] = data['reasons'][index]
            elif name == 'values':
                item['values'] = [{'name': n, 'value': float(v)} for n, v in zip(names, numbers)]
        yield item


def _reader(item: Any) -> Any:
    if isinstance(item, _Malformed):
        raise RequestError(item.reason)
    return item


def decode_columns(codec: ChannelCodec, data: Mapping[str, Any], robot: str, path: str = 'batch') -> DecodedBatch:
    """Validate a received batch (columns, plus sender, recipient, sequence, acked_ids) for ``robot``:
    :func:`check_columns`, then :func:`~.batching.decode_batch` (header, acks, each message)."""
    if not isinstance(data, Mapping):
        raise RequestError(f'{path}: must be a mapping (got {describe_type(data)})')
    check_columns(data, path)
    messages = list(_message_dicts(data, data.get('sender'), data.get('recipient'), path))
    return decode_batch(codec, {**{key: data.get(key) for key in ('sender', 'recipient', 'sequence')},
                                'session': data.get('session', 0),
                                'acked_ids': [int(acked) for acked in data.get('acked_ids', ())],
                                'messages': messages}, robot, _reader, path)


def message_rows(data: Any) -> Iterator[tuple[int, tuple[str, ...], float]]:
    """(kind, members, cost) of each message of a batch (an AgentMessageBatch or its columns)."""
    get = data.get if isinstance(data, Mapping) else lambda name: getattr(data, name)
    members, position = list(get('members')), 0
    for kind, count, cost in zip(get('kinds'), get('member_counts'), get('costs')):
        count = int(count)  # a bag reader's uint8 array element would overflow the running sum
        yield int(kind), tuple(members[position:position + count]), float(cost)
        position += count


__all__ = ['COLUMNS', 'FLAT_COLUMNS', 'MAX_COUNT', 'MESSAGE_COLUMNS', 'check_columns', 'decode_columns',
           'encode_batch', 'message_rows']
