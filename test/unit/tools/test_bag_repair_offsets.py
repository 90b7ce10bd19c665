"""bag_repair: a bag cut off like a killed recorder leaves it opens again in rosbags, in mcap's
indexed reader and passes the rosbag2 Jazzy format check; the writer's flush bounds the loss."""
from __future__ import annotations

import shutil
import struct
from pathlib import Path

import pytest
import yaml
from rosbags.highlevel import AnyReader

from collab_tools.core import mcap_records as mr
from collab_tools.core.bag_check import check_bag
from collab_tools.core.bag_repair import RepairError, main, needs_repair, repair_bag
from collab_tools.core.bag_types import build_typestore
from collab_tools.core.bag_writer import BagWriter, QosSpec
from collab_tools.core.recording_loss import STATUS_FILE, LossLedger, write_status

try:  # Foxglove's reference reader (scripts/requirements); without it, rosbags' indexed path alone
    from mcap import reader as mcap_reader
except ImportError:  # pragma: no cover - scripts/setup installs it
    mcap_reader = None

TYPES = {'/chatter': 'std_msgs/msg/String', '/robot_1/cmd_vel': 'geometry_msgs/msg/Twist'}
T0 = 1_700_000_000_000_000_000
N = 300


@pytest.fixture(scope='module')
def typestore():
    return build_typestore(list(TYPES.values()))


def write_bag(path: Path, typestore, preset: str = 'none', killed_at: Path | None = None,
              extra: int = 0) -> list[tuple[str, int, bytes]]:
    """A bag of N messages per topic in 12 chunks (a flush every 25 rounds, then ``extra`` rounds
    more); what it holds. killed_at: also copy the bag there as a kill leaves it (before the close)."""
    written = []
    writer = BagWriter(path, typestore, storage_preset=preset)
    for topic, type_name in TYPES.items():
        writer.add_topic(topic, type_name, [QosSpec('keep_last', 10, 'reliable', 'volatile')])
    String, Twist, Vector3 = (typestore.types[t] for t in
                              ('std_msgs/msg/String', 'geometry_msgs/msg/Twist', 'geometry_msgs/msg/Vector3'))
    for i in range(N + extra):
        for topic, msg in (('/chatter', String(data=f'message {i} ' + 'x' * (i % 40))),
                           ('/robot_1/cmd_vel', Twist(Vector3(0.1 * i, 0.0, 0.0), Vector3(0.0, 0.0, -0.01 * i)))):
            raw = bytes(typestore.serialize_cdr(msg, TYPES[topic]))
            writer.write(topic, T0 + i * 10_000_000, raw)
            written.append((topic, T0 + i * 10_000_000, raw))
        if i % 25 == 24 and i < N:
            assert writer.flush()
    if killed_at is not None:  # what the file system has when the process is killed
        killed_at.mkdir()
        shutil.copy(next(path.glob('*.mcap')), killed_at)
    writer.close()
    return written


def chunk_offsets(mcap: Path) -> list[tuple[int, int]]:
    """(start, end) of every chunk record in the data section."""
    data, offset, out = mcap.read_bytes(), len(mr.MAGIC), []
    while offset + mr.RECORD_HEAD <= len(data):
        opcode, length = struct.unpack_from('<BQ', data, offset)
        if opcode in (mr.OP_DATA_END, mr.OP_FOOTER):
            break
        if opcode == mr.OP_CHUNK:
            out.append((offset, offset + mr.RECORD_HEAD + length))
        offset += mr.RECORD_HEAD + length
    return out


def cut_copy(source: Path, dest: Path, offset: int) -> Path:
    """The bag as a kill at byte ``offset`` of its MCAP file leaves it: no metadata.yaml, file cut."""
    dest.mkdir()
    mcap = next(source.glob('*.mcap'))
    (dest / mcap.name).write_bytes(mcap.read_bytes()[:offset])
    return dest


def read_all(bag: Path) -> list[tuple[str, int, bytes]]:
    with AnyReader([bag]) as reader:
        return [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]


def read_indexed(bag: Path) -> tuple[int, list[tuple[str, int, bytes]]]:
    """mcap's SeekingReader: statistics from the summary and the messages through the chunk indexes."""
    if mcap_reader is None:
        from rosbags.rosbag2.storage_mcap import McapReader
        storage = McapReader(next(bag.glob('*.mcap')))
        storage.open()
        try:
            assert storage.chunks or not storage.statistics.message_count, 'no chunk index'
            messages = [(c.topic, t, bytes(d)) for c, t, d in storage.messages(storage.connections)]
            return storage.statistics.message_count, messages
        finally:
            storage.close()
    with next(bag.glob('*.mcap')).open('rb') as f:
        reader = mcap_reader.make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes, 'no summary / chunk index'
        messages = [(channel.topic, message.log_time, message.data)
                    for _, channel, message in reader.iter_messages(log_time_order=True)]
        return summary.statistics.message_count, messages


