"""``AgentMessageBatch`` written and read as serialized bytes (CDR) directly, without the message object.

Why: building the typed message from a core batch, converting it to C at ``publish`` and, on the
other side, deserialising it into a Python object and reading its fields back cost ~0.4 ms per
batch -- a 20-robot column moves ~20,000 batches. The batch's wire layout is simple (a header, two
strings, a uint64 and flat arrays of numbers and strings), so :func:`encode_cdr` packs the columns
of :func:`~..core.transport.batch_columns.encode_batch` straight into the bytes the middleware
would produce (rclpy publishes ``bytes`` as a serialized message) and :func:`decode_cdr` reads the
bytes a raw subscription takes into the same columns :func:`~.batch_wire.batch_from_ros` gives.
The topic, its type and what every listener (another host, the bag recorder, ``ros2 topic echo``)
sees are unchanged.

Format: plain little-endian CDR (encapsulation ``CDR_LE``, ``00 01 00 00``), as Fast DDS and Cyclone
DDS serialize this type: each field aligned to its size relative to the payload after the 4-byte
encapsulation; a string is a uint32 length counting its NUL, the UTF-8 bytes and the NUL; a sequence
a uint32 count and its elements. :class:`WireCheck` compares both functions with
``rclpy.serialization`` on sample batches once per process: if the middleware writes anything else
(another encapsulation), the channel keeps the typed path. :func:`decode_cdr` raises
:class:`ValueError` on bytes that are not such a batch; the caller then lets rclpy deserialise them
(which names the problem or reads what this reader does not).
"""
from __future__ import annotations

import struct
from typing import Any, Callable, Sequence

from ..core.transport.batch_columns import encode_batch
from ..core.transport.batching import Batch

#: the message's fields after header, sender, recipient, sequence and session, in order, with their element type
#: (Q uint64, B uint8, d float64, s string)
ARRAY_FIELDS = (('acked_ids', 'Q'), ('kinds', 'B'), ('message_ids', 'Q'), ('conversation_ids', 'Q'),
                ('in_reply_to', 'Q'), ('costs', 'd'), ('hold_seconds', 'd'), ('coalition_ids', 's'),
                ('reasons', 's'), ('information_counts', 'B'), ('chain_lengths', 'B'), ('member_counts', 'B'),
                ('value_counts', 'B'), ('information_types', 's'), ('referent_counts', 'B'), ('referents', 's'),
                ('chain_requesters', 's'), ('members', 's'), ('value_names', 's'), ('values', 'd'))
CDR_LE = b'\x00\x01\x00\x00'
_U32 = struct.Struct('<I')
_STAMP = struct.Struct('<iI')
_U64 = struct.Struct('<Q')
#: offset of the stamp in the bytes (right after the encapsulation)
STAMP_OFFSET = 4


def _pad(out: bytearray, size: int) -> None:
    out += b'\x00' * ((-(len(out) - 4)) % size)


def _string(out: bytearray, text: str) -> None:
    data = text.encode('utf-8')
    _pad(out, 4)
    out += _U32.pack(len(data) + 1)
    out += data
    out += b'\x00'


def _write_batch(out: bytearray, columns: dict[str, Any], stamp_ns: int) -> None:
    """Append one AgentMessageBatch to the stream ``out`` (alignment is relative to the stream's
    origin, so a batch inside a bundle is written in place, not copied from its own bytes)."""
    _pad(out, 4)
    out += _STAMP.pack(stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000)
    _string(out, '')  # header.frame_id
    _string(out, columns['sender'])
    _string(out, columns['recipient'])
    _pad(out, 8)
    out += _U64.pack(columns['sequence'])
    out += _U64.pack(columns.get('session', 0))
    for name, kind in ARRAY_FIELDS:
        values = columns[name]
        count = len(values)
        _pad(out, 4)
        out += _U32.pack(count)
        if kind == 'B':
            out += bytes(values)
        elif kind == 's':
            for text in values:
                _string(out, text)
        elif count:
            _pad(out, 8)
            out += struct.pack(f'<{count}{kind}', *values)


