"""Repair a bag whose recorder died: what `ros2 bag reindex` does, for an MCAP bag.

    report = repair_bag(path)             # the bag opens again in rosbags, mcap and `ros2 bag info`
    ros2 run collab_tools bag_reindex BAG  # the same from a shell (exit 1: nothing readable)

A recorder stopped by ``kill -9`` (or a crash, or a full disk) leaves an MCAP file that ends
inside a record, with no data end, summary or footer, and no metadata.yaml: indexed readers
(rosbags, mcap's SeekingReader) and ``ros2 bag info`` refuse it. rosbag2's reindexer
(rosbag2_cpp ``Reindexer``) rebuilds metadata.yaml from what its storage plugin can read; here
the MCAP file is also made whole again, so every reader accepts it:

1. The data section is read record by record. The first record that is cut off or does not
   decode (a chunk whose bytes are short, whose size or CRC is wrong, whose records overrun
   it) ends what is kept. Of a chunk that was cut, the complete messages of what decodes are kept
   in a new, uncompressed chunk (all that is there when uncompressed; zstd and lz4 decode whole
   blocks of up to 128 KiB, so a cut compressed chunk of one block gives up nothing).
2. The file is truncated after the last good record; the last chunk gets the message indexes it
   lacks; a ``rosbag2`` metadata record, data end, summary (schemas, channels, chunk indexes,
   metadata index, statistics, summary offsets) and footer are written as a clean close does.
3. metadata.yaml is written as rosbag2 Jazzy writes it (version 9, topics with counts, offered
   QoS and type hashes from the channels), ``custom_data`` saying what the repair kept and
   dropped, plus the recorder's last status (loss counts, :mod:`.recording_loss`) if it left one.

A bag that is whole (footer present) only gets its metadata.yaml rebuilt. Repairing twice is
harmless: the second run finds the data end and rewrites the same summary.
"""
from __future__ import annotations

import argparse
import os
import struct
import sys
import time
from binascii import crc32
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import yaml

from . import mcap_records as mr
from .bag_storage import BAG_VERSION, ROS_DISTRO, rosbag2_metadata, write_metadata_file
from .recording_loss import STATUS_FILE, read_status

__all__ = ['RepairReport', 'RepairError', 'needs_repair', 'repair_bag', 'main']

_NO_TIME = 2**63 - 1
_DATA_COMPLETE = 'the data section was complete'
#: A bag written to more recently than this may belong to a running recorder (the CLI refuses it).
LIVE_SECONDS = 3.0


class RepairError(ValueError):
    """The bag cannot be repaired (no MCAP file, not MCAP, not the ros2 profile)."""


@dataclass
class RepairReport:
    mcap: Path
    rewritten: bool           # False: the MCAP file was whole, only metadata.yaml was rebuilt
    stopped: str              # why the scan ended
    message_count: int
    chunk_count: int
    salvaged: int             # messages kept from a cut, uncompressed chunk
    dropped_bytes: int        # bytes after the last kept record
    topics: dict[str, int] = field(default_factory=dict)

    def describe(self) -> str:
        what = 'reindexed' if self.rewritten else 'metadata.yaml rebuilt (MCAP file whole)'
        salvage = f', {self.salvaged} from a cut chunk' if self.salvaged else ''
        return (f'{self.mcap.parent}: {what}: {self.message_count} messages on {len(self.topics)} topics in '
                f'{self.chunk_count} chunks kept{salvage}; {self.dropped_bytes} bytes dropped ({self.stopped})')


def _mcap_file(bag: Path) -> Path:
    files = sorted(bag.glob('*.mcap'))
    if len(files) != 1:
        raise RepairError(f'{bag}: expected one .mcap file, found {len(files)} '
                          f'({", ".join(f.name for f in files) or "none"})')
    return files[0]


def needs_repair(bag: str | Path) -> bool:
    """True when the bag has no metadata.yaml or its MCAP file does not end with a footer."""
    bag = Path(bag)
    if not (bag / 'metadata.yaml').is_file():
        return True
    try:
        mcap = _mcap_file(bag)
    except RepairError:
        return False  # not an MCAP bag (sqlite3): nothing here to repair
    with mcap.open('rb') as f:
        f.seek(0, os.SEEK_END)
        if f.tell() < 2 * len(mr.MAGIC) + mr.RECORD_HEAD + 20:
            return True
        f.seek(-len(mr.MAGIC), os.SEEK_END)
        return f.read() != mr.MAGIC


