"""Streamed information values: latest wins, stale detection, value checks, Table I conversions,
and the INFORMATION message of the agent channel that carries them."""
from __future__ import annotations

import math

import pytest

from coalition_agents.core.errors import RequestError
from coalition_agents.core.information import Entity, InformationInstance
from coalition_agents.core.transport.information_stream import InformationStream
from coalition_agents.core.value_fields import MAX_FIELDS, check_value, check_value_fields
from coalition_agents.core.information_values import (
    ValueUnavailable, global_from_relative, relative_composition, relative_inverse, torque_from_force,
)

A, B = Entity('robot_a', robot=True), Entity('robot_b', robot=True)
GA = InformationInstance('F_G', (A,))
RBA = InformationInstance('F_R', (B, A))


def test_the_latest_value_wins_even_when_an_older_one_arrives_later():
    stream = InformationStream(timeout_s=0.5)
    assert stream.update('robot_a', GA, {'x': 1.0, 'y': 0.0}, sequence=5, now=0.0)
    assert not stream.update('robot_a', GA, {'x': 0.0, 'y': 0.0}, sequence=4, now=0.1)  # reordered by the link
    assert stream.value('robot_a', GA, 0.1) == {'x': 1.0, 'y': 0.0}
    assert stream.out_of_order == 1


def test_a_value_goes_stale_after_the_timeout_and_forget_drops_a_provider():
    stream = InformationStream(timeout_s=0.5)
    stream.update('robot_a', GA, {'x': 1.0, 'y': 0.0}, 1, now=0.0)
    assert stream.value('robot_a', GA, 0.5) is not None
    assert stream.value('robot_a', GA, 0.51) is None
    assert stream.stale([('robot_a', GA), ('robot_b', GA)], 0.2) == [('robot_b', GA)]
    assert stream.age('robot_a', GA, 0.3) == pytest.approx(0.3) and stream.age('robot_b', GA, 0.3) == math.inf
    stream.forget('robot_a')
    assert stream.value('robot_a', GA, 0.1) is None
    with pytest.raises(RequestError, match='stream_timeout: must be a number > 0'):
        InformationStream(0)


@pytest.mark.parametrize('label, value, message', [
    ('F_G', {'x': 1.0}, 'values.y: missing required field of a F_G value'),
    ('F_G', {'x': 1.0, 'y': 2.0, 'z': 0.0}, 'values.z: unknown field of a F_G value (allowed: x, y, yaw)'),
    ('F_B', {'pressed': math.inf}, 'values.pressed: must be a finite number'),
    ('F_B', {'pressed': True}, 'values.pressed: must be a finite number'),
    ('F_G', [1.0, 2.0], 'values: must be a mapping'),
])
def test_malformed_values_are_rejected_naming_the_field(label, value, message):
    with pytest.raises(RequestError, match=message.replace('(', r'\(').replace(')', r'\)')):
        check_value(label, value)


def test_global_from_relative_rotates_by_the_known_heading():
    # A at (1, 2) heading +90 deg sees B 2 m ahead: B is at (1, 4).
    out = global_from_relative([(GA, {'x': 1.0, 'y': 2.0, 'yaw': math.pi / 2}), (RBA, {'x': 2.0, 'y': 0.0})], {})
    assert (out['x'], out['y']) == pytest.approx((1.0, 4.0)) and 'yaw' not in out
    # Without a measured heading the motor schema's estimate is used; without either: unavailable.
    out = global_from_relative([(GA, {'x': 1.0, 'y': 2.0}), (RBA, {'x': 2.0, 'y': 0.0})], {'robot_a': math.pi})
    assert (out['x'], out['y']) == pytest.approx((-1.0, 2.0))
    with pytest.raises(ValueUnavailable, match='the heading of robot_a is not known'):
        global_from_relative([(GA, {'x': 1.0, 'y': 2.0}), (RBA, {'x': 2.0, 'y': 0.0})], {})


def test_inverse_and_composition_need_relative_headings():
    # B 2 m ahead of A, facing A's +y: A lies along A's -x, which is B's +y (to B's left).
    out = relative_inverse([(RBA, {'x': 2.0, 'y': 0.0, 'yaw': math.pi / 2})], {})
    assert (out['x'], out['y'], out['yaw']) == pytest.approx((0.0, 2.0, -math.pi / 2))
    with pytest.raises(ValueUnavailable, match='needs the relative heading'):
        relative_inverse([(RBA, {'x': 2.0, 'y': 0.0})], {})
    # X at (3, 0) and Y at (1, 0) in Z's frame, Y turned 180 deg: X is 2 m behind Y.
    out = relative_composition([(RBA, {'x': 3.0, 'y': 0.0}), (RBA, {'x': 1.0, 'y': 0.0, 'yaw': math.pi})], {})
    assert (out['x'], out['y']) == pytest.approx((-2.0, 0.0), abs=1e-9)


def test_torque_is_the_cross_product_of_offset_and_force():
    # A pusher 0.5 m left of the box centre pushing along +x with 10 N turns the box clockwise.
    out = torque_from_force([(None, {'force': 10.0}), (RBA, {'x': -0.4, 'y': 0.5, 'yaw': 0.0})], {})
    assert out['torque'] == pytest.approx(-5.0)


# --- the INFORMATION message of the agent channel ------------------------------------------------

from coalition_agents.core.transport.codec import ChannelCodec, MessageKind, information_message  # noqa: E402
from coalition_agents.core.transport.reliable_channel import ReliableChannel  # noqa: E402


@pytest.fixture
def codec(library):
    return ChannelCodec.for_team(library, ['robot_a', 'robot_b'])


