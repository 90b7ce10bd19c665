"""The agent channel's core: link model statistics, the strict codec, retries, duplicates and
request-and-wait commitments -- in a simulated lossy network of several agents on a fake clock."""
from __future__ import annotations

import heapq
import itertools
import json
import math

import numpy as np
import pytest
from scipy import stats

from coalition_agents.core.transport.codec import (
    ChannelCodec, ChannelMessage, MessageKind, OfferSummary, commit_request_message, information_message,
    offer_message, release_message, reply_message, request_message,
)
from coalition_agents.core.errors import ConfigError, RequestError
from coalition_agents.core.transport.link_model import PRESETS, LinkModel
from coalition_agents.core.transport.commitments import CommitmentLedger
from coalition_agents.core.transport.reliable_channel import ReliableChannel
from coalition_agents.core.transport.retry import RetryPolicy
from coalition_agents.core.requests import InformationRequest

TEAM = ('robot_1', 'robot_2', 'robot_3', 'robot_4', 'robot_5', 'robot_6')


@pytest.fixture(scope='module')
def codec(library):
    return ChannelCodec.for_team(library, TEAM)


def label(library, text):
    return library.parse(text, TEAM)


# --- link model --------------------------------------------------------------------------------

def test_link_paper_preset_is_truncated_normal_with_the_analytic_moments():
    link = LinkModel.preset('paper_fig9', seed=11)
    delays = np.array([link.sample()[1] for _ in range(40000)])
    assert delays.min() >= 0.0
    # The truncated distribution's moments, independently from scipy.
    a = (0.0 - 0.00385) / 0.00505
    reference = stats.truncnorm(a, np.inf, loc=0.00385, scale=0.00505)
    assert link.delay.mean() == pytest.approx(reference.mean(), rel=1e-9)
    assert link.delay.std() == pytest.approx(reference.std(), rel=1e-9)
    assert delays.mean() == pytest.approx(reference.mean(), abs=6e-5)   # 5.79 ms, not 3.85 ms
    assert delays.std() == pytest.approx(reference.std(), abs=6e-5)
    # Truncated, not clipped: no pile of zero delays.
    assert np.mean(delays < 1e-4) < 0.01
    assert link.loss_probability == 0.0
    assert all(link.sample()[0] for _ in range(1000))


@pytest.mark.parametrize('loss', [0.0, 0.2, 0.5, 1.0])
def test_link_loss_rate_matches_probability(loss):
    link = LinkModel.preset('paper_fig9', loss_probability=loss, seed=5)
    delivered = np.array([link.sample()[0] for _ in range(20000)])
    assert 1.0 - delivered.mean() == pytest.approx(loss, abs=0.012)


def test_link_is_reproducible_by_seed_and_other_distributions():
    first = LinkModel.from_dict({'preset': 'paper_fig9', 'loss_probability': 0.3, 'seed': 9})
    second = LinkModel.from_dict({'preset': 'paper_fig9', 'loss_probability': 0.3, 'seed': 9})
    assert [first.sample() for _ in range(50)] == [second.sample() for _ in range(50)]
    constant = LinkModel.from_dict({'delay': {'distribution': 'constant', 'value_s': 0.02}, 'seed': 1})
    assert {constant.sample() for _ in range(20)} == {(True, 0.02)}
    uniform = LinkModel.from_dict({'delay': {'distribution': 'uniform', 'low_s': 0.01, 'high_s': 0.03},
                                   'seed': 2})
    delays = np.array([uniform.sample()[1] for _ in range(20000)])
    assert delays.min() >= 0.01 and delays.max() <= 0.03
    assert delays.mean() == pytest.approx(uniform.delay.mean(), abs=2e-4)
    assert delays.std() == pytest.approx(uniform.delay.std(), abs=2e-4)
    assert LinkModel.from_dict({'preset': 'ideal'}).sample() == (True, 0.0)
    assert set(PRESETS) >= {'paper_fig9', 'ideal'}