def encode_cdr(columns: dict[str, Any], stamp_ns: int = 0) -> bytearray:
    """The serialized AgentMessageBatch of ``columns`` (encode_batch's dict: sender, recipient,
    sequence, session, acked_ids and the columns), stamped ``stamp_ns`` (:func:`set_stamp` changes it later)."""
    out = bytearray(CDR_LE)
    _write_batch(out, columns, stamp_ns)
    return out


def encode_bundle(batches: Sequence[tuple[dict[str, Any], int]], stamp_ns: int = 0) -> bytearray:
    """The serialized AgentMessageBundle of ``batches`` ((columns, stamp_ns) each), stamped ``stamp_ns``."""
    out = bytearray(CDR_LE)
    out += _STAMP.pack(stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000)
    _string(out, '')  # header.frame_id
    _pad(out, 4)
    out += _U32.pack(len(batches))
    for columns, batch_stamp in batches:
        _write_batch(out, columns, batch_stamp)
    return out


def batch_to_cdr(batch: Batch) -> bytearray:
    """The serialized AgentMessageBatch of a core batch (stamped later, :func:`set_stamp`)."""
    return encode_cdr(encode_batch(batch))


def set_stamp(data: bytearray, stamp_ns: int) -> None:
    """Stamp a batch :func:`encode_cdr` wrote (header.stamp: when it left the link model)."""
    _STAMP.pack_into(data, STAMP_OFFSET, stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000)


class _Reader:
    __slots__ = ('data', 'offset')

    def __init__(self, data: bytes):
        self.data, self.offset = data, 4

    def align(self, size: int) -> None:
        self.offset += (-(self.offset - 4)) % size

    def count(self) -> int:
        self.align(4)
        value = _U32.unpack_from(self.data, self.offset)[0]
        self.offset += 4
        if value > len(self.data):
            raise ValueError(f'a count of {value} in a {len(self.data)}-byte batch')
        return value

    def string(self) -> str:
        length = self.count()
        end = self.offset + length
        if length < 1 or end > len(self.data) or self.data[end - 1] != 0:
            raise ValueError('a string without its terminating NUL')
        text = self.data[self.offset:end - 1].decode('utf-8')
        self.offset = end
        return text

    def skip_string(self) -> None:
        length = self.count()
        if length < 1 or self.offset + length > len(self.data):
            raise ValueError('a string past the end of the data')
        self.offset += length

    def skip_numbers(self, kind: str) -> None:
        count = self.count()
        if kind == 's':
            for _ in range(count):
                self.skip_string()
            return
        if kind != 'B' and count:
            self.align(8)
        self.offset += count * (1 if kind == 'B' else 8)
        if self.offset > len(self.data):
            raise ValueError('an array past the end of the data')

    def numbers(self, kind: str) -> list:
        count = self.count()
        if kind == 'B':
            end = self.offset + count
            if end > len(self.data):
                raise ValueError('an array past the end of the batch')
            values = list(self.data[self.offset:end])
            self.offset = end
            return values
        if not count:
            return []
        self.align(8)
        values = list(struct.unpack_from(f'<{count}{kind}', self.data, self.offset))
        self.offset += 8 * count
        return values


def peek_addresses(data: bytes) -> tuple[str, str] | None:
    """(sender, recipient) of a serialized AgentMessageBatch, read from its first bytes (after the
    stamp: header.frame_id, sender, recipient), or None if they do not look like one (the rest is
    not read: a process skips the batches for robots it does not host without decoding them)."""
    if len(data) < 16 or data[1] != 1:  # encapsulation: CDR_LE (0x0001)
        return None
    try:
        reader = _Reader(data)
        reader.offset = STAMP_OFFSET + 8
        reader.string()  # header.frame_id
        sender, recipient = reader.string(), reader.string()
    except (ValueError, struct.error, UnicodeDecodeError):
        return None
    return sender, recipient