def test_an_information_message_round_trips_and_is_delivered_without_ack(codec):
    message = information_message('robot_a', 12, 'robot_b', 'robot_b/3', GA, {'x': 1.5, 'y': -2.0, 'yaw': 0.25})
    assert codec.decode(message.to_dict()) == message
    assert codec.from_json(message.to_json()) == message
    assert message.kind is MessageKind.INFORMATION and not message.needs_ack
    sender, receiver = ReliableChannel('robot_a'), ReliableChannel('robot_b')
    copies = sender.send(message, 0.0)
    assert sender.next_deadline() == math.inf  # nothing kept for retries
    received = receiver.receive(copies[0], 0.0)
    assert received.deliver == message and received.replies == []


def test_an_information_message_carries_its_value_as_name_value_entries_in_order(codec):
    message = information_message('robot_a', 12, 'robot_b', 'robot_b/3', GA, {'yaw': 0.25, 'x': 1.5, 'y': -2.0})
    assert message.values == (('yaw', 0.25), ('x', 1.5), ('y', -2.0))
    data = message.to_dict()
    assert data['values'] == [{'name': 'yaw', 'value': 0.25}, {'name': 'x', 'value': 1.5},
                              {'name': 'y', 'value': -2.0}]
    assert 'reason' not in data  # the values no longer ride in the free-text field
    assert codec.decode(data).values == message.values


VALID_VALUES = [{'name': 'x', 'value': 1.5}, {'name': 'y', 'value': -2.0}]


@pytest.mark.parametrize('change, error', [
    # the value: missing, unknown, repeated or non-finite fields, malformed entries
    ({'values': [{'name': 'x', 'value': 1.0}]}, 'message.values.y: missing required field of a F_G value'),
    ({'values': []}, 'message.values.x: missing required field of a F_G value'),
    ({'values': VALID_VALUES + [{'name': 'z', 'value': 0.0}]},
     'message.values.z: unknown field of a F_G value (allowed: x, y, yaw)'),
    ({'values': VALID_VALUES + [{'name': 'x', 'value': 3.0}]},
     'message.values.x: given twice (at message.values[0] and message.values[2]'),
    ({'values': [{'name': 'x', 'value': math.nan}, VALID_VALUES[1]]},
     'message.values.x: must be a finite number (got float nan)'),
    ({'values': [VALID_VALUES[0], {'name': 'y', 'value': -math.inf}]},
     'message.values.y: must be a finite number (got float -inf)'),
    ({'values': [{'name': 'x', 'value': 'north'}, VALID_VALUES[1]]}, 'message.values.x: must be a finite number'),
    ({'values': [{'name': 'x', 'value': True}, VALID_VALUES[1]]}, 'message.values.x: must be a finite number'),
    ({'values': [VALID_VALUES[0], {'name': '', 'value': 1.0}]}, 'message.values[1].name: must be a non-empty field name'),
    ({'values': [VALID_VALUES[0], {'name': 'y'}]}, 'message.values[1]: must be a mapping with name and value'),
    ({'values': [VALID_VALUES[0], [2.0]]}, 'message.values[1]: must be a mapping with name and value'),
    ({'values': {'x': 1.0, 'y': 2.0}}, 'message.values: must be a list of {name, value} entries (got mapping)'),
    # who it is for, what it is about, which coalition it serves
    ({'receiver': ''}, "message.receiver: an information message goes to one robot"),
    ({'instance': {'type': 'F_G', 'referents': ['X']}}, 'message.instance: streamed information has every referent'),
    ({'instance': {'type': 'F_Q', 'referents': ['robot_a']}}, "message.instance.type: unknown information type 'F_Q'"),
    ({'coalition_id': ''}, 'message.coalition_id: must be a non-empty string'),
    ({'coalition_id': None}, 'message.coalition_id: must be a non-empty string'),
    ({'reason': '{"x": 1.0, "y": 2.0}'}, 'message.reason: unknown field for a information message'),
])
def test_malformed_information_messages_name_the_field(codec, change, error):
    data = information_message('robot_a', 12, 'robot_b', 'robot_b/3', GA, {'x': 1.5, 'y': -2.0}).to_dict()
    data.update(change)
    with pytest.raises(RequestError) as caught:
        codec.decode(data)
    assert error in str(caught.value)


def test_an_information_message_without_coalition_id_is_rejected(codec):
    data = information_message('robot_a', 12, 'robot_b', 'robot_b/3', GA, {'x': 1.5, 'y': -2.0}).to_dict()
    del data['coalition_id']
    with pytest.raises(RequestError, match='message.coalition_id: missing required field of a information message'):
        codec.decode(data)


def test_the_sender_cannot_build_a_malformed_information_message(codec):
    """check_outgoing (run by AgentChannel.send) stops a bad value before it reaches the link."""
    message = information_message('robot_a', 12, 'robot_b', 'robot_b/3', GA, {'x': math.nan, 'y': 0.0})
    with pytest.raises(RequestError, match='outgoing information message.values.x: must be a finite number'):
        codec.check_outgoing(message)
    message = information_message('robot_a', 12, 'robot_b', 'robot_b/3', RBA, {'x': 1.0, 'y': 0.0, 'heading': 0.0})
    with pytest.raises(RequestError, match='outgoing information message.values.heading: unknown field of a F_R'):
        codec.check_outgoing(message)


def test_value_fields_of_a_type_without_a_table_entry_are_bounded_not_named():
    fields = [(f'f{index}', float(index)) for index in range(MAX_FIELDS)]
    assert check_value_fields('F_NEW', fields) == dict(fields)
    with pytest.raises(RequestError, match=f'values: at most {MAX_FIELDS} fields'):
        check_value_fields('F_NEW', fields + [('extra', 0.0)])
    with pytest.raises(RequestError, match='values.f0: given twice'):
        check_value_fields('F_NEW', fields[:2] + [('f0', 1.0)])
