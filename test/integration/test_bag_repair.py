"""A recorder killed with SIGKILL leaves a bag the session repairs (rosbags and mcap's indexed
reader open it, nearly every message kept); a flood the recorder cannot keep up with is
counted: lost = published - recorded, for our own publisher; a recorder stopped while behind a burst
drains its queues first (every message in the bag), and a drain cut short is a counted loss (exit 5)."""
import json
import os
import signal
import time

import yaml
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosbags.highlevel import AnyReader
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from std_msgs.msg import UInt32

from bridge_helpers import wait_for_subscriber
from collab_tools.core.bag_check import check_bag
from collab_tools.core.recording_loss import STATUS_FILE, read_status
from collab_tools.orchestration.node_process import NodeSpec
from collab_tools.orchestration.session import EXIT_MESSAGES_LOST, EXIT_NODE_FAILED

try:  # Foxglove's reference reader (scripts/requirements): the indexed read of the repaired bag
    from mcap import reader as mcap_reader
except ImportError:  # pragma: no cover - scripts/setup installs it
    mcap_reader = None


def recorder(output, **parameters):
    return NodeSpec('collab_tools', 'bag_recorder', name='bag_recorder', use_sim_time=False,
                    parameters=[{'output': str(output), **parameters}])


def recorder_counts(bag, topic):
    """The recorder's latest counts for ``topic`` (its status file), {} before the first."""
    custom = read_status(bag / STATUS_FILE).get('custom_data') or {}
    return json.loads(custom.get('recorder_counts') or '{}').get(topic, {})


def wait_for(condition, timeout, what):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f'timed out waiting for {what}'
        time.sleep(0.1)


def bag_messages(bag):
    with AnyReader([bag]) as reader:
        return [(c.topic, t) for c, t, _ in reader.messages()]


def test_killed_recorder_bag_is_repaired_by_the_session(session, ros_node, tmp_path):
    bag = tmp_path / 'bag'
    publisher = ros_node.create_publisher(UInt32, '/steady', QoSProfile(depth=100))
    process = session.start(recorder(bag, topics=['/steady'], chunk_flush_period=0.2, topic_rates=['/steady=200']))
    session.add_recording('bag_recorder', bag)
    wait_for_subscriber(publisher, timeout=20.0)
    published = 400
    for i in range(published):
        publisher.publish(UInt32(data=i))
        time.sleep(0.005)
    # Everything received is in the file after a flush period or two; then the kill.
    wait_for(lambda: recorder_counts(bag, '/steady').get('received') == published, 20.0, 'the recorder')
    time.sleep(0.5)
    os.killpg(process.popen.pid, signal.SIGKILL)
    process.popen.wait(10.0)
    assert not (bag / 'metadata.yaml').exists()

    session.stop_all()
    session.finish_recordings()  # what the session does on exit

    recording = session.recordings['bag_recorder']
    assert recording.repaired and recording.problem is None, recording
    assert check_bag(bag) == []
    messages = bag_messages(bag)
    assert len(messages) >= published - 5, f'{len(messages)} of {published} kept'
    if mcap_reader is not None:
        with next(bag.glob('*.mcap')).open('rb') as f:
            reader = mcap_reader.make_reader(f)
            assert reader.get_summary().statistics.message_count == len(messages)
            assert sum(1 for _ in reader.iter_messages()) == len(messages)
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['custom_data']['messages_lost'] == '0'   # the recorder's last status
    assert session.exit_code() == EXIT_NODE_FAILED        # the recorder died: the run failed
    assert '(queue depth 400)' in process.log_path.read_text()  # 2 s of 200 Hz