@pytest.fixture(scope='module')
def reference(tmp_path_factory, typestore):
    bag = tmp_path_factory.mktemp('ref') / 'run'
    written = write_bag(bag, typestore)
    return bag, written


def in_time_order(messages):
    return sorted(messages, key=lambda m: (m[1], m[0]))


def assert_opens_with(bag: Path, expected: list, topics=tuple(TYPES)) -> None:
    assert check_bag(bag) == []
    got = read_all(bag)
    assert in_time_order(got) == in_time_order(expected)
    count, indexed = read_indexed(bag)
    assert count == len(expected)
    assert in_time_order(indexed) == in_time_order(expected)
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['message_count'] == len(expected)
    per_topic = {e['topic_metadata']['name']: e['message_count'] for e in info['topics_with_message_count']}
    assert per_topic == {t: sum(1 for m in expected if m[0] == t) for t in topics}


@pytest.mark.parametrize('where', ['chunk_end', 'mid_chunk', 'chunk_header', 'index_tail', 'record_head'])
def test_cut_bag_is_repaired_and_opens_in_both_readers(tmp_path, reference, where):
    source, written = reference
    chunks = chunk_offsets(next(source.glob('*.mcap')))
    assert len(chunks) >= 10
    start, end = chunks[6]
    # chunk_end: right after chunk 5, none of its message indexes written; index_tail: inside chunk 6's
    offset = {'chunk_end': chunks[5][1], 'mid_chunk': (start + end) // 2, 'chunk_header': start + 20,
              'index_tail': end + 12, 'record_head': start + 4}[where]
    bag = cut_copy(source, tmp_path / 'cut', offset)
    assert needs_repair(bag)

    report = repair_bag(bag)

    assert report.rewritten and not needs_repair(bag)
    kept_chunks = 6 if where != 'index_tail' else 7
    whole = 2 * 25 * kept_chunks  # messages of the chunks before the cut
    if where == 'mid_chunk':
        assert 0 < report.salvaged < 50  # the complete messages of the uncompressed, cut chunk
    else:
        assert report.salvaged == 0
    expected = written[:whole + report.salvaged]
    assert report.message_count == len(expected)
    assert_opens_with(bag, expected)
    custom = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']['custom_data']
    assert 'unclean stop' in custom['reindexed']

    # Twice is harmless: the same messages, the same file.
    before = next(bag.glob('*.mcap')).read_bytes()
    again = repair_bag(bag)
    assert not again.rewritten and again.message_count == len(expected)
    assert next(bag.glob('*.mcap')).read_bytes() == before