@pytest.mark.parametrize('config, message', [
    ({'preset': 'wifi'}, "link.preset: unknown preset 'wifi'"),
    ({}, 'link.delay: missing required field'),
    ({'preset': 'ideal', 'loss_probability': 1.5}, r'link.loss_probability: must be a number in \[0, 1\]'),
    ({'preset': 'ideal', 'loss_probability': True}, r'link.loss_probability: must be a number in \[0, 1\]'),
    ({'preset': 'ideal', 'seed': -1}, 'link.seed: must be an integer >= 0'),
    ({'preset': 'ideal', 'jitter': 1}, 'link.jitter: unknown field'),
    ({'delay': {'distribution': 'pareto'}}, "link.delay.distribution: unknown distribution 'pareto'"),
    ({'delay': {'distribution': 'normal', 'mean_s': 0.01}}, 'link.delay.std_s: missing required field'),
    ({'delay': {'distribution': 'normal', 'mean_s': 0.01, 'std_s': -1}}, 'link.delay.std_s: must be >= 0'),
    ({'delay': {'distribution': 'constant', 'value_s': 0.1, 'mean_s': 1}}, 'link.delay.mean_s: unknown field'),
    ({'delay': {'distribution': 'uniform', 'low_s': 0.2, 'high_s': 0.1}}, 'link.delay.high_s: must be >= low_s'),
    ({'delay': 'fast'}, 'link.delay: must be a mapping'),
])
def test_link_config_errors_name_the_field(config, message):
    with pytest.raises(ConfigError, match=message):
        LinkModel.from_dict(config)


# --- codec -----------------------------------------------------------------------------------------

def sample_messages(library):
    request = InformationRequest('robot_1', label(library, 'F_R(X, robot_1)'),
                                 (('robot_3', label(library, 'F_G(X)')),))
    req = request_message(request, 41)
    offer = OfferSummary('robot_2', request.label, label(library, 'F_R(robot_2, robot_1)'), 8.5,
                         ('robot_2', 'robot_4'))
    return [
        req,
        req.addressed_to('robot_2'),
        offer_message(offer, 7, req),
        reply_message(MessageKind.ACK, 8, 'robot_2', req),
        commit_request_message('robot_1', 42, 'robot_2', 'robot_1/1', ('robot_1', 'robot_2'), 16.0, 2.5),
        ChannelMessage(MessageKind.COMMIT_ACCEPT, 9, 'robot_2', 'robot_1', in_reply_to=42, coalition_id='robot_1/1'),
        ChannelMessage(MessageKind.COMMIT_REJECT, 10, 'robot_2', 'robot_1', in_reply_to=42, coalition_id='robot_1/1',
                       reason='busy'),
        release_message('robot_1', 43, 'robot_2', 'robot_1/1', 'done'),
        ChannelMessage(MessageKind.REQUEST, 44, 'robot_5', request=InformationRequest(
            'robot_5', label(library, 'F_M'))),
        information_message('robot_2', 45, 'robot_1', 'robot_1/1', label(library, 'F_G(robot_2)'),
                            {'x': 1.0, 'y': 2.0}),
    ]


def test_codec_round_trips_every_kind(library, codec):
    messages = sample_messages(library)
    assert {m.kind for m in messages} == set(MessageKind)
    for message in messages:
        assert codec.decode(message.to_dict()) == message
        assert codec.from_json(message.to_json()) == message
        assert codec.from_json(message.to_json().encode()) == message
        assert codec.check_outgoing(message) == message
    offer = codec.decode(messages[2].to_dict())
    assert offer.offer.instance == label(library, 'F_R(robot_2, robot_1)')
    assert offer.conversation_id == 41 and offer.in_reply_to == 41
    assert codec.decode(messages[0].to_dict()).request.chain == ((('robot_3', label(library, 'F_G(X)'))),)


def test_codec_canonicalises_request_variables(library, codec):
    data = sample_messages(library)[0].to_dict()
    data['label'] = {'type': 'F_R', 'referents': ['Z7', 'robot_1']}
    assert str(codec.decode(data).request.label) == 'F_R(X, robot_1)'


def test_codec_checks_a_repeated_instance_once_and_a_malformed_one_every_time(library):
    codec = ChannelCodec.for_team(library, TEAM)
    data = sample_messages(library)[0].to_dict()
    data['label'] = {'type': 'F_R', 'referents': ['Z7', 'robot_1']}
    first, again = codec.decode(data), codec.decode(json.loads(json.dumps(data)))
    assert first.request.label is again.request.label            # the checked instance, kept
    data['label'] = {'type': 'F_R', 'referents': ['robot_1', 'robot_1']}
    for _ in range(2):
        with pytest.raises(RequestError, match='an entity appears twice'):
            codec.decode(data)


