"""bag_recorder writes what was published: exact counts, decoded custom messages, QoS, an
action's feedback and status, metadata as rosbag2 Jazzy writes it; a topic it cannot record
fails it (exit code 1)."""

import os
import time

import rclpy
import yaml
from action_msgs.msg import GoalStatus
from bridge_interfaces.action import PickAndPlace
from bridge_interfaces.msg import BodyState, BodyStates
from rcl_interfaces.srv import SetParameters
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Int32, String

from bridge_helpers import bridge_spec, wait_for_subscriber
from collab_tools.core.bag_analysis import read_messages, summarize_bag
from collab_tools.core.bag_check import check_bag, read_mcap_summary
from collab_tools.orchestration.node_process import NodeSpec
from collab_tools.orchestration.session import EXIT_NODE_FAILED

FEEDBACK = '/leader_arm/pick_and_place/_action/feedback'
STATUS = '/leader_arm/pick_and_place/_action/status'
CELL_1_0 = [-0.15, -0.05, -0.05, 0.05]   # an empty cell next to the leader arm (test_bridge_arm_action)


def recorder(output, namespace=None, env=None, **parameters):
    return NodeSpec('collab_tools', 'bag_recorder', name='bag_recorder', namespace=namespace,
                    use_sim_time=False, env=env or {}, parameters=[{'output': str(output), **parameters}])


def wait_until(condition, timeout, what, check=None):
    deadline = time.monotonic() + timeout
    while not condition():
        if check is not None:
            check()
        assert time.monotonic() < deadline, f'timed out waiting for {what}'
        time.sleep(0.05)


def recorded_by_recorder(ros_node, topic):
    return any(info.node_name == 'bag_recorder' for info in ros_node.get_subscriptions_info_by_topic(topic))


def set_parameter(session, node, name, value):
    request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
    (result,) = session.call_service(f'{node}/set_parameters', 'rcl_interfaces/srv/SetParameters',
                                     request).results
    return result

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


def test_relative_topics_resolve_in_its_namespace_and_discovery_period_applies(session, ros_node, tmp_path):
    bag = tmp_path / 'bag'
    # A 60 s discovery period: after the first look, new topics wait for a faster period.
    session.start(recorder(bag, namespace='/team', topics=['chatter', '/absolute/chatter', 'late'],
                           discovery_period=60.0))
    relative = ros_node.create_publisher(String, '/team/chatter', 10)
    absolute = ros_node.create_publisher(String, '/absolute/chatter', 10)
    wait_until(lambda: '/team/bag_recorder' in {f'{ns.rstrip("/")}/{n}' for n, ns in
                                                ros_node.get_node_names_and_namespaces()}, 30.0, 'the recorder')
    result = set_parameter(session, '/team/bag_recorder', 'storage_preset', 'zstd_fast')
    assert not result.successful and 'read-only' in result.reason
    result = set_parameter(session, '/team/bag_recorder', 'discovery_period', 0.1)
    assert result.successful, result.reason
    late = ros_node.create_publisher(String, '/team/late', 10)
    for publisher in (relative, absolute, late):
        wait_for_subscriber(publisher, timeout=20.0)  # well within the first 60 s period
    for publisher, text in ((relative, 'relative'), (absolute, 'absolute'), (late, 'late')):
        publisher.publish(String(data=text))
    time.sleep(1.0)
    assert session.stop('team/bag_recorder') == 0  # the session names it under its namespace
    assert {t.topic: t.count for t in summarize_bag(bag).topics} == {
        '/team/chatter': 1, '/absolute/chatter': 1, '/team/late': 1}


