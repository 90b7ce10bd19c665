"""MCAP records as the repair of a bag reads and writes them (https://mcap.dev/spec).

Only what :mod:`.bag_repair` needs: parsing the data section's records (header, schema,
channel, message, chunk, message index, metadata) and encoding the summary section a clean
close writes (schemas, channels, chunk indexes, metadata index, statistics, summary offsets,
footer). Chunks are decompressed with rosbags' own decompressor, which checks their size and
CRC. Every parse error is a :class:`RecordError` (the record is not usable).
"""
from __future__ import annotations

import struct
import sys
from dataclasses import dataclass, field

import lz4.frame
from rosbags.rosbag2.errors import ReaderError
from rosbags.rosbag2.storage_mcap import decompress

if sys.version_info >= (3, 14):
    from compression import zstd
else:  # pragma: no cover - the rosbags dependency brings the backport
    from backports import zstd

MAGIC = b'\x89MCAP0\r\n'
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE = 0x01, 0x02, 0x03, 0x04, 0x05
OP_CHUNK, OP_MESSAGE_INDEX, OP_CHUNK_INDEX, OP_STATISTICS = 0x06, 0x07, 0x08, 0x0B
OP_METADATA, OP_METADATA_INDEX, OP_SUMMARY_OFFSET, OP_DATA_END = 0x0C, 0x0D, 0x0E, 0x0F
RECORD_HEAD = 9  # opcode (u8) + length (u64)


class RecordError(ValueError):
    """A record that is cut off or does not decode."""


# ---- reading ---------------------------------------------------------------------------------
class Cursor:
    """Little-endian reads from one record's body; reading past its end is a RecordError."""

    def __init__(self, data: bytes | memoryview, offset: int = 0, end: int | None = None):
        self.data, self.offset = data, offset
        self.end = len(data) if end is None else end

    def take(self, size: int) -> bytes:
        if size < 0 or self.offset + size > self.end:
            raise RecordError(f'record ends {self.offset + size - self.end} byte(s) early')
        chunk = bytes(self.data[self.offset:self.offset + size])
        self.offset += size
        return chunk

    def u16(self) -> int:
        return struct.unpack('<H', self.take(2))[0]

    def u32(self) -> int:
        return struct.unpack('<I', self.take(4))[0]

    def u64(self) -> int:
        return struct.unpack('<Q', self.take(8))[0]

    def string(self) -> str:
        try:
            return self.take(self.u32()).decode()
        except UnicodeDecodeError as error:
            raise RecordError(f'string is not UTF-8 ({error})') from None

    def string_map(self) -> dict[str, str]:
        length = self.u32()
        inner = Cursor(self.data, self.offset, self.offset + length)
        if inner.end > self.end:
            raise RecordError('map overruns its record')
        out = {}
        while inner.offset < inner.end:
            key = inner.string()
            out[key] = inner.string()
        self.offset = inner.end
        return out

    @property
    def done(self) -> bool:
        return self.offset >= self.end


@dataclass
class Schema:
    id: int
    name: str
    encoding: str
    data: bytes


@dataclass
class Channel:
    id: int
    schema_id: int
    topic: str
    message_encoding: str
    metadata: dict[str, str]


@dataclass
class ChunkIndex:
    """One chunk as the summary lists it, with its messages' (log time, offset) per channel."""

    message_start_time: int
    message_end_time: int
    chunk_start_offset: int
    chunk_length: int
    compression: str
    compressed_size: int
    uncompressed_size: int
    messages: dict[int, list[tuple[int, int]]] = field(default_factory=dict)
    message_index_offsets: dict[int, int] = field(default_factory=dict)
    message_index_length: int = 0


def parse_schema(body: Cursor) -> Schema:
    schema_id, name, encoding = body.u16(), body.string(), body.string()
    return Schema(schema_id, name, encoding, body.take(body.u32()))


def parse_channel(body: Cursor) -> Channel:
    return Channel(body.u16(), body.u16(), body.string(), body.string(), body.string_map())


def parse_message_head(body: Cursor) -> tuple[int, int]:
    """(channel id, log time) of a message record; the rest is sequence, publish time, data."""
    channel_id = body.u16()
    body.take(4)
    return channel_id, body.u64()


def chunk_records(body: Cursor) -> tuple[int, int, bytes, str, int]:
    """A chunk's (start, end, decompressed records, compression, compressed size); size and CRC checked."""
    start, end, size, crc = body.u64(), body.u64(), body.u64(), body.u32()
    compression = body.string()
    compressed = body.take(body.u64())
    try:
        records = decompress(compressed, compression, size, crc)
    except (ReaderError, RuntimeError, ValueError, OSError) as error:  # lz4/zstd raise their own kinds
        raise RecordError(f'chunk does not decompress ({error})') from None
    return start, end, records, compression, len(compressed)