def mutate(data, path, value):
    data = json.loads(json.dumps(data))
    target = data
    for key in path[:-1]:
        target = target[key]
    if value is DELETE:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return data


DELETE = object()

# (message index in sample_messages, field path, new value, expected error)
CODEC_ERRORS = [
    (0, ('kind',), 'shout', "message.kind: unknown message kind 'shout'"),
    (0, ('kind',), 9, 'message.kind: unknown message kind 9'),
    (0, ('label', 'type'), 'F_Q', "message.label.type: unknown information type 'F_Q'"),
    (0, ('label', 'referents'), 'X', 'message.label.referents: must be a list'),
    (0, ('label', 'referents', 1), 'robot 1', "message.label.referents\\[1\\]: malformed referent 'robot 1'"),
    (0, ('label', 'referents', 1), 3, 'message.label.referents\\[1\\]: malformed referent 3'),
    (0, ('label', 'referents', 1), 'robot_9', "message.label.referents\\[1\\]: unknown entity 'robot_9'"),
    (0, ('label', 'referents', 1), 'local', "message.label.referents\\[1\\]: messages name robots, not 'local'"),
    (0, ('label', 'referents'), ['X'], 'message.label.referents: .*has 2 referents'),
    (0, ('label', 'referents'), ['robot_1', 'robot_1'], 'message.label.referents: an entity appears twice'),
    (0, ('label', 'colour'), 'red', 'message.label.colour: unknown field'),
    (0, ('chain', 0, 'requester'), 'nobody', "message.chain\\[0\\].requester: unknown robot 'nobody'"),
    (0, ('chain', 0), {'requester': 'robot_3'}, 'message.chain\\[0\\]: must be a mapping with requester and label'),
    (0, ('chain',), {}, 'message.chain: must be a list'),
    (0, ('sender',), 'robot_9', "message.sender: unknown robot 'robot_9'"),
    (0, ('receiver',), 'robot_9', "message.receiver: unknown robot 'robot_9'"),
    (0, ('message_id',), 0, 'message.message_id: must be an integer in \\[1, 2\\^64 - 1\\]'),
    (0, ('message_id',), 2 ** 64, 'message.message_id: must be an integer'),
    (0, ('message_id',), '5', 'message.message_id: must be an integer'),
    (0, ('conversation_id',), -1, 'message.conversation_id: must be an integer in \\[0'),
    (0, ('label',), DELETE, 'message.label: missing required field of a request message'),
    (0, ('cost',), 3.0, 'message.cost: unknown field for a request message'),
    (2, ('instance', 'referents', 0), 'Y', 'message.instance: an offer provides actual information'),
    (2, ('instance',), {'type': 'F_G', 'referents': ['robot_2']},
     'message.instance: type F_G does not answer the requested'),
    (2, ('cost',), -1.0, 'message.cost: must be a finite number >= 0'),
    (2, ('cost',), float('nan'), 'message.cost: must be a finite number >= 0'),
    (2, ('members',), ['robot_4'], 'message.members: the provider robot_2 must be a member'),
    (2, ('members',), [], 'message.members: must be a non-empty list'),
    (2, ('members',), ['robot_2', 'robot_2'], 'message.members: a robot is listed twice'),
    (2, ('in_reply_to',), 0, 'message.in_reply_to: a offer message must name the message it answers'),
    (3, ('receiver',), '', "message.receiver: a ack message goes to one robot"),
    (4, ('coalition_id',), '  ', 'message.coalition_id: must be a non-empty string'),
    (4, ('hold_seconds',), -2, 'message.hold_seconds: must be a finite number >= 0'),
    (4, ('members',), ['robot_2', 'robot_3'], 'message.members: the leader robot_1 must be a member'),
    (6, ('reason',), 5, 'message.reason: must be a string'),
]


@pytest.mark.parametrize('index, path, value, message', CODEC_ERRORS)
def test_codec_errors_name_the_field(library, codec, index, path, value, message):
    data = mutate(sample_messages(library)[index].to_dict(), path, value)
    with pytest.raises(RequestError, match=message):
        codec.decode(data)