def test_flood_loss_is_counted_exactly(session, ros_node, tmp_path):
    bag = tmp_path / 'bag'
    # The publisher keeps every message until delivered; the recorder's queue holds one.
    publisher = ros_node.create_publisher(UInt32, '/flood', QoSProfile(depth=6000,
                                                                       reliability=ReliabilityPolicy.RELIABLE))
    diagnostics = []
    ros_node.create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 10)
    session.start(recorder(bag, topics=['/flood'], queue_depth=1, chunk_flush_period=0.2))
    session.add_recording('bag_recorder', bag)
    wait_for_subscriber(publisher, timeout=20.0)
    # Gaps count from the first message received: let that be the first one published.
    publisher.publish(UInt32(data=0))
    wait_for(lambda: recorder_counts(bag, '/flood').get('received') == 1, 20.0, 'the first message')
    published = 5000
    for i in range(1, published):
        publisher.publish(UInt32(data=i))
    # The newest message always stays in a keep-last queue: it arrives last.
    wait_for(lambda: sum(recorder_counts(bag, '/flood').get(k, 0) for k in ('received', 'gaps')) >= published,
             30.0, 'the last message')
    # The recorder says so while it records, on /diagnostics.
    wait_for(lambda: any(s.level == DiagnosticStatus.WARN for a in diagnostics for s in a.status), 10.0,
             'a WARN diagnostic')
    warn = next(s for a in reversed(diagnostics) for s in a.status if s.level == DiagnosticStatus.WARN)
    assert warn.name == '/bag_recorder' and 'lost' in warn.message
    assert session.stop('bag_recorder') == 0

    recorded = len(bag_messages(bag))
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    counts = json.loads(info['custom_data']['recorder_counts'])['/flood']
    lost = int(info['custom_data']['messages_lost'])
    assert 0 < lost == published - recorded, (lost, published, recorded)
    assert counts['written'] == counts['received'] == recorded
    session.finish_recordings()
    assert session.recordings['bag_recorder'].lost == {'/flood': lost}
    assert session.exit_code() == EXIT_MESSAGES_LOST
    assert f'{lost} message(s) LOST' in (session.run_dir / 'logs' / 'bag_recorder.log').read_text()


BURST = 20000


def _burst_then_stop_all(session, ros_node, bag, **parameters):
    """BURST messages published at once (reliable, nothing dropped on the way), then the session stops:
    the recorder is still behind when its SIGINT comes. Returns the bag's recorder counts."""
    publisher = ros_node.create_publisher(UInt32, '/burst', QoSProfile(depth=BURST,
                                                                       reliability=ReliabilityPolicy.RELIABLE))
    # A queue that holds the whole burst (2 s of 10 kHz): only the stop can lose messages.
    session.start(recorder(bag, topics=['/burst'], topic_rates=['/burst=10000'], **parameters))
    session.add_recording('bag_recorder', bag)
    wait_for_subscriber(publisher, timeout=20.0)
    for i in range(BURST):
        publisher.publish(UInt32(data=i))
        if i % 1000 == 999:
            # A breath for the middleware's receive thread: a sample it drops is repaired only at the
            # publisher's next heartbeat (Fast DDS: up to 3 s later), after any drain here.
            time.sleep(0.005)
    session.stop_all()
    session.finish_recordings()
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    return info['custom_data'], json.loads(info['custom_data']['recorder_counts'])['/burst']


def test_stop_drains_what_the_recorder_is_behind_on(session, ros_node, tmp_path):
    bag = tmp_path / 'bag'
    custom, counts = _burst_then_stop_all(session, ros_node, bag)
    assert len(bag_messages(bag)) == counts['written'] == BURST
    assert counts['drained'] > 0, counts  # the SIGINT came while messages were queued
    assert custom['messages_lost'] == '0' and counts['drain_left'] == 0
    assert session.recordings['bag_recorder'].lost is None or not session.recordings['bag_recorder'].lost
    assert session.exit_code() == 0
    assert 'queued message(s)' in (session.run_dir / 'logs' / 'bag_recorder.log').read_text()


def test_a_drain_cut_short_is_a_counted_loss(session, ros_node, tmp_path):
    bag = tmp_path / 'bag'
    custom, counts = _burst_then_stop_all(session, ros_node, bag, drain_timeout=0.0)
    recorded = len(bag_messages(bag))
    # At least what was queued at the bound (a sample still on its way then is not counted).
    assert 0 < counts['drain_left'] == int(custom['messages_lost']) <= BURST - recorded, counts
    assert session.recordings['bag_recorder'].lost == {'/burst': counts['drain_left']}
    assert session.exit_code() == EXIT_MESSAGES_LOST
    log = (session.run_dir / 'logs' / 'bag_recorder.log').read_text()
    assert '/burst: DRAIN INCOMPLETE' in log and 'message(s) LOST' in log
