"""Aggregation of the agent channel (core.transport.batching, no ROS): one batch per recipient per step,
piggybacked ACKs, negotiation messages first, a lost batch recovered by the retries, malformed
batches and malformed messages inside one, and the adaptive retry timeout."""
from __future__ import annotations

import pytest

from coalition_agents.core.transport.batching import Outbox, decode_batch, piggybacked_ack, processing_order
from coalition_agents.core.transport.codec import (
    ChannelCodec, MessageKind, commit_request_message, release_message, request_message,
)
from coalition_agents.core.errors import ConfigError, RequestError
from coalition_agents.core.transport.reliable_channel import ReliableChannel
from coalition_agents.core.transport.retry import RetryPolicy
from coalition_agents.core.requests import InformationRequest

TEAM = ('robot_1', 'robot_2', 'robot_3')


@pytest.fixture(scope='module')
def codec(library):
    return ChannelCodec.for_team(library, TEAM)


def request(library, sender, text, message_id):
    return request_message(InformationRequest(sender, library.parse(text, TEAM)), message_id)


def as_dict(batch):
    return {'sender': batch.sender, 'recipient': batch.recipient, 'sequence': batch.sequence,
            'messages': [m.to_dict() for m in batch.messages], 'acked_ids': list(batch.acked_ids)}


def test_outbox_sends_one_batch_per_recipient_with_piggybacked_acks(library):
    channel, outbox = ReliableChannel('robot_1'), Outbox('robot_1', ack_delay_s=0.01)
    copies = channel.send(request(library, 'robot_1', 'F_G(X)', channel.new_id()), 0.0, ['robot_2', 'robot_3'])
    copies += channel.send(request(library, 'robot_1', 'F_A(X)', channel.new_id()), 0.0, ['robot_2', 'robot_3'])
    incoming = request(library, 'robot_2', 'F_G(X)', 77).addressed_to('robot_1')
    ack = channel.receive(incoming, 0.0).replies
    assert [r.kind for r in ack] == [MessageKind.ACK]
    assert [outbox.put(m, 0.0) for m in copies + ack] == [False] * 5
    batches = {b.recipient: b for b in outbox.flush(0.0)}
    assert sorted(batches) == ['robot_2', 'robot_3']
    assert [m.message_id for m in batches['robot_2'].messages] == [c.message_id for c in copies
                                                                  if c.receiver == 'robot_2']
    assert batches['robot_2'].acked_ids == (77,) and batches['robot_3'].acked_ids == ()
    assert batches['robot_2'].logical_count == 3 and batches['robot_2'].sequence == 1
    assert outbox.flush(0.0) == [] and outbox.stats.batches == 2 and outbox.stats.acks == 1
    # ACKs alone wait ack_delay_s for a batch to ride on, then go as an ack-only batch.
    outbox.put(piggybacked_ack('robot_1', 'robot_3', 5), 1.0)
    assert outbox.next_ack_due() == pytest.approx(1.01) and outbox.flush(1.005) == []
    [alone] = outbox.flush(1.01)
    assert alone.messages == () and alone.acked_ids == (5,) and alone.sequence == 2
    assert outbox.stats.ack_only_batches == 1


def test_negotiation_messages_are_urgent_and_processed_first(library, codec):
    outbox = Outbox('robot_1')
    plain = request(library, 'robot_1', 'F_G(X)', 1).addressed_to('robot_2')
    commit = commit_request_message('robot_1', 2, 'robot_2', 'robot_1/2', ('robot_1', 'robot_2'), 9.0, 0.0)
    release = release_message('robot_1', 3, 'robot_2', 'robot_1/1')
    assert outbox.put(plain, 0.0) is False
    assert outbox.put(commit, 0.0) is True and outbox.put(release, 0.0) is True
    [batch] = outbox.flush(0.0, ['robot_2'])
    assert [m.kind for m in batch.messages] == [MessageKind.COMMIT_REQUEST, MessageKind.RELEASE, MessageKind.REQUEST]
    # The receiver processes them in the same order, after the piggybacked ACKs.
    data = as_dict(batch)
    data['messages'].reverse()
    data['acked_ids'] = [12]
    decoded = decode_batch(codec, data, 'robot_2')
    assert [m.kind for m in decoded.messages] == [MessageKind.ACK, MessageKind.RELEASE, MessageKind.COMMIT_REQUEST,
                                                  MessageKind.REQUEST]
    assert decoded.messages[0].in_reply_to == 12 and decoded.messages[0].sender == 'robot_1'
    assert processing_order([plain, commit]) == [commit, plain]


