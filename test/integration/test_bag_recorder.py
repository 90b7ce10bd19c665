"""bag_recorder writes what was published: exact counts, decoded custom messages, QoS."""

import time

import yaml
from bridge_interfaces.msg import BodyState, BodyStates
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from bridge_helpers import wait_for_subscriber
from collab_tools.core.bag_analysis import read_messages, summarize_bag
from collab_tools.orchestration.node_process import NodeSpec

CHATTER_COUNT = 25
BODIES_COUNT = 12


def test_records_exact_counts_and_custom_types(session, ros_node, tmp_path):
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    chatter = ros_node.create_publisher(String, '/test/chatter', 10)
    bodies = ros_node.create_publisher(BodyStates, '/test/bodies', 10)
    legend = ros_node.create_publisher(String, '/test/latched', latched)
    legend.publish(String(data='published before the recorder started'))

    bag = tmp_path / 'bag'
    session.start(NodeSpec('collab_tools', 'bag_recorder', name='bag_recorder', use_sim_time=False,
                           parameters=[{'output': str(bag),
                                        'topics': ['/test/chatter', '/test/bodies',
                                                   '/test/latched']}]))
    for publisher in (chatter, bodies, legend):
        wait_for_subscriber(publisher, timeout=20.0)

    for i in range(CHATTER_COUNT):
        chatter.publish(String(data=f'hello {i}'))
    for i in range(BODIES_COUNT):
        msg = BodyStates()
        msg.header.frame_id = 'world'
        msg.bodies = [BodyState(name=f'robot_{i}', kind='mobile_robot', label=i + 1)]
        msg.bodies[0].pose.position.x = 0.5 * i
        bodies.publish(msg)
    time.sleep(1.0)  # delivery before the recorder is interrupted
    assert session.stop('bag_recorder') == 0

    summary = summarize_bag(bag)
    counts = {t.topic: t.count for t in summary.topics}
    assert counts == {'/test/chatter': CHATTER_COUNT, '/test/bodies': BODIES_COUNT,
                      '/test/latched': 1}

    texts = [m.data for topic, _, m in read_messages(bag, ['/test/chatter'])]
    assert texts == [f'hello {i}' for i in range(CHATTER_COUNT)]
    decoded = [m for _, _, m in read_messages(bag, ['/test/bodies'])]
    assert [m.bodies[0].name for m in decoded] == [f'robot_{i}' for i in range(BODIES_COUNT)]
    assert [m.bodies[0].pose.position.x for m in decoded] == [0.5 * i for i in range(BODIES_COUNT)]
    assert decoded[3].bodies[0].label == 4

    metadata = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert metadata['version'] == 9 and metadata['storage_identifier'] == 'mcap'
    topics = {t['topic_metadata']['name']: t['topic_metadata']
              for t in metadata['topics_with_message_count']}
    assert topics['/test/bodies']['type'] == 'bridge_interfaces/msg/BodyStates'
    latched_qos = topics['/test/latched']['offered_qos_profiles']
    assert 'transient_local' in str(latched_qos)


def test_bad_parameter_stops_the_recorder_with_a_message(session, tmp_path):
    process = session.start(NodeSpec('collab_tools', 'bag_recorder', name='bag_recorder',
                                     parameters=[{'output': str(tmp_path / 'bag'), 'exclude': ['(']}]))
    assert session.wait_for_exit('bag_recorder', timeout=60.0) == 2
    assert 'parameter exclude: invalid regular expression' in process.log_path.read_text()