@pytest.mark.parametrize('payload, message', [
    ('[1, 2]', 'message: must be a mapping'),
    ('{"kind": ', 'message: invalid JSON'),
    (b'\xff\xfe', 'message: not UTF-8 text'),
    (42, 'message: must be JSON text'),
])
def test_codec_rejects_non_messages(codec, payload, message):
    with pytest.raises(RequestError, match=message):
        codec.from_json(payload)


def test_ros_message_conversion_round_trips(library, codec):
    """AgentMessage <-> dict (the node adapter's conversion) loses nothing the codec checks."""
    from coalition_agents.transport.agent_channel import from_ros, to_ros
    from coalition_interfaces.msg import AgentMessage
    for message in sample_messages(library):
        ros = to_ros(message)
        assert ros.kind == int(message.kind)
        assert codec.decode(from_ros(ros)) == message
    unknown = AgentMessage(kind=77, message_id=1, sender='robot_1')
    with pytest.raises(RequestError, match='message.kind: unknown message kind 77'):
        codec.decode(from_ros(unknown))


def test_ros_information_message_carries_typed_values(library):
    """The streamed value is in AgentMessage.values (NamedValue[]), not text in ``reason``."""
    from coalition_agents.transport.agent_channel import to_ros
    from coalition_interfaces.msg import AgentMessage
    ros = to_ros(sample_messages(library)[-1])
    assert ros.kind == AgentMessage.INFORMATION == int(MessageKind.INFORMATION)
    assert [(entry.name, entry.value) for entry in ros.values] == [('x', 1.0), ('y', 2.0)]
    assert ros.reason == '' and ros.coalition_id == 'robot_1/1'
    assert (ros.instance.type, list(ros.instance.referents)) == ('F_G', ['robot_2'])


def ros_information(**changes):
    """A well-formed INFORMATION AgentMessage from robot_2 to robot_1, with ``changes``."""
    from coalition_interfaces.msg import AgentMessage, Information, NamedValue
    fields = {'message_id': 45, 'sender': 'robot_2', 'receiver': 'robot_1', 'kind': AgentMessage.INFORMATION,
              'instance': Information(type='F_G', referents=['robot_2']), 'coalition_id': 'robot_1/1',
              'values': [NamedValue(name='x', value=1.0), NamedValue(name='y', value=2.0)]}
    fields.update(changes)
    return AgentMessage(**fields)


def named(*pairs):
    from coalition_interfaces.msg import NamedValue
    return [NamedValue(name=name, value=value) for name, value in pairs]


@pytest.mark.parametrize('changes, message', [
    ({'values': named(('x', 1.0), ('y', math.nan))}, 'message.values.y: must be a finite number (got float nan)'),
    ({'values': named(('x', math.inf), ('y', 2.0))}, 'message.values.x: must be a finite number (got float inf)'),
    ({'values': named(('x', 1.0), ('y', 2.0), ('y', 2.5))},
     'message.values.y: given twice (at message.values[1] and message.values[2]'),
    ({'values': named(('x', 1.0), ('y', 2.0), ('speed', 0.3))},
     'message.values.speed: unknown field of a F_G value (allowed: x, y, yaw)'),
    ({'values': named(('x', 1.0))}, 'message.values.y: missing required field of a F_G value'),
    ({'values': named(('x', 1.0), ('', 2.0))}, 'message.values[1].name: must be a non-empty field name'),
    ({'coalition_id': ''}, 'message.coalition_id: must be a non-empty string'),
    ({'receiver': ''}, 'message.receiver: an information message goes to one robot'),
])
def test_malformed_ros_information_messages_are_rejected_naming_the_field(codec, changes, message):
    """What a peer (or a bug) can put on the wire: the codec rejects it, the channel logs and drops it."""
    from coalition_agents.transport.agent_channel import from_ros
    assert codec.decode(from_ros(ros_information())).values == (('x', 1.0), ('y', 2.0))  # the base is valid
    with pytest.raises(RequestError) as caught:
        codec.decode(from_ros(ros_information(**changes)))
    assert message in str(caught.value)


# --- reliable channel: single steps --------------------------------------------------------------

