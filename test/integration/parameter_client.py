"""What `ros2 param` does, through the standard parameter services of a running node.

Shared by the per-package parameter tests: set, get, list + describe, and the contract every node
keeps (dynamic parameters are applied, every other one is refused as read-only, each is described).
"""
from __future__ import annotations

from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters, SetParameters
from rclpy.parameter import Parameter, parameter_value_to_python

#: Parameters rclpy declares on every node (not the node's own).
ROS_OWN = {'use_sim_time', 'start_type_description_service', 'qos_overrides'}


def set_parameters(session, node: str, **values):
    """`ros2 param set` of several values at once; the SetParametersResult of each."""
    request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()
                                                for name, value in values.items()])
    return session.call_service(f'{node}/set_parameters', 'rcl_interfaces/srv/SetParameters', request).results


def set_one(session, node: str, name: str, value, type_: Parameter.Type | None = None):
    """`ros2 param set NODE NAME VALUE` (``type_`` forces a parameter type, e.g. an int for a double)."""
    parameter = Parameter(name, type_, value) if type_ is not None else Parameter(name, value=value)
    request = SetParameters.Request(parameters=[parameter.to_parameter_msg()])
    (result,) = session.call_service(f'{node}/set_parameters', 'rcl_interfaces/srv/SetParameters', request).results
    return result


def get_values(session, node: str, names) -> dict:
    """`ros2 param get` of each name."""
    names = list(names)
    response = session.call_service(f'{node}/get_parameters', 'rcl_interfaces/srv/GetParameters',
                                    GetParameters.Request(names=names))
    return {name: parameter_value_to_python(value) for name, value in zip(names, response.values)}


def get_value(session, node: str, name: str):
    return get_values(session, node, [name])[name]


def descriptors(session, node: str) -> dict:
    """`ros2 param describe` of every parameter the node itself declared."""
    names = session.call_service(f'{node}/list_parameters', 'rcl_interfaces/srv/ListParameters',
                                 ListParameters.Request()).result.names
    response = session.call_service(f'{node}/describe_parameters', 'rcl_interfaces/srv/DescribeParameters',
                                    DescribeParameters.Request(names=list(names)))
    return {d.name: d for d in response.descriptors if d.name.split('.')[0] not in ROS_OWN}


def another_value(value):
    """A different value of the same type (so a refusal cannot be a type error)."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        return value + 1
    if isinstance(value, str):
        return value + '_x'
    return list(value) + [list(value)[0]]


def check_parameter_contract(session, node: str, dynamic, read_only=None, *, refuse_negative: bool = False) -> dict:
    """The contract every node keeps; returns the descriptors.

    Each parameter is described and typed; exactly ``dynamic`` may change (and ``read_only`` is the
    rest, when given); every read-only one is refused as read-only; a dynamic one refuses a value of
    the wrong type (a number or flag given a string; and a negative number with ``refuse_negative``); nothing refused changes a value.
    """
    found = descriptors(session, node)
    if read_only is not None:
        assert set(found) == set(dynamic) | set(read_only), f'{node}: declared {sorted(found)}'
    assert {name for name, d in found.items() if not d.read_only} == set(dynamic)
    for name, descriptor in found.items():
        assert descriptor.description, f'{node} {name}: no description'
        assert descriptor.type != ParameterType.PARAMETER_NOT_SET, f'{node} {name}: no type'
    current = get_values(session, node, sorted(found))
    for name in sorted(set(found) - set(dynamic)):
        result = set_one(session, node, name, another_value(current[name]))
        assert not result.successful and 'read-only' in result.reason, (node, name, result.reason)
    for name in sorted(name for name in dynamic if not isinstance(current[name], str)):
        result = set_one(session, node, name, 'not a number')
        assert not result.successful and 'type' in result.reason.lower(), (node, name, result.reason)
        if refuse_negative:
            result = set_one(session, node, name, -1 if isinstance(current[name], int) else -1.0)
            assert not result.successful, f'{node}: {name} = -1 was accepted'
    assert get_values(session, node, sorted(found)) == current
    return found


__all__ = ['ParameterMsg', 'ROS_OWN', 'another_value', 'check_parameter_contract', 'descriptors', 'get_value',
           'get_values', 'set_one', 'set_parameters']
