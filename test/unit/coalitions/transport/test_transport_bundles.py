"""A processing step's batches as one bundle of serialized bytes (transport.batch_cdr): rclpy reads
the bytes encode_bundle writes as the bundle they encode -- each batch in place, whatever its
alignment -- decode_bundle reads rclpy's bytes, decodes only the batches a receiver wants, and
refuses what is not a bundle; the middleware check covers bundles."""
from __future__ import annotations

import random

import pytest

from coalition_agents.transport.batch_cdr import SAMPLES, WireCheck, bundle_samples, decode_bundle, encode_bundle
from test_transport_cdr import STAMP, random_columns, rclpy_bytes, rclpy_fields


def rclpy_bundle_bytes(batches, stamp_ns: int) -> bytes:
    from rclpy.serialization import serialize_message
    from coalition_agents.transport.channel_hub import _typed_bundle
    return serialize_message(_typed_bundle(batches, stamp_ns))


def rclpy_bundle_fields(data: bytes):
    from coalition_agents.transport.channel_hub import _bundle_fields
    return _bundle_fields(data)


def random_bundle(rng: random.Random) -> list:
    return [(random_columns(rng), rng.randrange(2 ** 31 * 1_000_000_000)) for _ in range(rng.choice([0, 1, 2, 5, 9]))]


def test_rclpy_reads_the_bundle_bytes_and_decode_bundle_reads_rclpys():
    rng = random.Random(7)
    for batches in [bundle_samples(), *(random_bundle(rng) for _ in range(150))]:
        wanted = [{**columns, 'stamp_ns': stamp} for columns, stamp in batches]
        assert rclpy_bundle_fields(bytes(encode_bundle(batches, STAMP))) == (STAMP, wanted)
        assert decode_bundle(rclpy_bundle_bytes(batches, STAMP)) == (STAMP, wanted)


def test_only_the_wanted_batches_are_decoded_the_others_are_skipped():
    rng = random.Random(11)
    for _ in range(100):
        batches = random_bundle(rng)
        asked = []

        def wanted(sender, recipient):
            asked.append((sender, recipient))
            return recipient == 'robot_13' and sender != 'r'
        stamp, read = decode_bundle(bytes(encode_bundle(batches, STAMP)), wanted)
        assert stamp == STAMP and asked == [(c['sender'], c['recipient']) for c, _ in batches]
        assert read == [{**c, 'stamp_ns': s} for c, s in batches if c['recipient'] == 'robot_13' and c['sender'] != 'r']


def test_a_truncated_bundle_or_a_batch_is_refused():
    data = bytes(encode_bundle(bundle_samples()[:3], STAMP))
    for cut in range(4, len(data) - 1, 5):
        with pytest.raises(ValueError):
            decode_bundle(data[:cut])
    with pytest.raises(ValueError):
        decode_bundle(b'\x00\x00\x00\x00' + data[4:])  # not CDR_LE


def test_the_middleware_check_covers_bundles():
    assert WireCheck(rclpy_bytes, rclpy_fields, rclpy_bundle_bytes, rclpy_bundle_fields).result() == (True, '')
    shifted = WireCheck(rclpy_bytes, rclpy_fields, rclpy_bundle_bytes,
                        lambda data: (0, rclpy_bundle_fields(data)[1]))
    assert shifted.result() == (False, 'it reads these bundles differently')
    dropping = WireCheck(rclpy_bytes, rclpy_fields, lambda batches, stamp: rclpy_bundle_bytes(batches[1:], stamp),
                         rclpy_bundle_fields)
    assert dropping.result() == (False, 'its bundles read back differently')
    assert len(SAMPLES) * 8 == len(bundle_samples())
