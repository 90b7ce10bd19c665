"""Batches as serialized bytes (transport.batch_cdr): rclpy reads the bytes encode_cdr writes as the
batch they encode, decode_cdr reads rclpy's bytes as batch_from_ros does, every kind of message
survives the bytes, the check against the middleware says why it disagrees, and bytes that are not
a batch are refused (the hub then lets rclpy read them)."""
from __future__ import annotations

import random

import pytest

from coalition_agents.core.transport.batch_columns import decode_columns, encode_batch
from coalition_agents.core.transport.batching import Batch
from coalition_agents.core.transport.codec import MessageKind
from coalition_agents.transport.batch_cdr import (
    ARRAY_FIELDS, SAMPLES, WireCheck, batch_to_cdr, decode_cdr, encode_cdr, set_stamp,
)
from test_transport_columns import TEAM, codec, every_kind  # noqa: F401 - the codec fixture

STAMP = 1_795_681_953_504_594_834


def random_columns(rng: random.Random) -> dict:
    columns = {'sender': rng.choice(['robot_1', 'r', 'robot_12']), 'recipient': rng.choice(['robot_13', '', 'ab']),
               'sequence': rng.randrange(2 ** 64), 'session': rng.choice([0, rng.randrange(2 ** 64)])}
    for name, kind in ARRAY_FIELDS:
        count = rng.choice([0, 0, 1, 2, 3, 5])
        if kind == 'B':
            columns[name] = [rng.randrange(256) for _ in range(count)]
        elif kind == 'Q':
            columns[name] = [rng.randrange(2 ** 64) for _ in range(count)]
        elif kind == 'd':
            columns[name] = [rng.uniform(-1e3, 1e3) for _ in range(count)]
        else:
            columns[name] = [rng.choice(['', 'X', 'robot_3', 'F_R', 'é']) for _ in range(count)]
    return columns


def rclpy_fields(data: bytes) -> dict:
    from rclpy.serialization import deserialize_message
    from coalition_interfaces.msg import AgentMessageBatch
    from coalition_agents.transport.batch_wire import batch_from_ros
    msg = deserialize_message(data, AgentMessageBatch)
    fields = {key: value if isinstance(value, (str, int)) else list(value) for key, value in batch_from_ros(msg).items()}
    return {**fields, 'stamp_ns': msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec}


def rclpy_bytes(columns: dict, stamp_ns: int) -> bytes:
    from rclpy.serialization import serialize_message
    from coalition_interfaces.msg import AgentMessageBatch
    msg = AgentMessageBatch(**columns)
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    return serialize_message(msg)


def test_rclpy_reads_the_bytes_as_the_batch_and_decode_cdr_reads_rclpys_bytes():
    rng = random.Random(5)
    for columns in [*SAMPLES, *(random_columns(rng) for _ in range(300))]:
        stamp = rng.randrange(2 ** 31 * 1_000_000_000)
        assert rclpy_fields(bytes(encode_cdr(columns, stamp))) == {**columns, 'stamp_ns': stamp}
        assert decode_cdr(rclpy_bytes(columns, stamp)) == {**columns, 'stamp_ns': stamp}


def test_a_stamp_set_later_is_the_header_stamp():
    data = encode_cdr(SAMPLES[0])
    set_stamp(data, STAMP)
    assert rclpy_fields(bytes(data))['stamp_ns'] == STAMP


def test_every_kind_of_message_survives_the_bytes(library, codec):  # noqa: F811
    batch = Batch('robot_2', 'robot_1', 3, tuple(every_kind(library)), (101, 102), session=2 ** 63 + 5)
    fields = decode_cdr(bytes(batch_to_cdr(batch)))
    decoded = decode_columns(codec, fields, 'robot_1')
    assert decoded.rejected == [] and decoded.sequence == 3 and decoded.session == 2 ** 63 + 5
    assert [m.in_reply_to for m in decoded.messages if m.kind is MessageKind.ACK] == [101, 102]
    assert [m for m in decoded.messages if m.kind is not MessageKind.ACK] == list(batch.messages)
    assert {key: fields[key] for key in encode_batch(batch)} == encode_batch(batch)


def test_the_middleware_check_agrees_with_rclpy_and_says_why_not_otherwise():
    assert WireCheck(rclpy_bytes, rclpy_fields).result() == (True, '')
    big_endian = WireCheck(lambda columns, stamp: b'\x00\x00\x00\x00' + rclpy_bytes(columns, stamp)[4:], rclpy_fields)
    assert big_endian.result() == (False, 'the middleware writes encapsulation 00000000, not CDR_LE')
    other_reader = WireCheck(rclpy_bytes, lambda data: {**rclpy_fields(data), 'sequence': 0})
    assert other_reader.result() == (False, 'it reads these batches differently')
    broken = WireCheck(lambda columns, stamp: 1 / 0, rclpy_fields)
    assert broken.result() == (False, 'ZeroDivisionError: division by zero')


@pytest.mark.parametrize('data', [b'', b'\x00\x00\x00\x00' + bytes(40), b'\x00\x01\x00\x00' + bytes(6),
                                  b'\x00\x01\x00\x00' + bytes(8) + b'\xff\xff\xff\x7f'])
def test_bytes_that_are_not_a_batch_are_refused(data):
    with pytest.raises(ValueError):
        decode_cdr(data)


def test_a_truncated_batch_is_refused():
    data = bytes(encode_cdr(SAMPLES[0], STAMP))
    for cut in range(4, len(data) - 1, 7):
        with pytest.raises(ValueError):
            decode_cdr(data[:cut])


def test_the_hubs_check_finds_that_this_middleware_agrees():
    from coalition_agents.transport.channel_hub import WIRE_CHECK
    assert WIRE_CHECK.result() == (True, '')