def test_retry_policy_backoff_and_validation():
    policy = RetryPolicy(tail_timeout_s=0.05, min_timeout_s=0.01, backoff=2.0, max_timeout_s=0.3,
                         peer_timeout_s=2.0, message_lifetime_s=3.0)
    assert [policy.tail_timeout(0.0, k) for k in range(5)] == pytest.approx([0.05, 0.1, 0.2, 0.3, 0.3])
    assert policy.tail_timeout(0.12, 1) == pytest.approx(0.24)   # the measured round trip, once there is one
    assert policy.tail_timeout(0.001, 0) == pytest.approx(0.01)  # at least min_timeout_s
    assert policy.duplicate_memory_s == pytest.approx(4.0)       # the lifetime + 1 s in flight
    assert RetryPolicy().reorder_window_s == 0.05
    for data, message in [({'tail_timeout_s': 0}, 'retry.tail_timeout_s: must be a number > 0'),
                          ({'reorder_window_s': -0.1}, 'retry.reorder_window_s: must be a number >= 0'),
                          ({'backoff': 0.5}, 'retry.backoff: must be a number >= 1'),
                          ({'peer_timeout_s': 0}, 'retry.peer_timeout_s: must be a number > 0'),
                          ({'min_timeout_s': -1}, 'retry.min_timeout_s: must be a number > 0'),
                          ({'max_timeout_s': 0.01}, 'retry.max_timeout_s: must be a number >= tail_timeout_s'),
                          ({'message_lifetime_s': 1.0}, 'retry.message_lifetime_s: must be a number >= peer_timeout_s'),
                          ({'duplicate_memory_s': 1.0}, 'retry.duplicate_memory_s: must be >= message_lifetime_s'),
                          ({'retries': 3}, 'retry.retries: unknown field')]:
        with pytest.raises(ConfigError, match=message):
            RetryPolicy.from_dict(data)


def test_request_is_retried_with_backoff_until_acked_and_duplicates_delivered_once(library):
    """A lone message (a tail loss: nothing later to prove it lost) falls back to the backed-off timeout."""
    policy = RetryPolicy(tail_timeout_s=0.1, backoff=2.0, max_timeout_s=1.0)
    sender, receiver = ReliableChannel('robot_1', policy), ReliableChannel('robot_2', policy)
    request = request_message(InformationRequest('robot_1', label(library, 'F_G(X)')), sender.new_id())
    [copy] = sender.send(request, 0.0, ['robot_2'])
    assert copy.receiver == 'robot_2' and sender.awaiting(request.message_id) == ('robot_2',)
    assert sender.poll(0.09) == ([], [])
    assert sender.poll(0.1)[0] == [copy]             # first retry after 0.1 s
    assert sender.poll(0.29)[0] == []
    assert sender.poll(0.3 + 1e-9)[0] == [copy]      # then after 0.2 s more
    first = receiver.receive(copy, 0.31)
    assert first.deliver == copy and [r.kind for r in first.replies] == [MessageKind.ACK]
    again = receiver.receive(copy, 0.32)               # the retry of a lost ACK
    assert again.deliver is None and again.duplicate and again.replies == first.replies
    assert receiver.stats.delivered == 1 and receiver.stats.duplicates == 1
    assert sender.receive(again.replies[0], 0.33).deliver is None
    assert sender.awaiting(request.message_id) == () and sender.next_deadline() == math.inf
    assert sender.receive(first.replies[0], 0.34).deliver is None   # a late duplicate ACK: harmless
    assert sender.stats.answered == 1 and sender.stats.resent == 2


def test_silent_peers_are_given_up_after_peer_timeout(library):
    policy = RetryPolicy(tail_timeout_s=0.1, min_timeout_s=0.1, backoff=1.0, max_timeout_s=0.1, peer_timeout_s=0.25)
    sender = ReliableChannel('robot_1', policy)
    request = request_message(InformationRequest('robot_1', label(library, 'F_G(X)')), sender.new_id())
    sender.send(request, 0.0, ['robot_2', 'robot_3'])
    sends = 2
    failed = []
    for step in range(1, 10):
        resend, gave_up = sender.poll(step * 0.1 + 1e-9)
        sends += len(resend)
        failed += gave_up
    assert sends == 6                                 # sent at 0, re-sent at 0.1 and 0.2, given up at 0.25
    assert sorted(f.receiver for f in failed) == ['robot_2', 'robot_3'] and {f.attempts for f in failed} == {3}
    assert sender.stats.undelivered == 2


