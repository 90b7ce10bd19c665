"""The columnar batch (core.transport.batch_columns; transport.batch_wire for the ROS message):
every kind of message survives encode -> AgentMessageBatch -> CDR -> decode unchanged, malformed
columns refuse the batch, a malformed message is refused alone, the recipient is read from the
serialized bytes, and the bag analysis reads the rows."""
from __future__ import annotations

import pytest

from coalition_agents.core.errors import RequestError
from coalition_agents.core.requests import InformationRequest
from coalition_agents.core.transport.batch_columns import (
    COLUMNS, check_columns, decode_columns, encode_batch, message_rows,
)
from coalition_agents.core.transport.batching import Batch
from coalition_agents.core.transport.codec import (
    ChannelCodec, MessageKind, OfferSummary, commit_request_message, information_message, offer_message,
    release_message, reply_message, request_message,
)

TEAM = ('robot_1', 'robot_2', 'robot_3', 'robot_4')


@pytest.fixture(scope='module')
def codec(library):
    return ChannelCodec.for_team(library, TEAM)


def every_kind(library):
    """One message of each kind from robot_2 to robot_1 (a request with a chain of two links)."""
    parse = lambda text: library.parse(text, TEAM)  # noqa: E731
    chain = (('robot_3', parse('F_G(robot_3)')), ('robot_4', parse('F_R(X, robot_3)')))
    request = request_message(InformationRequest('robot_2', parse('F_R(X, robot_2)'), chain), 11, 'robot_1')
    asked = request_message(InformationRequest('robot_1', parse('F_G(X)')), 5, 'robot_2')
    offer = offer_message(OfferSummary('robot_2', parse('F_G(X)'), parse('F_G(robot_2)'), 7.5,
                                       ('robot_2', 'robot_3')), 12, asked)
    commit = commit_request_message('robot_2', 13, 'robot_1', 'robot_2/1', ('robot_2', 'robot_1', 'robot_4'), 21.5, 3.0)
    accept = reply_message(MessageKind.COMMIT_ACCEPT, 14, 'robot_2', commit_request_message(
        'robot_1', 9, 'robot_2', 'robot_1/4', ('robot_1', 'robot_2'), 4.0, 0.0), coalition_id='robot_1/4')
    reject = reply_message(MessageKind.COMMIT_REJECT, 15, 'robot_2', commit_request_message(
        'robot_1', 10, 'robot_2', 'robot_1/5', ('robot_1', 'robot_2'), 4.0, 0.0), coalition_id='robot_1/5',
        reason='robot_2 runs one motor schema at a time')
    release = release_message('robot_2', 16, 'robot_1', 'robot_2/1', 'search again')
    value = information_message('robot_2', 17, 'robot_1', 'robot_1/4', parse('F_G(robot_2)'),
                                {'x': 1.5, 'y': -0.25, 'yaw': 0.3})
    return [commit, accept, reject, release, request, offer, value]


def wire(batch):
    """The columns after a trip through the ROS message and its CDR bytes."""
    from rclpy.serialization import deserialize_message, serialize_message
    from coalition_interfaces.msg import AgentMessageBatch
    from coalition_agents.transport.batch_wire import batch_from_ros, batch_to_ros, peek_addresses, peek_recipient
    data = serialize_message(batch_to_ros(batch))
    assert peek_recipient(data) == batch.recipient and peek_addresses(data) == (batch.sender, batch.recipient)
    return batch_from_ros(deserialize_message(data, AgentMessageBatch))


def test_every_kind_round_trips_through_the_columns_unchanged(library, codec):
    messages = every_kind(library)
    batch = Batch('robot_2', 'robot_1', 3, tuple(messages), (101, 102))
    columns = encode_batch(batch)
    assert set(COLUMNS) <= set(columns) and columns['kinds'] == [4, 5, 6, 7, 1, 2, 8]
    # the request: its label then its chain's labels; requesters beside
    assert columns['information_counts'][4] == 3 and columns['chain_lengths'][4] == 2
    assert columns['chain_requesters'] == ['robot_3', 'robot_4']
    for data in (columns, wire(batch)):
        decoded = decode_columns(codec, data, 'robot_1')
        assert decoded.rejected == [] and decoded.sequence == 3
        acks = [m for m in decoded.messages if m.kind is MessageKind.ACK]
        assert [m.in_reply_to for m in acks] == [101, 102]
        assert [m for m in decoded.messages if m.kind is not MessageKind.ACK] == messages


