"""Where a node's topics live: the robot's namespace and the team namespace.

The workspace follows the multi-robot conventions of Nav2:

* every name a node uses is relative, so ``-r __ns:=/sim1`` moves all of it;
* a *per-robot node* (role_player, schema_agent, leader_planner, follower_executor) runs in its
  robot's namespace (``/burger1/role_player``): its robot is the last component of that
  namespace, and its per-robot topics, services and actions are relative to it (``cmd_vel`` is
  ``/burger1/cmd_vel``), so ``ros2 node list`` is unique for any team;
* a *team-level node* (pybullet_bridge, role_engine, the recorder) runs in the team namespace
  (``/`` by default) and reaches a robot's topics as ``<robot>/cmd_vel``;
* what the team shares (the roles channel, coalition inboxes, SGCM guidance, the top camera,
  ground truth) lives under the team namespace: by default the parent of a per-robot node's
  namespace (``/sim1/burger1`` -> ``/sim1``) or a team-level node's own namespace; the
  ``team_namespace`` parameter sets it explicitly.

Only ``/clock``, ``/tf`` and ``/tf_static`` stay absolute, as ROS tools expect; two simulations in
one domain remap them (``-r /clock:=/sim1/clock``), which the orchestration does for a session
with a namespace.
"""
from __future__ import annotations

import re

from rclpy.node import Node

from .node_support import ConfigurationError

_NAME_TOKEN = re.compile(r'^[A-Za-z_][A-Za-z0-9_]*$')


def join(namespace: str, *relative: str) -> str:
    """Absolute name of `relative` parts under `namespace` ('/' joins to '/a/b')."""
    parts = [p for p in namespace.strip('/').split('/') if p]
    for name in relative:
        parts += [p for p in name.strip('/').split('/') if p]
    return '/' + '/'.join(parts)


def parent(namespace: str) -> str:
    parts = [p for p in namespace.strip('/').split('/') if p]
    return '/' + '/'.join(parts[:-1])


def check_namespace(value: str) -> str | None:
    """Problem text if `value` is not a valid absolute ROS namespace (None when it is)."""
    if not isinstance(value, str) or not value.startswith('/'):
        return f'must be an absolute namespace starting with / (got {value!r})'
    for token in value.strip('/').split('/'):
        if value != '/' and not _NAME_TOKEN.match(token):
            return f'must be made of / separated names of letters, digits and _ (got {value!r})'
    return None


def check_robot_name(value: str) -> str | None:
    if not isinstance(value, str) or not _NAME_TOKEN.match(value):
        return f'must be a ROS name token: letters, digits and _, not starting with a digit (got {value!r})'
    return None


class RobotNode:
    """The names of a per-robot node: its robot and the team namespace (see module docstring).

    Declares two read-only parameters on `params` (a NodeParameters):
    ``robot`` (default '': the last component of the node's namespace; when given it must be that
    component) and ``team_namespace`` (default '': the parent of the node's namespace).
    """

    def __init__(self, node: Node, params):
        namespace = node.get_namespace()
        own = namespace.strip('/').split('/')[-1] if namespace != '/' else ''
        robot = params.declare('robot', '', "this node's robot: the last component of its namespace "
                               "('' = take it from the namespace; when given it must match)")
        if not own:
            raise ConfigurationError(
                'the node must run in its robot\'s namespace (ros2 run ... --ros-args -r __ns:=/<robot>)'
                + (f"; parameter robot is '{robot}', so: -r __ns:=/{robot}" if robot else ''))
        if robot and robot != own:
            raise ConfigurationError(f"parameter robot: '{robot}' differs from the node's namespace {namespace} "
                                     f'(its robot is {own}; per-robot topics are relative to the namespace)')
        self.robot = own
        self.namespace = namespace
        team = params.declare('team_namespace', '', "namespace of the team's shared topics (channels, camera, "
                              "ground truth); '' = the parent of this node's namespace",
                              check=lambda v: None if v == '' else check_namespace(v))
        self.team_namespace = team or parent(namespace)

    def team(self, *relative: str) -> str:
        """Absolute name of a team-shared topic."""
        return join(self.team_namespace, *relative)

    def teammate(self, robot: str, *relative: str) -> str:
        """Absolute name of another robot's topic (``<team>/<robot>/<relative>``)."""
        return join(self.team_namespace, robot, *relative)


class TeamNode:
    """The names of a team-level node: the team namespace is its own unless set."""

    def __init__(self, node: Node, params):
        team = params.declare('team_namespace', '', "namespace of the team's shared topics (channels, camera, "
                              "ground truth); '' = this node's namespace",
                              check=lambda v: None if v == '' else check_namespace(v))
        self.team_namespace = team or node.get_namespace()

    def team(self, *relative: str) -> str:
        return join(self.team_namespace, *relative)

    def robot(self, robot: str, *relative: str) -> str:
        """Absolute name of a robot's topic (``<team>/<robot>/<relative>``)."""
        return join(self.team_namespace, robot, *relative)