class _Scan:
    """What the readable part of the data section holds."""

    def __init__(self) -> None:
        self.schemas: dict[int, mr.Schema] = {}
        self.channels: dict[int, mr.Channel] = {}
        self.chunks: list[mr.ChunkIndex] = []
        self.counts: dict[int, int] = {}
        self.start, self.end = _NO_TIME, 0
        self.metadata: list[tuple[int, int, str]] = []
        self.salvaged = 0
        self.close_began: int | None = None          # offset of a rosbag2 metadata record
        self.closed_custom_data: dict[str, str] = {}  # its custom_data

    def count(self, channel_id: int, log_time: int) -> None:
        self.counts[channel_id] = self.counts.get(channel_id, 0) + 1
        self.start, self.end = min(self.start, log_time), max(self.end, log_time)

    def chunk_contents(self, records: bytes, salvage: bool = False) -> tuple[bytes, dict, list]:
        """The chunk's (kept records, messages per channel, (channel, time) list); schemas and channels
        are taken in. salvage: keep the complete records before the first cut one instead of failing."""
        kept, messages, seen, schemas, channels = 0, {}, [], {}, {}
        try:
            for opcode, offset, body in mr.inner_records(records):
                if opcode == mr.OP_SCHEMA:
                    schema = mr.parse_schema(body)
                    schemas[schema.id] = schema
                elif opcode == mr.OP_CHANNEL:
                    channel = mr.parse_channel(body)
                    channels[channel.id] = channel
                elif opcode == mr.OP_MESSAGE:
                    channel_id, log_time = mr.parse_message_head(body)
                    messages.setdefault(channel_id, []).append((log_time, offset))
                    seen.append((channel_id, log_time))
                kept = body.end
        except mr.RecordError:
            if not salvage:
                raise
        self.schemas.update(schemas)
        self.channels.update(channels)
        for channel_id, log_time in seen:
            self.count(channel_id, log_time)
        return records[:kept], messages, seen


def _scan(f: BinaryIO, size: int, scan: _Scan) -> tuple[int, str, tuple[int, bytes] | None]:
    """Walk the data section: (end of the last good record, why the walk stopped, cut chunk)."""
    f.seek(0)
    if f.read(len(mr.MAGIC)) != mr.MAGIC:
        raise RepairError(f'{f.name}: not an MCAP file (no magic bytes)')
    head = f.read(mr.RECORD_HEAD)
    if len(head) < mr.RECORD_HEAD or head[0] != mr.OP_HEADER:
        raise RepairError(f'{f.name}: no MCAP header record')
    body = mr.Cursor(f.read(struct.unpack_from('<Q', head, 1)[0]))
    if body.string() != 'ros2':
        raise RepairError(f'{f.name}: MCAP profile is not ros2')
    good = f.tell()
    while True:
        head = f.read(mr.RECORD_HEAD)
        if not head:
            return good, 'the file ended after a complete record', None
        if len(head) < mr.RECORD_HEAD:
            return good, f'the file ends inside a record header at byte {good}', None
        opcode, length = struct.unpack_from('<BQ', head)
        if opcode in (mr.OP_DATA_END, mr.OP_FOOTER):
            return good, _DATA_COMPLETE, None
        if opcode in (0x00, mr.OP_HEADER):  # zeros a crash left, or garbage: no record starts here
            return good, f'no valid record at byte {good} (opcode 0x{opcode:02x})', None
        if good + mr.RECORD_HEAD + length > size:
            cut = (opcode, f.read()) if opcode == mr.OP_CHUNK else None
            return good, f'record 0x{opcode:02x} at byte {good} is cut off ({size - good} of ' \
                         f'{mr.RECORD_HEAD + length} bytes)', cut
        data = f.read(length)
        try:
            _take(scan, opcode, good, length, data)
        except (mr.RecordError, yaml.YAMLError) as error:
            return good, f'record 0x{opcode:02x} at byte {good} does not decode ({error})', None
        good += mr.RECORD_HEAD + length


