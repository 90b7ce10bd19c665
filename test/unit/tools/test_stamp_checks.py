"""Stamps and /clock as input: invalid ones are refused with a kind, the node's clock follows valid ones,
and the guard drops, counts and logs each kind once (issue 16 item 1)."""
import math

import pytest
import rclpy
from builtin_interfaces.msg import Time as TimeMsg
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header

from collab_tools.core.input_checks import ClockFilter, MalformedInput, NANOSECONDS, error_kind, reference_time, \
    stamp_nanoseconds
from collab_tools.input_guard import InputGuard
from collab_tools.parameters import NodeParameters
from collab_tools.sim_clock import guard_sim_clock


# --- pure checks ------------------------------------------------------------------------------------
def test_valid_stamps_convert_to_nanoseconds():
    assert stamp_nanoseconds(0, 0) == 0
    assert stamp_nanoseconds(12, 500) == 12 * NANOSECONDS + 500
    assert stamp_nanoseconds(2**31 - 1, 999_999_999) == (2**31 - 1) * NANOSECONDS + 999_999_999  # no clock: ok


@pytest.mark.parametrize('sec, nanosec, now, kind', [
    (-1, 0, None, 'header.stamp: negative'),
    (-2**31, 0, None, 'header.stamp: negative'),
    (5, NANOSECONDS, None, 'header.stamp: nanosec out of range'),
    (5, 2**32 - 1, None, 'header.stamp: nanosec out of range'),
    (2**31 - 1, 0, 10 * NANOSECONDS, 'header.stamp: far ahead'),
])
def test_invalid_stamps_are_refused_with_their_kind(sec, nanosec, now, kind):
    with pytest.raises(MalformedInput) as caught:
        stamp_nanoseconds(sec, nanosec, now_ns=now)
    assert caught.value.kind == kind and error_kind(caught.value) == kind
    assert 'header.stamp' in str(caught.value)


def test_far_ahead_is_judged_against_the_clock_or_the_wall_clock_before_it_started():
    wall = 1_795_000_000 * NANOSECONDS
    # A latched message can arrive before a simulated clock has started (now = 0): judged by the wall clock.
    assert reference_time(0, wall) == wall and reference_time(5, wall) == 5
    assert stamp_nanoseconds(100_000, 0, now_ns=reference_time(0, wall)) == 100_000 * NANOSECONDS
    with pytest.raises(MalformedInput, match='ahead'):
        stamp_nanoseconds(2**31 - 1, 0, now_ns=reference_time(0, wall))
    assert stamp_nanoseconds(100, 0, now_ns=90 * NANOSECONDS) == 100 * NANOSECONDS  # a little ahead: fine


def test_error_kind_groups_by_field_not_value():
    assert error_kind(ValueError("move.colour: unknown colour 'purple'")) == \
        error_kind(ValueError("move.colour: unknown colour 'pink'"))
    assert error_kind(ValueError('state.counts: expected 27 entries')) != error_kind(ValueError('move.colour: x'))
    assert error_kind(KeyError('x')).startswith('KeyError')


def test_clock_filter_refuses_invalid_and_far_jumps_and_follows_valid_ones():
    clock = ClockFilter(max_ahead=100.0, confirmations=3)
    assert clock.accept(5, 0) == 5 * NANOSECONDS                  # any first message
    for bad in [(-1, 0), (6, NANOSECONDS), (2**31 - 1, 0)]:
        with pytest.raises(MalformedInput):
            clock.accept(*bad)
    assert clock.last_ns == 5 * NANOSECONDS
    assert clock.accept(6, 0) == 6 * NANOSECONDS                  # the valid clock goes on
    assert clock.accept(0, 10) == 10                              # back (a reset simulation): followed
    # Forged jumps between valid messages are never followed.
    for _ in range(10):
        with pytest.raises(MalformedInput):
            clock.accept(2**31 - 1, 0)
        clock.accept(0, 20)
    # A clock source that really moved on: followed after 3 consistent messages.
    with pytest.raises(MalformedInput):
        clock.accept(10_000, 0)
    with pytest.raises(MalformedInput):
        clock.accept(10_001, 0)
    assert clock.accept(10_002, 0) == 10_002 * NANOSECONDS


