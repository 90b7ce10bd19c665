"""Robot and team namespaces (collab_tools.names)."""
import pytest
import rclpy
from rclpy.context import Context
from rclpy.node import Node

from collab_tools.names import RobotNode, TeamNode, check_namespace, join, parent
from collab_tools.node_support import ConfigurationError
from collab_tools.parameters import NodeParameters


def test_join_and_parent():
    assert join('/') == '/'
    assert join('/', 'roles/channel') == '/roles/channel'
    assert join('/sim1/', '/burger1', 'cmd_vel') == '/sim1/burger1/cmd_vel'
    assert parent('/sim1/burger1') == '/sim1'
    assert parent('/burger1') == '/'


def test_check_namespace():
    assert check_namespace('/') is None and check_namespace('/sim_1/a') is None
    assert 'absolute' in check_namespace('sim1')
    assert check_namespace('/sim-1') is not None


@pytest.fixture
def node_in():
    made = []

    def make(namespace, *arguments):
        context = Context()
        rclpy.init(context=context, args=['--ros-args', *arguments])
        node = Node('n', context=context, namespace=namespace, start_parameter_services=False)
        made.append((node, context))
        return node

    yield make
    for node, context in made:
        node.destroy_node()
        context.try_shutdown()


def test_robot_node_takes_its_robot_and_team_from_the_namespace(node_in):
    node = node_in('/sim1/burger1')
    names = RobotNode(node, NodeParameters(node))
    assert names.robot == 'burger1'
    assert names.team('roles/channel') == '/sim1/roles/channel'
    assert names.teammate('burger2', 'coalition') == '/sim1/burger2/coalition'
    assert node.get_parameter('robot').value == ''


def test_robot_node_outside_a_robot_namespace_is_refused(node_in):
    with pytest.raises(ConfigurationError, match=r'__ns:=/burger1'):
        node = node_in('/', '-p', 'robot:=burger1')
        RobotNode(node, NodeParameters(node))


def test_robot_parameter_must_match_the_namespace(node_in):
    node = node_in('/burger1', '-p', 'robot:=burger2')
    with pytest.raises(ConfigurationError, match='parameter robot'):
        RobotNode(node, NodeParameters(node))


def test_team_namespace_parameter_overrides(node_in):
    node = node_in('/robots/burger1', '-p', 'team_namespace:=/team_a')
    assert RobotNode(node, NodeParameters(node)).team('roles/channel') == '/team_a/roles/channel'
    node = node_in('/sim2')
    assert TeamNode(node, NodeParameters(node)).robot('burger1', 'cmd_vel') == '/sim2/burger1/cmd_vel'
    node = node_in('/', '-p', 'team_namespace:=bad')
    with pytest.raises(ConfigurationError, match='team_namespace'):
        TeamNode(node, NodeParameters(node))