def test_a_lost_batch_is_recovered_by_retrying_only_the_unacked_messages(library, codec):
    policy = RetryPolicy(tail_timeout_s=0.1, backoff=2.0, max_timeout_s=1.0)
    sender, receiver = ReliableChannel('robot_1', policy), ReliableChannel('robot_2', policy)
    out_1, out_2 = Outbox('robot_1', 0.0), Outbox('robot_2', 0.0)
    first = sender.send(request(library, 'robot_1', 'F_G(X)', sender.new_id()), 0.0, ['robot_2'])
    for m in first:
        out_1.put(m, 0.0)
    [delivered] = out_1.flush(0.0)
    for m in decode_batch(codec, as_dict(delivered), 'robot_2').messages:
        for reply in receiver.receive(m, 0.01).replies:
            out_2.put(reply, 0.01)
    [acks] = out_2.flush(0.01)
    for m in decode_batch(codec, as_dict(acks), 'robot_1').messages:
        sender.receive(m, 0.02)
    assert sender.awaiting(first[0].message_id) == ()
    # The second batch is lost on the link: both its messages are re-sent, nothing else.
    second = sender.send(request(library, 'robot_1', 'F_A(X)', sender.new_id()), 0.05, ['robot_2'])
    second += sender.send(request(library, 'robot_1', 'F_R(X, robot_1)', sender.new_id()), 0.05, ['robot_2'])
    for m in second:
        out_1.put(m, 0.05)
    [lost] = out_1.flush(0.05)
    assert len(lost.messages) == 2
    resend, failed = sender.poll(0.5)
    assert failed == [] and sorted(m.message_id for m in resend) == sorted(m.message_id for m in second)
    for m in resend:
        out_1.put(m, 0.5)
    [retry] = out_1.flush(0.5)
    assert retry.sequence == lost.sequence + 1     # the receiver can see the gap
    decoded = decode_batch(codec, as_dict(retry), 'robot_2')
    delivered_now = [receiver.receive(m, 0.51) for m in decoded.messages]
    assert [r.deliver.message_id for r in delivered_now] == [m.message_id for m in retry.messages]
    for r in delivered_now:
        for reply in r.replies:
            out_2.put(reply, 0.51)
    [acks] = out_2.flush(0.51)
    assert sorted(acks.acked_ids) == sorted(m.message_id for m in second)
    for m in decode_batch(codec, as_dict(acks), 'robot_1').messages:
        sender.receive(m, 0.52)
    assert sender.next_deadline() == float('inf') and receiver.stats.delivered == 3


def test_malformed_batches_are_rejected_and_malformed_messages_alone(library, codec):
    good = request(library, 'robot_1', 'F_G(X)', 5).addressed_to('robot_2')
    other = request(library, 'robot_1', 'F_A(X)', 6).addressed_to('robot_2')
    base = {'sender': 'robot_1', 'recipient': 'robot_2', 'sequence': 3,
            'messages': [good.to_dict(), {**other.to_dict(), 'kind': 99}, other.to_dict(),
                         {**good.to_dict(), 'message_id': 9, 'sender': 'robot_3'}],
            'acked_ids': [4]}
    decoded = decode_batch(codec, base, 'robot_2')
    assert [m.message_id for m in decoded.messages if m.kind is not MessageKind.ACK] == [5, 6]
    assert [index for index, _ in decoded.rejected] == [1, 3]
    assert 'batch.messages[1].kind: unknown message kind 99' in decoded.rejected[0][1]
    assert 'from robot_3' in decoded.rejected[1][1]
    for changes, message in [({'sender': 'robot_9'}, 'batch.sender: must be a teammate of robot_2'),
                             ({'sender': 'robot_2'}, 'batch.sender: must be a teammate of robot_2'),
                             ({'recipient': 'robot_3'}, "batch.recipient: this inbox is robot_2's"),
                             ({'sequence': 0}, r'batch.sequence: must be an integer in \[1'),
                             ({'acked_ids': [3, 0]}, r'batch.acked_ids\[1\]: must be a message id')]:
        with pytest.raises(RequestError, match=message):
            decode_batch(codec, {**base, **changes}, 'robot_2')
    with pytest.raises(RequestError, match='batch.messages: missing required field'):
        decode_batch(codec, {k: v for k, v in base.items() if k != 'messages'}, 'robot_2')
    with pytest.raises(RequestError, match='batch: must be a mapping'):
        decode_batch(codec, [base], 'robot_2')


def test_outbox_validation(library):
    with pytest.raises(ConfigError, match='ack_delay_s: must be a number >= 0'):
        Outbox('robot_1', -1.0)
    outbox = Outbox('robot_1')
    with pytest.raises(RequestError, match='cannot send as'):
        outbox.put(request(library, 'robot_2', 'F_G(X)', 1).addressed_to('robot_3'), 0.0)
    with pytest.raises(RequestError, match='goes to one teammate'):
        outbox.put(request(library, 'robot_1', 'F_G(X)', 1), 0.0)


def test_tail_timeout_adapts_to_the_measured_round_trip_and_backs_off(library):
    policy = RetryPolicy(tail_timeout_s=0.05, min_timeout_s=0.05, backoff=2.0, max_timeout_s=2.0)
    sender = ReliableChannel('robot_1', policy)
    assert sender.tail_timeout('robot_2') == 0.05 and sender.round_trip('robot_2') is None

    def send(t):
        [copy] = sender.send(request(library, 'robot_1', 'F_G(X)', sender.new_id()), t, ['robot_2'])
        return copy

    def answer(copy, t):
        sender.receive(piggybacked_ack('robot_2', 'robot_1', copy.message_id), t)

    answer(send(0.0), 0.03)                                   # RTT sample 0.03 s
    assert sender.round_trip('robot_2') == pytest.approx(0.03)
    assert sender.tail_timeout('robot_2') == pytest.approx(0.09)    # SRTT + 4 RTTVAR (RFC 6298)
    late = send(1.0)
    assert sender.poll(1.089) == ([], []) and sender.poll(1.09)[0] == [late]
    assert sender.tail_timeout('robot_2') == pytest.approx(0.18)    # backed off after the expiry
    answer(late, 1.3)
    assert sender.round_trip('robot_2') == pytest.approx(0.03)      # Karn: no sample from a re-sent message
    assert sender.tail_timeout('robot_2') == pytest.approx(0.09)    # an answer ends the back-off
    busy = send(2.0)
    answer(busy, 2.15)
    assert sender.round_trip('robot_2') == pytest.approx(0.875 * 0.03 + 0.125 * 0.15)
    assert sender.tail_timeout('robot_2') == pytest.approx(0.045 + 4 * (0.75 * 0.015 + 0.25 * 0.12))
    assert sender.tail_timeout('robot_3') == 0.05             # per robot
    assert sender.stats.tail_resent == 1 and sender.stats.fast_resent == 0
