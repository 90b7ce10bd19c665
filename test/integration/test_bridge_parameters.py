"""The bridge's parameters over the standard services, as `ros2 param set/describe` use them.

Every dynamic parameter (real_time_factor, publish_camera, ground_truth_rate, status_rate)
changes what the bridge does; every other one is refused, and so are wrong types and values
out of range.
"""
import time

import pytest
from bridge_interfaces.msg import SimulationStatus
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import DescribeParameters
from rclpy.parameter import Parameter
from sensor_msgs.msg import Image
from tf2_msgs.msg import TFMessage

from bridge_helpers import bridge_spec, collect, set_paused, settle, stamp_seconds, step
from parameter_client import get_value, set_one

NODE = '/pybullet_bridge'


@pytest.fixture
def bridge(session, config_dir):
    session.start(bridge_spec(config_dir / 'scenarios' / 'test_single_robot.yaml'))
    session.wait_for_message(f'{NODE}/status', 'bridge_interfaces/msg/SimulationStatus', timeout=30.0)
    return session


def set_parameter(session, name, value, type_=None):
    return set_one(session, NODE, name, value, type_)


def test_descriptors_show_type_range_and_read_only(bridge):
    names = ['real_time_factor', 'control_period', 'ground_truth_rate', 'status_rate', 'publish_camera',
             'scenario', 'start_paused']
    response = bridge.call_service(f'{NODE}/describe_parameters', 'rcl_interfaces/srv/DescribeParameters',
                                   DescribeParameters.Request(names=names))
    d = {descriptor.name: descriptor for descriptor in response.descriptors}
    rtf = d['real_time_factor']
    assert rtf.type == ParameterType.PARAMETER_DOUBLE and not rtf.read_only and rtf.description
    assert (rtf.floating_point_range[0].from_value, rtf.floating_point_range[0].to_value) == (0.0, 1000.0)
    assert d['ground_truth_rate'].additional_constraints == 'in (0, 1000]'
    assert d['control_period'].read_only and d['control_period'].additional_constraints == 'in (0, 1]'
    assert d['publish_camera'].type == ParameterType.PARAMETER_BOOL and not d['publish_camera'].read_only
    assert d['scenario'].read_only and d['start_paused'].read_only and not d['status_rate'].read_only


@pytest.mark.parametrize('name, value, type_, reason', [
    ('scenario', '/tmp/other.yaml', None, 'read-only'),
    ('control_period', 0.02, None, 'read-only'),
    ('start_paused', False, None, 'read-only'),
    ('real_time_factor', 'fast', Parameter.Type.STRING, 'type'),
    ('real_time_factor', 5000.0, None, 'range'),
    ('ground_truth_rate', 0.0, None, '(0, 1000]'),      # the open bound rclpy's range cannot say
    ('publish_camera', 1, None, 'type'),
    ('use_sim_time', True, None, 'clock source'),
])
def test_refused_sets_say_why_and_change_nothing(bridge, name, value, type_, reason):
    before = get_value(bridge, NODE, name)
    result = set_parameter(bridge, name, value, type_)
    assert not result.successful
    assert reason in result.reason
    assert get_value(bridge, NODE, name) == before


def test_publish_camera_stops_and_restarts_the_camera(bridge, ros_node):
    images = collect(ros_node, Image, '/top_camera/image_raw')
    assert step(bridge, 24).success                       # 0.1 s: one 10 Hz frame
    assert settle(images), 'no camera frame while publish_camera is true'

    assert set_parameter(bridge, 'publish_camera', False).successful
    count = len(images)
    assert step(bridge, 96).success                       # 0.4 s: four frames if it still rendered
    assert len(settle(images, at_least=count + 1, timeout=1.0)) == count, 'the camera published while off'
    assert get_value(bridge, NODE, 'publish_camera') is False

    assert set_parameter(bridge, 'publish_camera', True).successful
    assert step(bridge, 24).success
    assert len(settle(images, at_least=count + 1)) > count, 'the camera did not come back'


def test_ground_truth_rate_sets_how_often_tf_and_ground_truth_come(bridge, ros_node):
    transforms = collect(ros_node, TFMessage, '/tf', reliable=True)

    def samples_during(steps):
        start = len(settle(transforms, timeout=0.5))
        assert step(bridge, steps).success
        return settle(transforms, at_least=start + 2)[start:]

    fast = samples_during(240)                               # 1 s at the default 20 Hz
    assert 19 <= len(fast) <= 21
    assert set_parameter(bridge, 'ground_truth_rate', 2.0).successful
    slow = samples_during(240)                               # 1 s at 2 Hz
    assert 2 <= len(slow) <= 3
    stamps = [stamp_seconds(m.transforms[0]) for m in slow]
    assert all(b - a == pytest.approx(0.5, abs=0.01) for a, b in zip(stamps, stamps[1:]))


def test_real_time_factor_paces_the_running_simulation(bridge):
    assert set_parameter(bridge, 'publish_camera', False).successful  # pacing only, no rendering
    assert set_parameter(bridge, 'status_rate', 4.0).successful
    assert set_parameter(bridge, 'real_time_factor', 0.25).successful
    assert set_paused(bridge, False).success

    def status_where(predicate):
        return bridge.wait_for_message(f'{NODE}/status', 'bridge_interfaces/msg/SimulationStatus',
                                       predicate=predicate, timeout=30.0)

    # Bounds that a loaded machine cannot break: slower than asked is always possible, faster never.
    slow = status_where(lambda s: s.target_real_time_factor == 0.25 and 0.0 < s.measured_real_time_factor)
    later = status_where(lambda s: s.step_count > slow.step_count)
    assert later.measured_real_time_factor < 0.4
    assert set_parameter(bridge, 'real_time_factor', 0.0).successful   # as fast as possible
    fast = status_where(lambda s: s.target_real_time_factor == 0.0 and s.measured_real_time_factor > 1.0)
    assert fast.step_count > later.step_count


def test_status_rate_sets_how_often_status_comes(bridge, ros_node):
    statuses = collect(ros_node, SimulationStatus, f'{NODE}/status', reliable=True)
    assert set_parameter(bridge, 'status_rate', 50.0).successful
    start = len(statuses)
    deadline = time.monotonic() + 3.0   # 150 at 50 Hz; the 1 Hz default would give 3
    while len(statuses) < start + 10 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert len(statuses) >= start + 10