def test_messages_for_others_and_own_echoes_are_ignored(library):
    channel = ReliableChannel('robot_2')
    request = request_message(InformationRequest('robot_1', label(library, 'F_G(X)')), 1, receiver='robot_3')
    assert channel.receive(request, 0.0).deliver is None
    own = request_message(InformationRequest('robot_2', label(library, 'F_G(X)')), 1)
    assert channel.receive(own, 0.0).deliver is None
    assert channel.stats.ignored == 2
    with pytest.raises(RequestError, match='cannot send to itself'):
        channel.send(own, 0.0, ['robot_2'])
    with pytest.raises(RequestError, match='a broadcast needs its recipients'):
        channel.send(own, 0.0)
    with pytest.raises(RequestError, match='cannot send as'):
        channel.send(request, 0.0)


def test_commitment_ledger_holds_one_coalition():
    ledger = CommitmentLedger('robot_2')
    assert ledger.hold('x', 'robot_1', ('robot_1', 'robot_2'), 0.0, 2.0) == (True, '')
    accepted, reason = ledger.hold('y', 'robot_3', ('robot_3', 'robot_2'), 1.0, 2.0)
    assert not accepted and reason == 'robot_2 is committed to coalition x of robot_1'
    assert ledger.hold('x', 'robot_1', ('robot_1', 'robot_2'), 1.5, 2.0) == (True, '')   # renewed to 3.5
    assert not ledger.hold('y', 'robot_3', ('robot_3', 'robot_2'), 3.4, 2.0)[0]
    assert ledger.hold('y', 'robot_3', ('robot_3', 'robot_2'), 3.5, 2.0)[0]                # x expired
    assert not ledger.release('x', 'robot_1', 3.6) and ledger.release('y', 'robot_3', 3.6)
    assert ledger.active(3.6) is None
    assert [event for _, event, _ in ledger.history] == ['committed', 'renewed', 'expired', 'committed', 'released']


def test_commit_request_conflicts_are_rejected_and_duplicates_answered_consistently():
    helper = ReliableChannel('robot_2')
    x = commit_request_message('robot_1', 5, 'robot_2', 'x', ('robot_1', 'robot_2'), 10.0, 1.0)
    y = commit_request_message('robot_3', 5, 'robot_2', 'y', ('robot_3', 'robot_2'), 9.0, 1.0)
    answer_x = helper.receive(x, 0.0)
    assert answer_x.accepted and answer_x.replies[0].kind is MessageKind.COMMIT_ACCEPT
    answer_y = helper.receive(y, 0.1)
    assert answer_y.accepted is False and answer_y.replies[0].kind is MessageKind.COMMIT_REJECT
    assert 'committed to coalition x of robot_1' in answer_y.replies[0].reason
    assert helper.receive(x, 0.5).replies[0].kind is MessageKind.COMMIT_ACCEPT      # retry while held
    late = helper.receive(x, 1.2)                                                   # retry after expiry
    assert late.deliver is None and late.replies[0].kind is MessageKind.COMMIT_REJECT
    assert helper.ledger.active(1.2) is None
    # A COMMIT_REQUEST overtaken by its coalition's RELEASE does not commit the helper.
    release = release_message('robot_3', 6, 'robot_2', 'z')
    assert helper.receive(release, 2.0).replies[0].kind is MessageKind.ACK
    z = commit_request_message('robot_3', 7, 'robot_2', 'z', ('robot_3', 'robot_2'), 9.0, 0.0)
    assert helper.receive(z, 2.1).accepted is False and helper.ledger.active(2.1) is None