def test_records_an_actions_feedback_and_status_as_rosbag2_does(session, ros_node, config_dir, tmp_path):
    data = yaml.safe_load((config_dir / 'scenarios' / 'test_tabletop.yaml').read_text())
    for arm in data['arms']:
        arm['failure_probability'] = 0.0
    scenario = tmp_path / 'tabletop.yaml'
    scenario.write_text(yaml.safe_dump(data))
    session.start(bridge_spec(scenario, start_paused=False, publish_camera=False))
    bag = tmp_path / 'bag'
    # A relative name in the root namespace is the absolute one.
    session.start(recorder(bag, topics=[FEEDBACK.lstrip('/'), STATUS], storage_preset='zstd_fast'))
    for topic in (FEEDBACK, STATUS):
        wait_until(lambda topic=topic: recorded_by_recorder(ros_node, topic), 60.0, f'the recorder on {topic}',
                   check=session.check_alive)
        wait_until(lambda topic=topic: ros_node.get_publishers_info_by_topic(topic), 30.0, f'publishers of {topic}')
    hashes = {topic: str(ros_node.get_publishers_info_by_topic(topic)[0].topic_type_hash)
              for topic in (FEEDBACK, STATUS)}

    client = ActionClient(ros_node, PickAndPlace, '/leader_arm/pick_and_place')
    assert client.wait_for_server(timeout_sec=30.0)
    phases = []
    goal = PickAndPlace.Goal(object_name='red_1', place_region=CELL_1_0)
    future = client.send_goal_async(goal, feedback_callback=lambda msg: phases.append(msg.feedback.phase))
    wait_until(future.done, 60.0, 'the goal response', check=session.check_alive)
    result = future.result().get_result_async()
    wait_until(result.done, 120.0, 'the result', check=session.check_alive)
    assert result.result().status == GoalStatus.STATUS_SUCCEEDED
    time.sleep(1.0)  # the last status and feedback reach the recorder
    assert session.stop('bag_recorder') == 0

    counts = {t.topic: t.count for t in summarize_bag(bag).topics}
    assert counts[FEEDBACK] == len(phases) >= 7
    assert counts[STATUS] >= 2  # executing, succeeded
    recorded = [m.feedback.phase for _, _, m in read_messages(bag, [FEEDBACK])]
    assert recorded == phases and recorded[-1] == 'retreat'
    statuses = [m.status_list[0].status for _, _, m in read_messages(bag, [STATUS]) if m.status_list]
    assert statuses[-1] == GoalStatus.STATUS_SUCCEEDED

    assert check_bag(bag) == []
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['ros_distro'] == 'jazzy'
    topics = {t['topic_metadata']['name']: t['topic_metadata'] for t in info['topics_with_message_count']}
    assert topics[FEEDBACK]['type'] == 'bridge_interfaces/action/PickAndPlace_FeedbackMessage'
    assert topics[STATUS]['type'] == 'action_msgs/msg/GoalStatusArray'
    summary = read_mcap_summary(bag / info['relative_file_paths'][0])
    channels = {c['topic']: c['metadata'] for c in summary['channels'].values()}
    for topic in (FEEDBACK, STATUS):  # the publishers' own type hash, in metadata.yaml and per channel
        assert topics[topic]['type_description_hash'] == channels[topic]['topic_type_hash'] == hashes[topic]
    assert summary['chunk_compression'] == {'zstd'}


def test_a_topic_it_cannot_record_fails_the_recorder(session, ros_node, tmp_path):
    # Two types on one topic: DDS allows it across participants only, so a second context publishes Int32.
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=session.domain_id)
    try:
        other = rclpy.create_node('other_type', context=context)
        _check_failures(session, ros_node, other, tmp_path / 'bag')
    finally:
        rclpy.shutdown(context=context)


def _check_failures(session, ros_node, other, bag):
    chatter = ros_node.create_publisher(String, '/test/chatter', 10)
    ros_node.create_publisher(BodyStates, '/test/bodies', 10)
    ros_node.create_publisher(String, '/test/mixed', 10)
    other.create_publisher(Int32, '/test/mixed', 10)
    wait_until(lambda: len(dict(ros_node.get_topic_names_and_types()).get('/test/mixed', [])) == 2, 30.0,
               'both types of /test/mixed in the graph')
    # Without the workspace's prefixes the recorder can import bridge_interfaces (PYTHONPATH) but
    # finds no definition for its types: the type store fails for /test/bodies.
    prefixes = [p for p in os.environ['AMENT_PREFIX_PATH'].split(os.pathsep)
                if not os.path.isdir(os.path.join(p, 'share', 'bridge_interfaces'))]
    session.start(recorder(bag, topics=['/test/chatter', '/test/bodies', '/test/mixed'],
                           env={'AMENT_PREFIX_PATH': os.pathsep.join(prefixes)}))
    wait_for_subscriber(chatter, timeout=20.0)
    chatter.publish(String(data='still recorded'))
    log = session.nodes['bag_recorder'].log_path
    wait_until(lambda: log.read_text().count('CANNOT RECORD') >= 2, 30.0, 'both failures in the log')
    assert session.nodes['bag_recorder'].poll() is None, 'the recorder keeps recording the rest'
    time.sleep(0.5)

    assert session.stop('bag_recorder') == 1
    assert session.exit_code() == EXIT_NODE_FAILED  # what an experiment reports (exit code 3)
    text = log.read_text()
    assert '/test/bodies: CANNOT RECORD' in text and 'bridge_interfaces/msg/BodyStates' in text
    assert '/test/mixed: CANNOT RECORD, it carries several types' in text
    assert '2 topic(s) NOT recorded' in text
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    counts = {t['topic_metadata']['name']: t['message_count'] for t in info['topics_with_message_count']}
    # The recorder may have seen /test/mixed with one type before the second appeared in its graph:
    # then the topic is in the bag with what it recorded until then (nothing here), and refused after.
    assert counts.pop('/test/mixed', 0) == 0
    assert counts == {'/test/chatter': 1}
    assert info['custom_data']['unrecorded_topics'].startswith('/test/bodies: ')
    assert '/test/mixed: it carries several types' in info['custom_data']['unrecorded_topics']


def test_an_unknown_storage_preset_stops_the_recorder_with_a_message(session, tmp_path):
    process = session.start(recorder(tmp_path / 'bag', storage_preset='zstd'))
    assert session.wait_for_exit('bag_recorder', timeout=60.0) == 2
    assert 'parameter storage_preset: must be one of none, fastwrite, zstd_fast, zstd_small' \
        in process.log_path.read_text()
    assert not (tmp_path / 'bag').exists()