def test_compressed_cut_chunk_keeps_its_complete_blocks(tmp_path, typestore):
    """zstd decodes block by block (128 KiB): a cut compressed chunk gives up the messages of its
    complete blocks (kept in a new, uncompressed chunk); a chunk of one block, nothing."""
    import random
    rng = random.Random(7)
    source, written = tmp_path / 'zstd', []
    writer = BagWriter(source, typestore, storage_preset='zstd_fast')
    writer.add_topic('/chatter', TYPES['/chatter'])
    for i in range(3000):  # 3 chunks of ~300 KiB of incompressible text
        text = ''.join(rng.choice('abcdefghijklmnopqrstuvwxyz0123456789') for _ in range(300))
        raw = bytes(typestore.serialize_cdr(typestore.types[TYPES['/chatter']](data=text), TYPES['/chatter']))
        writer.write('/chatter', T0 + i, raw)
        written.append(('/chatter', T0 + i, raw))
        if i % 1000 == 999:
            writer.flush()
    writer.close()
    start, end = chunk_offsets(next(source.glob('*.mcap')))[2]
    bag = cut_copy(source, tmp_path / 'cut', start + (end - start) * 9 // 10)
    report = repair_bag(bag)
    assert report.chunk_count == 3 and 300 < report.salvaged < 1000
    assert_opens_with(bag, written[:2000 + report.salvaged], topics=('/chatter',))
    small = tmp_path / 'small'
    written = write_bag(small, typestore, preset='zstd_fast')
    start, end = chunk_offsets(next(small.glob('*.mcap')))[3]
    report = repair_bag(cut_copy(small, tmp_path / 'small_cut', (start + end) // 2))
    assert report.salvaged == 0 and report.chunk_count == 3
    assert_opens_with(tmp_path / 'small_cut', written[:3 * 50])


def test_killed_writer_loses_at_most_the_pending_chunk(tmp_path, typestore):
    """Each flush puts the chunk into the file: a kill loses only what came after the last one."""
    bag = tmp_path / 'killed'
    written = write_bag(tmp_path / 'run', typestore, killed_at=bag, extra=10)
    assert not (bag / 'metadata.yaml').exists() and needs_repair(bag)
    report = repair_bag(bag)
    assert report.message_count == len(written) - 2 * 10
    assert_opens_with(bag, written[:-2 * 10])


def test_empty_recording_and_header_only(tmp_path, typestore):
    source = tmp_path / 'src'
    write_bag(source, typestore)
    header_end = chunk_offsets(next(source.glob('*.mcap')))[0][0]
    bag = cut_copy(source, tmp_path / 'cut', header_end)
    report = repair_bag(bag)
    assert report.message_count == 0
    assert check_bag(bag) == [] or all('no channel' in p for p in check_bag(bag))
    assert read_all(bag) == []


def test_whole_bag_only_gets_metadata_rebuilt(tmp_path, reference):
    source, written = reference
    bag = tmp_path / 'whole'
    shutil.copytree(source, bag)
    (bag / 'metadata.yaml').unlink()
    mcap = next(bag.glob('*.mcap'))
    before = mcap.read_bytes()
    assert needs_repair(bag)
    report = repair_bag(bag)
    assert not report.rewritten and mcap.read_bytes() == before
    assert_opens_with(bag, written)


def test_recorder_status_goes_into_custom_data(tmp_path, reference):
    source, written = reference
    ledger = LossLedger()
    ledger.add_topic('/chatter')
    for number in (1, 2, 5):
        ledger.received('/chatter', number)
    bag = cut_copy(source, tmp_path / 'cut', chunk_offsets(next(source.glob('*.mcap')))[2][1])
    write_status(bag / STATUS_FILE, ledger.custom_data(), 'recording')
    repair_bag(bag)
    custom = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']['custom_data']
    assert custom['messages_lost'] == '2'
    assert check_bag(bag) == []


def test_what_cannot_be_repaired_is_named(tmp_path, capsys):
    empty = tmp_path / 'empty'
    empty.mkdir()
    with pytest.raises(RepairError, match='expected one .mcap file'):
        repair_bag(empty)
    junk = tmp_path / 'junk'
    junk.mkdir()
    (junk / 'junk.mcap').write_bytes(b'not an mcap file at all')
    with pytest.raises(RepairError, match='not an MCAP file'):
        repair_bag(junk)
    assert main(['--force', str(junk)]) == 1
    assert 'bag_reindex:' in capsys.readouterr().err


def test_cli_repairs_and_describes(tmp_path, reference, capsys):
    source, written = reference
    bag = cut_copy(source, tmp_path / 'cut', chunk_offsets(next(source.glob('*.mcap')))[4][1] + 3)
    assert main([str(bag)]) == 1  # just written: a live recorder's bag is left alone
    assert 'is a recorder still writing it?' in capsys.readouterr().err
    assert needs_repair(bag)
    assert main(['--force', str(bag)]) == 0
    out = capsys.readouterr().out
    assert 'reindexed' in out and f'{5 * 50} messages' in out


def test_flush_keeps_a_young_chunk_pending(tmp_path, typestore):
    writer = BagWriter(tmp_path / 'bag', typestore)
    writer.add_topic('/chatter', TYPES['/chatter'])
    assert not writer.flush()  # nothing pending
    writer.write('/chatter', T0, bytes(typestore.serialize_cdr(typestore.types[TYPES['/chatter']](data='a'),
                                                            TYPES['/chatter'])))
    assert not writer.flush(max_age_s=60.0)
    assert writer.flush(max_age_s=0.0)
    assert not writer.flush()
    writer.close()
    assert not writer.flush()


def test_zeros_after_the_last_record_are_dropped(tmp_path, reference):
    """What a crashed file system can leave: the tail filled with zeros."""
    source, written = reference
    end = chunk_offsets(next(source.glob('*.mcap')))[3][1]
    bag = cut_copy(source, tmp_path / 'cut', end)
    with next(bag.glob('*.mcap')).open('ab') as f:
        f.write(bytes(4096))
    report = repair_bag(bag)
    assert report.dropped_bytes == 4096 and 'no valid record' in report.stopped
    assert_opens_with(bag, written[:4 * 50])