def test_negotiation_fails_on_reject_and_releases_every_helper():
    leader, h2, h3 = (ReliableChannel(name) for name in ('robot_1', 'robot_2', 'robot_3'))
    assert h3.ledger.hold('other', 'robot_4', ('robot_4', 'robot_3'), 0.0, 0.0)[0]
    negotiation, requests, reason = leader.propose('c1', ('robot_1', 'robot_2', 'robot_3'), 12.0, 0.0, 5.0)
    assert reason == '' and sorted(m.receiver for m in requests) == ['robot_2', 'robot_3']
    assert negotiation.state(0.0) == 'waiting' and leader.ledger.holds('c1', 'robot_1', 0.0)
    for message in requests:
        helper = h2 if message.receiver == 'robot_2' else h3
        for reply in helper.receive(message, 0.01).replies:
            leader.receive(reply, 0.02)
    assert negotiation.accepted == {'robot_2'} and negotiation.state(0.02) == 'failed'
    releases = leader.release('c1', 0.03, 'robot_3 is busy')
    assert sorted(m.receiver for m in releases) == ['robot_2', 'robot_3']
    assert leader.ledger.active(0.03) is None and negotiation.state(0.03) == 'released'
    h2.receive(releases[0] if releases[0].receiver == 'robot_2' else releases[1], 0.04)
    assert h2.ledger.active(0.04) is None
    with pytest.raises(RequestError, match="'c1' was already used"):
        leader.propose('c1', ('robot_1', 'robot_2'), 1.0, 0.1, 1.0)


# --- simulated lossy network of agents on a fake clock -------------------------------------------

class Network:
    """Agents exchanging JSON over links with the given loss and the paper's delay; every copy
    goes through the codec on arrival, as on the real channel."""

    def __init__(self, codec, loss, seed, policy=RetryPolicy(), team=TEAM):
        self.codec = codec
        self.now = 0.0
        self.agents = {name: ReliableChannel(name, policy, first_message_id=1000 * (i + 1))
                       for i, name in enumerate(team)}
        self.links = {name: LinkModel.preset('paper_fig9', loss_probability=loss, seed=seed * 100 + i)
                      for i, name in enumerate(team)}
        self.queue: list = []
        self.sequence = itertools.count()
        self.lost = 0
        self.delivered: list[tuple[str, ChannelMessage]] = []

    def transmit(self, copies):
        for copy in copies:
            delivered, delay = self.links[copy.sender].sample()
            if not delivered:
                self.lost += 1
                continue
            heapq.heappush(self.queue, (self.now + delay, next(self.sequence), copy.to_json()))

    def run_until(self, end, on_deliver=None, on_tick=None, tick=0.005):
        next_tick = self.now
        while self.now < end:
            arrival = self.queue[0][0] if self.queue else math.inf
            if next_tick <= arrival:
                self.now = next_tick
                next_tick += tick
                for agent in self.agents.values():
                    resend, _ = agent.poll(self.now)
                    self.transmit(resend)
                if on_tick is not None:
                    on_tick()
                continue
            self.now, _, text = heapq.heappop(self.queue)
            message = self.codec.from_json(text)
            agent = self.agents[message.receiver]
            received = agent.receive(message, self.now)
            self.transmit(received.replies)
            if received.deliver is not None:
                self.delivered.append((agent.robot, received.deliver))
                if on_deliver is not None:
                    on_deliver(agent, received.deliver)

    def idle(self):
        return not self.queue and all(agent.next_deadline() == math.inf for agent in self.agents.values())


@pytest.mark.parametrize('loss', [0.2, 0.5])
def test_every_request_answered_exactly_once_under_loss(library, codec, loss):
    policy = RetryPolicy(tail_timeout_s=0.05, backoff=1.5, max_timeout_s=0.2, peer_timeout_s=20.0)
    net = Network(codec, loss, seed=int(loss * 10), policy=policy)
    labels = [label(library, text) for text in ('F_G(X)', 'F_R(X, goal)', 'F_A(X)')]
    sent_requests = []

    def answer(agent, message):
        if message.kind is MessageKind.REQUEST:
            offer = OfferSummary(agent.robot, message.request.label,
                                 message.request.label.substitute({message.request.label.variables[0]:
                                                                   codec.catalog.entity(agent.robot)}),
                                 1.0, (agent.robot,))
            net.transmit(agent.send(offer_message(offer, agent.new_id(), message), net.now))

    for name, agent in net.agents.items():
        for text in labels:
            request = request_message(InformationRequest(name, text), agent.new_id())
            sent_requests.append(request)
            net.transmit(agent.send(request, 0.0, [r for r in TEAM if r != name]))
    net.run_until(60.0, on_deliver=answer)
    assert net.idle()
    requests = [(robot, m.key) for robot, m in net.delivered if m.kind is MessageKind.REQUEST]
    offers = [(robot, m.key) for robot, m in net.delivered if m.kind is MessageKind.OFFER]
    expected = len(TEAM) * (len(TEAM) - 1) * len(labels)
    # Every request reached every teammate exactly once, every offer its requester exactly once.
    assert len(requests) == len(set(requests)) == expected
    assert len(offers) == len(set(offers)) == expected
    assert {(robot, key) for robot, key in requests} == {
        (robot, m.key) for m in sent_requests for robot in TEAM if robot != m.sender}
    duplicates = sum(agent.stats.duplicates for agent in net.agents.values())
    resent = sum(agent.stats.resent for agent in net.agents.values())
    assert net.lost > 0.8 * loss * (expected * 4) and resent > 0 and duplicates > 0
    assert sum(agent.stats.undelivered for agent in net.agents.values()) == 0