def _take(scan: _Scan, opcode: int, offset: int, length: int, data: bytes) -> None:
    """Take in one complete record of the data section."""
    body = mr.Cursor(data)
    if opcode == mr.OP_SCHEMA:
        schema = mr.parse_schema(body)
        scan.schemas[schema.id] = schema
    elif opcode == mr.OP_CHANNEL:
        channel = mr.parse_channel(body)
        scan.channels[channel.id] = channel
    elif opcode == mr.OP_MESSAGE:
        scan.count(*mr.parse_message_head(body))
    elif opcode == mr.OP_CHUNK:
        start, end, records, compression, compressed_size = mr.chunk_records(body)
        _, messages, _ = scan.chunk_contents(records)
        scan.chunks.append(mr.ChunkIndex(start, end, offset, mr.RECORD_HEAD + length, compression,
                                         compressed_size, len(records), messages))
    elif opcode == mr.OP_MESSAGE_INDEX and scan.chunks:
        chunk = scan.chunks[-1]
        if offset == chunk.chunk_start_offset + chunk.chunk_length + chunk.message_index_length:
            chunk.message_index_offsets[body.u16()] = offset
            chunk.message_index_length += mr.RECORD_HEAD + length
    elif opcode == mr.OP_METADATA:
        name = body.string()
        if name == 'rosbag2':  # written by a close: from here on, a repair writes it again
            scan.close_began = offset
            serialized = yaml.safe_load(body.string_map().get('serialized_metadata') or '') or {}
            scan.closed_custom_data = dict(serialized.get('custom_data') or {}) if isinstance(serialized, dict) else {}
        else:
            scan.metadata.append((offset, mr.RECORD_HEAD + length, name))


def _salvage(scan: _Scan, cut: tuple[int, bytes]) -> bytes:
    """A new, uncompressed chunk record with the complete messages of a cut chunk (b'' if none)."""
    body = mr.Cursor(cut[1])
    try:
        body.take(28)
        compression = body.string()
        body.take(8)
    except mr.RecordError:
        return b''
    readable = mr.partial_records(cut[1][body.offset:], compression)
    records, messages, seen = scan.chunk_contents(readable, salvage=True)
    if not seen:
        return b''
    scan.salvaged = len(seen)
    times = [t for _, t in seen]
    chunk = (mr.u64(min(times)) + mr.u64(max(times)) + mr.u64(len(records)) + mr.u32(crc32(records))
             + mr.string('') + mr.u64(len(records)) + records)
    scan.chunks.append(mr.ChunkIndex(min(times), max(times), -1, 0, '', len(records), len(records), messages))
    return mr.record(mr.OP_CHUNK, chunk)


def _append_chunk_tail(f: BinaryIO, chunk: mr.ChunkIndex) -> None:
    """Write the message indexes the chunk (the last one, ending at f.tell()) lacks."""
    for channel_id, entries in sorted(chunk.messages.items()):
        if channel_id not in chunk.message_index_offsets:
            chunk.message_index_offsets[channel_id] = f.tell()
            data = mr.message_index_record(channel_id, entries)
            f.write(data)
            chunk.message_index_length += len(data)


def _metadata(scan: _Scan, mcap: Path, custom_data: dict[str, str], ros_distro: str) -> dict:
    """metadata.yaml's rosbag2_bagfile_information, as rosbag2 Jazzy writes it."""
    total = sum(scan.counts.values())
    start = scan.start if total else 0
    duration = scan.end - scan.start if total else 0
    topics = []
    for channel in sorted(scan.channels.values(), key=lambda c: c.id):
        schema = scan.schemas.get(channel.schema_id)
        qos = yaml.safe_load(channel.metadata.get('offered_qos_profiles') or '[]') or []
        topics.append({'topic_metadata': {
            'name': channel.topic, 'type': schema.name if schema else '',
            'serialization_format': channel.message_encoding, 'offered_qos_profiles': qos,
            'type_description_hash': channel.metadata.get('topic_type_hash', '')},
            'message_count': scan.counts.get(channel.id, 0)})
    info = {'version': BAG_VERSION, 'storage_identifier': 'mcap', 'duration': {'nanoseconds': duration},
            'starting_time': {'nanoseconds_since_epoch': start}, 'message_count': total,
            'topics_with_message_count': topics, 'compression_format': '', 'compression_mode': '',
            'relative_file_paths': [mcap.name],
            'files': [{'path': mcap.name, 'starting_time': {'nanoseconds_since_epoch': start},
                       'duration': {'nanoseconds': duration}, 'message_count': total}],
            'custom_data': custom_data or None}
    return rosbag2_metadata(info, ros_distro)