def partial_records(data: bytes, compression: str) -> bytes:
    """What the first bytes of a chunk's (maybe compressed) records decode to; b'' if nothing."""
    if compression == '':
        return data
    try:
        if compression == 'zstd':
            return zstd.ZstdDecompressor().decompress(data)
        if compression == 'lz4':
            return lz4.frame.LZ4FrameDecompressor().decompress(data)
    except (zstd.ZstdError, RuntimeError, ValueError):
        pass
    return b''


def inner_records(records: bytes):
    """(opcode, offset, body cursor) of each record inside a chunk; a cut record raises RecordError."""
    offset = 0
    while offset < len(records):
        if offset + RECORD_HEAD > len(records):
            raise RecordError('chunk ends inside a record header')
        opcode, length = struct.unpack_from('<BQ', records, offset)
        end = offset + RECORD_HEAD + length
        if end > len(records):
            raise RecordError('chunk ends inside a record')
        yield opcode, offset, Cursor(records, offset + RECORD_HEAD, end)
        offset = end


# ---- writing ---------------------------------------------------------------------------------
def u16(value: int) -> bytes:
    return struct.pack('<H', value)


def u32(value: int) -> bytes:
    return struct.pack('<I', value)


def u64(value: int) -> bytes:
    return struct.pack('<Q', value)


def string(value: str) -> bytes:
    data = value.encode()
    return u32(len(data)) + data


def string_map(values: dict[str, str]) -> bytes:
    data = b''.join(string(k) + string(v) for k, v in values.items())
    return u32(len(data)) + data


def record(opcode: int, body: bytes) -> bytes:
    return bytes([opcode]) + u64(len(body)) + body


def schema_record(schema: Schema) -> bytes:
    return record(OP_SCHEMA, u16(schema.id) + string(schema.name) + string(schema.encoding)
                  + u32(len(schema.data)) + schema.data)


def channel_record(channel: Channel) -> bytes:
    return record(OP_CHANNEL, u16(channel.id) + u16(channel.schema_id) + string(channel.topic)
                  + string(channel.message_encoding) + string_map(channel.metadata))


def message_index_record(channel_id: int, entries: list[tuple[int, int]]) -> bytes:
    pairs = b''.join(u64(time) + u64(offset) for time, offset in entries)
    return record(OP_MESSAGE_INDEX, u16(channel_id) + u32(len(pairs)) + pairs)


def chunk_index_record(chunk: ChunkIndex) -> bytes:
    offsets = b''.join(u16(cid) + u64(off) for cid, off in sorted(chunk.message_index_offsets.items()))
    return record(OP_CHUNK_INDEX, u64(chunk.message_start_time) + u64(chunk.message_end_time)
                  + u64(chunk.chunk_start_offset) + u64(chunk.chunk_length) + u32(len(offsets)) + offsets
                  + u64(chunk.message_index_length) + string(chunk.compression)
                  + u64(chunk.compressed_size) + u64(chunk.uncompressed_size))


def metadata_record(name: str, values: dict[str, str]) -> bytes:
    return record(OP_METADATA, string(name) + string_map(values))


def summary_section(start: int, schemas: list[Schema], channels: list[Channel], chunks: list[ChunkIndex],
                    metadata: list[tuple[int, int, str]], statistics: bytes) -> bytes:
    """Summary section starting at file offset ``start``, its summary offsets, footer and end magic.

    metadata: (offset, length, name) of each metadata record of the data section.
    """
    groups: list[tuple[int, bytes]] = [
        (OP_SCHEMA, b''.join(schema_record(s) for s in schemas)),
        (OP_CHANNEL, b''.join(channel_record(c) for c in channels)),
        (OP_CHUNK_INDEX, b''.join(chunk_index_record(c) for c in chunks)),
        (OP_METADATA_INDEX, b''.join(record(OP_METADATA_INDEX, u64(off) + u64(length) + string(name))
                                     for off, length, name in metadata)),
        (OP_STATISTICS, record(OP_STATISTICS, statistics)),
    ]
    body, offsets, at = b'', b'', start
    for opcode, data in groups:
        if data:
            offsets += record(OP_SUMMARY_OFFSET, bytes([opcode]) + u64(at) + u64(len(data)))
            body += data
            at += len(data)
    footer = record(OP_FOOTER, u64(start) + u64(at) + u32(0))
    return body + offsets + footer + MAGIC


def statistics_body(message_count: int, schemas: int, channels: int, metadata: int, chunks: int,
                    start: int, end: int, per_channel: dict[int, int]) -> bytes:
    counts = b''.join(u16(cid) + u64(n) for cid, n in sorted(per_channel.items()))
    return (u64(message_count) + u16(schemas) + u32(channels) + u32(0) + u32(metadata) + u32(chunks)
            + u64(start) + u64(end) + u32(len(counts)) + counts)