@pytest.mark.parametrize('loss, seed', [(0.2, 1), (0.2, 2), (0.5, 3)])
def test_coalitions_form_under_loss_without_conflicting_commitments(codec, loss, seed):
    """Three leaders compete for overlapping helpers (request-and-wait, retries with a random
    back-off after a failure, each coalition 'executes' 0.3 s and is released): every leader gets
    its coalition and at no time does a robot belong to two established coalitions."""
    policy = RetryPolicy(tail_timeout_s=0.03, backoff=2.0, max_timeout_s=0.2, peer_timeout_s=1.0)
    net = Network(codec, loss, seed=seed, policy=policy)
    rng = np.random.default_rng(seed)
    wants = {'robot_1': ('robot_1', 'robot_4', 'robot_5'),
             'robot_2': ('robot_2', 'robot_5', 'robot_6'),
             'robot_3': ('robot_3', 'robot_4', 'robot_6')}
    state = {leader: {'negotiation': None, 'retry_at': 0.0, 'done': False, 'established_at': None, 'attempt': 0}
             for leader in wants}
    established_log = []
    checks = 0

    def on_tick():
        nonlocal checks
        now = net.now
        for leader, info in state.items():
            agent = net.agents[leader]
            negotiation = info['negotiation']
            if info['done']:
                continue
            if negotiation is None:
                if now >= info['retry_at']:
                    info['attempt'] += 1
                    negotiation, messages, _ = agent.propose(f"{leader}/{info['attempt']}", wants[leader], 10.0,
                                                             now, hold_seconds=1.5)
                    info['negotiation'] = negotiation
                    net.transmit(messages)
                    if negotiation is None:
                        info['retry_at'] = now + rng.uniform(0.05, 0.4)
                continue
            current = negotiation.state(now)
            if current == 'established' and info['established_at'] is None:
                info['established_at'] = now
                established_log.append((leader, negotiation.coalition_id, now))
            if current == 'established' and now - info['established_at'] >= 0.3:
                net.transmit(agent.release(negotiation.coalition_id, now, 'task done'))
                info['done'] = True
            elif current in ('failed', 'expired'):
                net.transmit(agent.release(negotiation.coalition_id, now, 'negotiation failed'))
                info['negotiation'] = None
                info['established_at'] = None
                info['retry_at'] = now + rng.uniform(0.05, 0.4)
        # The invariant: a robot is in at most one established coalition, and holds it.
        holders: dict[str, list[str]] = {}
        for leader, info in state.items():
            negotiation = info['negotiation']
            if negotiation is not None and negotiation.state(now) == 'established':
                for robot in negotiation.members:
                    holders.setdefault(robot, []).append(negotiation.coalition_id)
                    assert net.agents[robot].ledger.holds(negotiation.coalition_id, leader, now), \
                        f'{robot} does not hold {negotiation.coalition_id} at {now:.3f}'
        assert all(len(ids) <= 1 for ids in holders.values()), holders
        checks += 1

    net.run_until(30.0, on_tick=on_tick)
    assert all(info['done'] for info in state.values()), state
    assert sorted(leader for leader, _, _ in established_log) == sorted(wants)
    assert checks > 1000
    # Every helper ends free (the RELEASEs were acknowledged or the holds expired).
    assert all(agent.ledger.active(net.now) is None for agent in net.agents.values())
    # Ledgers never held two commitments at once: every 'committed' follows a release/expiry.
    for agent in net.agents.values():
        held = None
        for _, event, coalition in agent.ledger.history:
            if event == 'committed':
                assert held is None, agent.ledger.history
                held = coalition
            elif event in ('released', 'expired'):
                assert held == coalition
                held = None
