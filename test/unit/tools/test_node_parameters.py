"""NodeParameters: typed descriptors with ranges; dynamic parameters applied, the rest refused."""
import math

import pytest
import rclpy
from rcl_interfaces.msg import ParameterType
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from collab_tools.node_support import ConfigurationError
from collab_tools.parameters import NodeParameters


@pytest.fixture
def make_node():
    contexts, nodes = [], []

    def make(*arguments: str, namespace: str | None = None) -> Node:
        context = Context()
        rclpy.init(context=context, args=['--ros-args', *arguments])
        contexts.append(context)
        node = Node('parameters_under_test', context=context, namespace=namespace,
                    start_parameter_services=False)
        nodes.append(node)
        return node

    yield make
    for node in nodes:
        node.destroy_node()
    for context in contexts:
        context.try_shutdown()


def test_descriptor_carries_type_range_description_and_read_only(make_node):
    node = make_node()
    params = NodeParameters(node)
    params.declare('rate', 2.0, 'Hz of something', low=0.0, high=100.0, low_open=True, on_change=lambda v: None)
    params.declare('count', 3, 'how many', low=1, high=10)
    params.declare('mode', 'a', 'the mode', choices=['a', 'b'])
    rate, count, mode = node.describe_parameters(['rate', 'count', 'mode'])
    assert rate.type == ParameterType.PARAMETER_DOUBLE and not rate.read_only
    assert rate.description == 'Hz of something' and 'in (0, 100]' in rate.additional_constraints
    assert (rate.floating_point_range[0].from_value, rate.floating_point_range[0].to_value) == (0.0, 100.0)
    assert count.type == ParameterType.PARAMETER_INTEGER and count.read_only
    assert (count.integer_range[0].from_value, count.integer_range[0].to_value) == (1, 10)
    assert mode.read_only and 'one of: a, b' in mode.additional_constraints


def test_dynamic_parameter_is_applied_and_checked(make_node):
    node = make_node()
    params = NodeParameters(node)
    applied = []
    params.declare('rate', 2.0, 'Hz', low=0.0, high=100.0, low_open=True, on_change=applied.append)
    assert applied == []  # declaring is not a change
    assert node.set_parameters([Parameter('rate', value=5.0)])[0].successful
    assert applied == [5.0] and params['rate'] == 5.0
    refused = node.set_parameters([Parameter('rate', value=0.0)])[0]  # open lower bound: our check
    assert not refused.successful and 'parameter rate' in refused.reason
    refused = node.set_parameters([Parameter('rate', value=500.0)])[0]  # the descriptor's range: rclpy
    assert not refused.successful
    refused = node.set_parameters([Parameter('rate', value='fast')])[0]  # wrong type
    assert not refused.successful
    assert applied == [5.0] and params['rate'] == 5.0


def test_applier_error_refuses_the_set(make_node):
    node = make_node()
    params = NodeParameters(node)

    def apply(value):
        raise ValueError('cannot apply while running')

    params.declare('gain', 1.0, 'a gain', on_change=apply)
    result = node.set_parameters([Parameter('gain', value=2.0)])[0]
    assert not result.successful and 'cannot apply while running' in result.reason
    assert params['gain'] == 1.0


def test_read_only_parameter_is_refused(make_node):
    node = make_node()
    NodeParameters(node).declare('file', 'a.yaml', 'a file')
    result = node.set_parameters([Parameter('file', value='b.yaml')])[0]
    assert not result.successful and 'read-only' in result.reason


def test_start_values_are_checked(make_node):
    with pytest.raises(ConfigurationError, match=r'parameter rate: must be in \(0, 10\]'):
        NodeParameters(make_node('-p', 'rate:=0.0')).declare('rate', 1.0, 'Hz', low=0.0, high=10.0, low_open=True)
    with pytest.raises(ConfigurationError, match='parameter mode: must be one of a, b'):
        NodeParameters(make_node('-p', 'mode:=c')).declare('mode', 'a', 'mode', choices=['a', 'b'])
    with pytest.raises(ConfigurationError, match='parameter file: required'):
        NodeParameters(make_node()).declare('file', '', 'a file', required=True)
    with pytest.raises(ConfigurationError, match='exactly 2 elements'):
        NodeParameters(make_node('-p', 'xy:=[1.0, 2.0, 3.0]')).declare('xy', [0.0, 0.0], 'x y', length=2)


def test_integer_start_value_is_taken_as_double(make_node):
    params = NodeParameters(make_node('-p', 'rate:=3', '-p', 'xy:=[1, 2]'))
    assert params.declare('rate', 1.0, 'Hz') == 3.0
    assert params.declare('xy', [0.0, 0.0], 'x y') == [1.0, 2.0]


def test_non_finite_values_are_refused(make_node):
    node = make_node()
    params = NodeParameters(node)
    params.declare('rate', 1.0, 'Hz', on_change=lambda v: None)
    assert not node.set_parameters([Parameter('rate', value=math.nan)])[0].successful


def test_long_values_are_not_echoed_whole(make_node):
    node = make_node()
    params = NodeParameters(node)
    params.declare('mode', 'a', 'mode', choices=['a', 'b'], on_change=lambda v: None)
    reason = node.set_parameters([Parameter('mode', value='x' * 10_000)])[0].reason
    assert len(reason) < 300


def test_use_sim_time_refused_for_a_clock_source(make_node):
    with pytest.raises(ConfigurationError, match='use_sim_time'):
        NodeParameters(make_node('-p', 'use_sim_time:=true')).refuse_use_sim_time('the bridge is the clock')
    node = make_node()
    NodeParameters(node).refuse_use_sim_time('the bridge is the clock')
    assert not node.set_parameters([Parameter('use_sim_time', value=True)])[0].successful


def test_start_values_get_our_message_before_rclpy_checks_them(make_node):
    with pytest.raises(ConfigurationError, match=r'parameter p: must be in \[0, 1\] \(got 2.0\)'):
        NodeParameters(make_node('-p', 'p:=2.0')).declare('p', 0.5, 'probability', low=0.0, high=1.0)
    with pytest.raises(ConfigurationError, match=r"parameter p: must be a number \(got 'high'\)"):
        NodeParameters(make_node('-p', 'p:=high')).declare('p', 0.5, 'probability', low=0.0, high=1.0)
    with pytest.raises(ConfigurationError, match=r'parameter n: must be an integer \(got 1.5\)'):
        NodeParameters(make_node('-p', 'n:=1.5')).declare('n', 1, 'count')
