"""/tf and /tf_static from the bridge: standard types and QoS, and poses equal to ground truth."""
import math

import pytest
from bridge_interfaces.msg import BodyStates
from geometry_msgs.msg import Twist
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
from tf2_msgs.msg import TFMessage

from bridge_helpers import bridge_spec, collect, drive, settle, stamp_seconds, wait_for_subscriber
from collab_tools.core.tf_tree import Pose, TfTree


@pytest.fixture
def bridge(session, config_dir):
    session.start(bridge_spec(config_dir / 'scenarios' / 'test_sensors.yaml', publish_camera=False))
    session.wait_for_message('/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus', timeout=30.0)
    return session


def add_all(tree, msg):
    for t in msg.transforms:
        tr, q = t.transform.translation, t.transform.rotation
        tree.add(t.header.frame_id, t.child_frame_id, Pose((tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w)))


def test_tf_types_and_qos_are_what_tf2_listeners_expect(bridge, ros_node):
    static = bridge.wait_for_message('/tf_static', 'tf2_msgs/msg/TFMessage', latched=True)
    types = dict(ros_node.get_topic_names_and_types())
    assert types['/tf'] == ['tf2_msgs/msg/TFMessage'] and types['/tf_static'] == ['tf2_msgs/msg/TFMessage']
    static_qos = ros_node.get_publishers_info_by_topic('/tf_static')[0].qos_profile
    assert static_qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert static_qos.reliability == ReliabilityPolicy.RELIABLE
    assert ros_node.get_publishers_info_by_topic('/tf')[0].qos_profile.reliability == ReliabilityPolicy.RELIABLE
    children = {t.child_frame_id: t.header.frame_id for t in static.transforms}
    assert children['top_camera'] == 'world'
    assert children['top_camera_optical_frame'] == 'top_camera'
    assert children['robot_1/laser_link'] == 'robot_1/base_link'
    assert children['robot_2/fiducial_link'] == 'robot_2/base_link'
    assert 'robot_1/base_link' not in children, 'robots move: their base_link is on /tf'


def test_world_to_base_link_matches_ground_truth_at_the_same_stamp(bridge, ros_node):
    static = bridge.wait_for_message('/tf_static', 'tf2_msgs/msg/TFMessage', latched=True)
    transforms = collect(ros_node, TFMessage, '/tf', reliable=True)
    truths = collect(ros_node, BodyStates, '/ground_truth/bodies', reliable=True)
    cmd = ros_node.create_publisher(Twist, '/robot_1/cmd_vel', 10)
    wait_for_subscriber(cmd)
    drive(bridge, cmd, 0.5, 0.8, seconds=1.5)    # an arc: x, y and yaw all change
    settle(transforms, at_least=int(1.5 * 20))

    by_stamp = {stamp_seconds(m.transforms[0]): m for m in transforms}
    compared = 0
    for truth in settle(truths):
        tf = by_stamp.get(stamp_seconds(truth))
        if tf is None:
            continue
        assert {t.header.stamp.sec + t.header.stamp.nanosec * 1e-9 for t in tf.transforms} == \
            {stamp_seconds(truth)}
        tree = TfTree()
        add_all(tree, static)
        add_all(tree, tf)
        for body in truth.bodies:
            if body.kind != 'mobile_robot':
                continue
            pose = tree.lookup('world', f'{body.name}/base_link')
            p, q = body.pose.position, body.pose.orientation
            assert pose.translation == pytest.approx((p.x, p.y, p.z), abs=1e-9)
            dot = sum(a * b for a, b in zip(pose.rotation, (q.x, q.y, q.z, q.w)))
            assert abs(dot) == pytest.approx(1.0, abs=1e-9)
        compared += 1
    assert compared >= 3
    # robot_1 moved: the last compared pose is not its start (-1, 0, heading 0).
    moved = tree.lookup('world', 'robot_1/base_link')
    assert math.hypot(moved.translation[0] + 1.0, moved.translation[1]) > 0.3
    # Sensor readings in robot_1's laser frame reach the camera's optical frame through the tree.
    ahead = tree.lookup('top_camera_optical_frame', 'robot_1/laser_link').apply((1.0, 0.0, 0.0))
    here = tree.lookup('top_camera_optical_frame', 'robot_1/base_link').translation
    assert math.dist(ahead, here) == pytest.approx(1.0)