def test_an_ack_only_batch_and_an_empty_one(codec):
    decoded = decode_columns(codec, wire(Batch('robot_3', 'robot_1', 1, (), (7,))), 'robot_1')
    assert [(m.kind, m.in_reply_to) for m in decoded.messages] == [(MessageKind.ACK, 7)]


def test_columns_that_disagree_refuse_the_batch_naming_the_column(library, codec):
    columns = encode_batch(Batch('robot_2', 'robot_1', 1, tuple(every_kind(library)), ()))
    broken = {**columns, 'costs': columns['costs'][:-1]}
    with pytest.raises(RequestError, match=r'batch\.costs: 6 entries for 7 messages'):
        decode_columns(codec, broken, 'robot_1')
    broken = {**columns, 'referents': columns['referents'] + ['robot_9']}
    with pytest.raises(RequestError, match=r'batch\.referents: .* referent_counts adds up to'):
        check_columns(broken)
    with pytest.raises(RequestError, match=r'batch\.recipient: this inbox is robot_3'):
        decode_columns(codec, columns, 'robot_3')


def test_a_malformed_message_is_refused_alone(library, codec):
    messages = every_kind(library)
    columns = encode_batch(Batch('robot_2', 'robot_1', 1, tuple(messages), ()))
    columns['kinds'][0] = 42                              # unknown kind
    columns['values'][-1] = float('nan')                  # the streamed yaw
    columns['information_counts'][5] = 1                  # an offer with one information entry ...
    columns['information_counts'][6] = 2                  # ... the next message takes the other
    decoded = decode_columns(codec, columns, 'robot_1')
    rejected = dict(decoded.rejected)
    assert sorted(rejected) == [0, 5, 6]
    assert 'unknown message kind 42' in rejected[0]
    assert 'batch.messages[5].information_counts: a offer message carries 2' in rejected[5]
    assert decoded.messages == messages[1:5]


def test_the_bag_rows_name_kind_members_and_cost(library):
    columns = encode_batch(Batch('robot_2', 'robot_1', 1, tuple(every_kind(library)), ()))
    rows = list(message_rows(columns))
    assert rows[0] == (4, ('robot_2', 'robot_1', 'robot_4'), 21.5)
    assert rows[5] == (2, ('robot_2', 'robot_3'), 7.5) and rows[4] == (1, (), 0.0)


def test_peek_recipient_refuses_what_is_not_a_batch():
    from coalition_agents.transport.batch_wire import peek_recipient
    assert peek_recipient(b'') is None and peek_recipient(b'\x00\x01\x00\x00\xff\xff\xff\xff') is None


def test_a_batch_handed_over_in_process_gives_what_the_wire_gives(library, codec):
    """local_messages (a teammate in the same agent process: no wire, no codec) yields the messages
    decode_columns yields for the same batch: the piggybacked ACKs first, then processing order."""
    from coalition_agents.core.transport.batching import local_messages, processing_order
    messages = every_kind(library)
    batch = Batch('robot_2', 'robot_1', 4, tuple(processing_order(messages[::-1])), (5, 6))
    assert local_messages(batch) == decode_columns(codec, wire(batch), 'robot_1').messages


def test_the_bag_rows_survive_uint8_counts_adding_up_past_255(library):
    """A bag reader hands the count columns as uint8 arrays: the running position must not wrap."""
    import numpy as np
    members = tuple(f'robot_{i % 4 + 1}' for i in range(200))
    data = {'kinds': np.array([4, 4], dtype=np.uint8), 'member_counts': np.array([200, 200], dtype=np.uint8),
            'costs': np.array([1.0, 2.0]), 'members': list(members * 2)}
    rows = list(message_rows(data))
    assert rows[1] == (4, members, 2.0)