# --- the guard and the clock on a node (in-process, no messages sent) --------------------------------
@pytest.fixture
def make_node():
    contexts, nodes = [], []

    def make(*arguments: str) -> Node:
        context = Context()
        rclpy.init(context=context, args=['--ros-args', *arguments])
        contexts.append(context)
        node = Node('stamps_under_test', context=context, start_parameter_services=False)
        nodes.append(node)
        return node

    yield make
    for node in nodes:
        node.destroy_node()
    for context in contexts:
        context.try_shutdown()


class Lines:
    def __init__(self):
        self.warnings = []

    def warning(self, text):
        self.warnings.append(text)

    info = error = warning


def clock_msg(sec, nanosec=0):
    return Clock(clock=TimeMsg(sec=sec, nanosec=nanosec))


def test_guarded_callback_drops_counts_and_logs_once_per_kind(make_node):
    node = make_node()
    guard = InputGuard.of(node)
    assert InputGuard.of(node) is guard
    lines = Lines()
    node.get_logger = lambda: lines
    seen = []

    def on_header(msg: Header):
        seen.append(guard.stamp(msg.stamp).nanoseconds)

    callback = guard.guard('/topic', on_header)
    for _ in range(25):
        callback(Header(stamp=TimeMsg(sec=-1)))
    callback(Header(stamp=TimeMsg(sec=1, nanosec=2**32 - 1)))
    callback(Header(stamp=TimeMsg(sec=3, nanosec=4)))
    assert seen == [3 * NANOSECONDS + 4]
    assert guard.counts[('/topic', 'header.stamp: negative')] == 25 and guard.total == 26
    first = [w for w in lines.warnings if 'dropped a malformed message on /topic' in w]
    assert len(first) == 2                                    # one per kind
    assert any('10 malformed messages dropped so far' in w for w in lines.warnings)
    assert not any('20 malformed' in w for w in lines.warnings)


def test_fatal_errors_pass_the_guard_and_services_answer_refused(make_node):
    node = make_node()
    guard = InputGuard.of(node)

    class Fatal(ValueError):
        pass

    def boom(msg):
        raise Fatal('stop')

    with pytest.raises(Fatal):
        guard.guard('/t', boom, fatal=(Fatal,))(None)

    class Response:
        success = True
        message = ''

    def service(request, response):
        raise ValueError(f'steps: must be finite (got {math.nan})')

    answer = guard.guard_service('/s', service)(None, Response())
    assert answer.success is False and 'steps' in answer.message and guard.dropped('/s') == 1


def test_sim_clock_drops_invalid_clock_messages_and_keeps_going(make_node):
    node = make_node('-p', 'use_sim_time:=true')
    NodeParameters(node)        # every node of the workspace: guards its /clock
    source = node._time_source
    subscription = source._clock_sub
    assert subscription is not None
    deliver = subscription.callback      # what the executor calls for a /clock message
    deliver(clock_msg(5))
    assert node.get_clock().now().nanoseconds == 5 * NANOSECONDS
    deliver(clock_msg(-1))                                   # killed the node before the guard
    deliver(clock_msg(6, NANOSECONDS))
    deliver(clock_msg(2**31 - 1))
    assert node.get_clock().now().nanoseconds == 5 * NANOSECONDS
    deliver(clock_msg(7))
    assert node.get_clock().now().nanoseconds == 7 * NANOSECONDS
    assert InputGuard.of(node).dropped('/clock') == 3


def test_use_sim_time_keeps_its_meaning_set_at_run_time(make_node):
    node = make_node()
    NodeParameters(node)
    assert node._time_source._clock_sub is None
    assert node.set_parameters([Parameter('use_sim_time', value=True)])[0].successful
    deliver = node._time_source._clock_sub.callback
    deliver(clock_msg(-5))
    deliver(clock_msg(42))
    assert node.get_clock().now().nanoseconds == 42 * NANOSECONDS
    refused = node.set_parameters([Parameter('use_sim_time', value='yes')])[0]
    assert not refused.successful
    assert node.set_parameters([Parameter('use_sim_time', value=False)])[0].successful
    assert node._time_source._clock_sub is None and node.get_clock().now().nanoseconds > 10**18   # wall time


def test_guarding_twice_is_harmless(make_node):
    node = make_node('-p', 'use_sim_time:=true')
    first = guard_sim_clock(node)
    assert guard_sim_clock(node) is first