def _read_batch(reader: _Reader) -> dict[str, Any]:
    """One AgentMessageBatch from the reader's offset (batch_from_ros's fields plus ``stamp_ns``)."""
    data = reader.data
    reader.align(4)
    sec, nanosec = _STAMP.unpack_from(data, reader.offset)
    reader.offset += 8
    reader.string()  # header.frame_id
    result: dict[str, Any] = {'stamp_ns': sec * 1_000_000_000 + nanosec, 'sender': reader.string(),
                              'recipient': reader.string()}
    reader.align(8)
    result['sequence'], result['session'] = _U64.unpack_from(data, reader.offset)[0], \
        _U64.unpack_from(data, reader.offset + 8)[0]
    reader.offset += 16
    for name, kind in ARRAY_FIELDS:
        result[name] = [reader.string() for _ in range(reader.count())] if kind == 's' else reader.numbers(kind)
    return result


def _skip_batch_rest(reader: _Reader) -> None:
    """Move past the rest of a batch whose sender and recipient were just read."""
    reader.align(8)
    reader.offset += 16  # sequence, session
    for _, kind in ARRAY_FIELDS:
        reader.skip_numbers(kind)


def decode_cdr(data: bytes) -> dict[str, Any]:
    """The fields of a serialized AgentMessageBatch as :func:`~.batch_wire.batch_from_ros` gives them
    (plus ``stamp_ns``); ValueError if the bytes are not a CDR_LE batch this reader can read."""
    if data[:4] != CDR_LE:
        raise ValueError(f'encapsulation {bytes(data[:4]).hex()} (this reader reads CDR_LE, 00010000)')
    try:
        return _read_batch(_Reader(data))
    except (struct.error, UnicodeDecodeError) as exc:
        raise ValueError(f'not an AgentMessageBatch: {exc}') from None


def decode_bundle(data: bytes, wanted: Callable[[str, str], bool] = lambda sender, recipient: True
                  ) -> tuple[int, list[dict[str, Any]]]:
    """(stamp_ns, the batches) of a serialized AgentMessageBundle: every batch whose (sender,
    recipient) ``wanted`` accepts, decoded as :func:`decode_cdr` decodes one; the others are
    skipped without being read. ValueError if the bytes are not a CDR_LE bundle this reader can read."""
    if data[:4] != CDR_LE:
        raise ValueError(f'encapsulation {bytes(data[:4]).hex()} (this reader reads CDR_LE, 00010000)')
    try:
        reader = _Reader(data)
        sec, nanosec = _STAMP.unpack_from(data, STAMP_OFFSET)
        reader.offset = STAMP_OFFSET + 8
        reader.string()  # header.frame_id
        batches = []
        for _ in range(reader.count()):
            start = reader.offset
            reader.align(4)
            reader.offset += 8
            reader.skip_string()  # header.frame_id
            sender, recipient = reader.string(), reader.string()
            if wanted(sender, recipient):
                reader.offset = start
                batches.append(_read_batch(reader))
            else:
                _skip_batch_rest(reader)
    except (struct.error, UnicodeDecodeError) as exc:
        raise ValueError(f'not an AgentMessageBundle: {exc}') from None
    return sec * 1_000_000_000 + nanosec, batches


#: batches :class:`WireCheck` compares (every field used, empty and non-empty arrays, odd lengths)
SAMPLES = (
    {'sender': 'robot_12', 'recipient': 'robot_3', 'sequence': 7, 'session': 8_446_744_073_709_551_615,
     'acked_ids': [1795681945905458, 3],
     'kinds': [1, 2, 8], 'message_ids': [11, 12, 13], 'conversation_ids': [0, 5, 0], 'in_reply_to': [0, 9, 0],
     'costs': [0.0, 17.5, 0.0], 'hold_seconds': [0.0, 0.0, 0.0], 'coalition_ids': ['', '', 'robot_12/4'],
     'reasons': ['', '', ''], 'information_counts': [2, 2, 1], 'chain_lengths': [1, 0, 0], 'member_counts': [0, 3, 0],
     'value_counts': [0, 0, 3], 'information_types': ['F_G', 'F_R', 'F_R', 'F_G', 'F_R'],
     'referent_counts': [1, 2, 2, 1, 2], 'referents': ['X', 'robot_12', 'X', 'robot_12', 'X', 'robot_3', 'é', 'Y'],
     'chain_requesters': ['robot_13'], 'members': ['robot_12', 'robot_3', 'robot_1'], 'value_names': ['x', 'y', 'yaw'],
     'values': [1.5, -2.25, 3.0]},
    {'sender': 'r', 'recipient': 'ab', 'sequence': 2 ** 64 - 1, 'session': 0, **{name: [] for name, _ in ARRAY_FIELDS}},
)