def repair_bag(bag: str | Path, ros_distro: str = ROS_DISTRO) -> RepairReport:
    """Make the bag at ``bag`` readable again (module docstring); RepairError if it cannot be."""
    bag = Path(bag)
    mcap = _mcap_file(bag)
    scan = _Scan()
    with mcap.open('r+b') as f:
        size = f.seek(0, os.SEEK_END)
        good, stopped, cut = _scan(f, size, scan)
        f.seek(max(0, size - len(mr.MAGIC)))
        whole = stopped == _DATA_COMPLETE and f.read() == mr.MAGIC
        custom = dict(scan.closed_custom_data)
        if whole:
            custom.setdefault('reindexed', 'by collab_tools bag_reindex: the MCAP file was whole, '
                                           'metadata.yaml rebuilt')
        else:
            if scan.close_began is not None:
                good, cut = scan.close_began, None  # the old metadata record is written again below
            f.truncate(good)
            f.seek(good)
            if scan.chunks and good == (scan.chunks[-1].chunk_start_offset + scan.chunks[-1].chunk_length
                                        + scan.chunks[-1].message_index_length):
                _append_chunk_tail(f, scan.chunks[-1])
            salvaged = _salvage(scan, cut) if cut else b''
            if salvaged:
                scan.chunks[-1].chunk_start_offset, scan.chunks[-1].chunk_length = f.tell(), len(salvaged)
                f.write(salvaged)
                _append_chunk_tail(f, scan.chunks[-1])
            # The recorder's last status (loss counts) stands in for the custom_data it never wrote.
            custom.update(read_status(bag / STATUS_FILE).get('custom_data') or {})
            custom['reindexed'] = (f'by collab_tools bag_reindex after an unclean stop: kept '
                                   f'{sum(scan.counts.values())} messages ({scan.salvaged} from a cut chunk), '
                                   f'dropped {size - good} bytes; {stopped}')
        metadata = _metadata(scan, mcap, custom, ros_distro)
        if not whole:
            _close(f, scan, metadata)
    write_metadata_file(bag, metadata)
    topics = {c.topic: scan.counts.get(c.id, 0) for c in scan.channels.values()}
    return RepairReport(mcap, not whole, stopped, sum(scan.counts.values()), len(scan.chunks), scan.salvaged,
                        size - good, topics)


def _close(f: BinaryIO, scan: _Scan, metadata: dict) -> None:
    """Write what a clean close writes after the data: rosbag2 metadata, data end, summary, footer."""
    text = yaml.safe_dump(metadata, sort_keys=False, default_flow_style=False).rstrip('\n')
    start = f.tell()
    data = mr.metadata_record('rosbag2', {'serialized_metadata': text})
    f.write(data)
    f.write(mr.record(mr.OP_DATA_END, mr.u32(0)))
    records = [*scan.metadata, (start, len(data), 'rosbag2')]
    statistics = mr.statistics_body(sum(scan.counts.values()), len(scan.schemas), len(scan.channels),
                                    len(records), len(scan.chunks), scan.start if scan.counts else 0,
                                    scan.end, scan.counts)
    f.write(mr.summary_section(f.tell(), sorted(scan.schemas.values(), key=lambda s: s.id),
                               sorted(scan.channels.values(), key=lambda c: c.id), scan.chunks, records,
                               statistics))
    f.flush()
    os.fsync(f.fileno())


def _seconds_since_written(bag: Path) -> float:
    """Seconds since the bag's MCAP file or the recorder's status file last changed."""
    times = [p.stat().st_mtime for p in (*Path(bag).glob('*.mcap'), Path(bag) / STATUS_FILE) if p.is_file()]
    return time.time() - max(times) if times else float('inf')


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog='bag_reindex', description='Repair a bag whose recorder died (as `ros2 bag reindex` does for '
        'metadata.yaml): rebuild the MCAP summary and index and metadata.yaml from the readable records.')
    parser.add_argument('bag', type=Path, nargs='+', help='bag directory (holds one .mcap file)')
    parser.add_argument('--ros-distro', default=ROS_DISTRO, help='what metadata.yaml says recorded it')
    parser.add_argument('--force', action='store_true',
                        help=f'repair even a bag written to in the last {LIVE_SECONDS:g} s (a live recorder\'s)')
    args = parser.parse_args(argv)
    code = 0
    for bag in args.bag:
        try:
            age = _seconds_since_written(bag)
            if age < LIVE_SECONDS and not args.force:
                raise RepairError(f'{bag} was written {age:.1f} s ago: is a recorder still writing it? '
                                  '(stop it first, or --force)')
            print(repair_bag(bag, args.ros_distro).describe())
        except (RepairError, OSError) as error:
            print(f'bag_reindex: {error}', file=sys.stderr)
            code = 1
    return code


if __name__ == '__main__':
    sys.exit(main())