class WireCheck:
    """Whether the middleware reads :func:`encode_cdr`'s and :func:`encode_bundle`'s bytes as the
    batches they encode and :func:`decode_cdr` / :func:`decode_bundle` read the middleware's bytes
    (``serialize(columns, stamp_ns) -> bytes``, ``fields(bytes) -> dict`` for one batch and
    ``serialize_bundle([(columns, stamp_ns)], stamp_ns) -> bytes``, ``bundle_fields(bytes) ->
    (stamp_ns, [dict])`` for a bundle: rclpy's, supplied by the caller; padding and trailing bytes are
    not compared: the middleware leaves them unset), on :data:`SAMPLES` -- in a bundle each batch
    starts at another alignment, so the bundle's samples put the batches at every offset modulo 8;
    checked once, at the first question."""

    def __init__(self, serialize: Callable[[dict, int], bytes], fields: Callable[[bytes], dict],
                 serialize_bundle: Callable[[list, int], bytes] | None = None,
                 bundle_fields: Callable[[bytes], tuple[int, list[dict]]] | None = None):
        self._serialize, self._fields = serialize, fields
        self._serialize_bundle, self._bundle_fields = serialize_bundle, bundle_fields
        self._result: tuple[bool, str] | None = None

    def result(self) -> tuple[bool, str]:
        """(agrees, why not)."""
        if self._result is None:
            try:
                self._result = self._check()
            except Exception as exc:  # noqa: BLE001 - any failure means: keep the typed path
                self._result = (False, f'{type(exc).__name__}: {exc}')
        return self._result

    def _check(self) -> tuple[bool, str]:
        stamp = 1_795_681_953_504_594_834
        for columns in SAMPLES:
            wanted = {**columns, 'stamp_ns': stamp}
            theirs = self._serialize(columns, stamp)
            if theirs[:4] != CDR_LE:
                return False, f'the middleware writes encapsulation {bytes(theirs[:4]).hex()}, not CDR_LE'
            read = decode_cdr(theirs)
            if {key: read[key] for key in wanted} != wanted:
                return False, 'its batches read back differently'
            if self._fields(bytes(encode_cdr(columns, stamp))) != wanted:
                return False, 'it reads these batches differently'
        if self._serialize_bundle is None or self._bundle_fields is None:
            return True, ''
        batches = bundle_samples()
        wanted_batches = [{**columns, 'stamp_ns': batch_stamp} for columns, batch_stamp in batches]
        theirs = self._serialize_bundle(batches, stamp)
        read_stamp, read = decode_bundle(theirs)
        if read_stamp != stamp or [{key: r[key] for key in w} for r, w in zip(read, wanted_batches)] != wanted_batches \
                or len(read) != len(wanted_batches):
            return False, 'its bundles read back differently'
        if self._bundle_fields(bytes(encode_bundle(batches, stamp))) != (stamp, wanted_batches):
            return False, 'it reads these bundles differently'
        return True, ''


def bundle_samples() -> list[tuple[dict[str, Any], int]]:
    """The samples in a bundle, each batch preceded by sender names of 1..8 characters: the batches
    start at every offset modulo 8 (the alignment of their 64-bit fields depends on it)."""
    batches = []
    for length in range(1, 9):
        for columns in SAMPLES:
            batches.append(({**columns, 'sender': 's' * length}, 1_795_681_953_000_000_000 + length))
    return batches


__all__ = ['ARRAY_FIELDS', 'CDR_LE', 'SAMPLES', 'WireCheck', 'batch_to_cdr', 'bundle_samples', 'decode_bundle',
           'decode_cdr', 'encode_bundle', 'encode_cdr', 'peek_addresses', 'set_stamp']
