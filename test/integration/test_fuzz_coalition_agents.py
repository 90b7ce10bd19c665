"""Fuzzing the coalition agents (issue 16 items 1-2 and 4): the three-robot team of
test_coalition_agents (robot_blind needs robot_helper) on the bridge gets, while it searches:
batches (single, and in bundles: the agents' own wire) whose columns disagree, a 100,000-message
batch, NaN and infinite costs and hold times, a batch from an unknown robot, a forged commitment
request without a session, 50,000 acknowledged ids, a flood of 300 malformed batches, single
channel messages of an unknown robot and with a NaN value, statuses with an unknown state or of
another robot, NaN fiducial and GPS reports and a bad /clock; once the coalition is set up, a
forged RELEASE of it from another teammate and batches of a teammate's earlier and forged
sessions. Every agent stays up, logs each kind of rejection once (per topic), and the coalition
forms and stays set up.
"""

import math
import time

from bridge_interfaces.msg import FiducialDetection, FiducialDetections
from coalition_interfaces.msg import (
    AgentMessage, AgentMessageBatch, AgentMessageBundle, AgentStatus, Information, NamedValue,
)
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from fuzz_helpers import LATCHED, assert_rejected_once_per_kind, bad_clock, clock_rejections_ok, flood, publish_all
from test_coalition_agents import BYSTANDER, HELPER, LEADER, STATUS, files, start_team  # noqa: F401 - files: fixture

BATCHES, BUNDLES, CHANNEL = '/coalition/batches', '/coalition/bundles', '/coalition/channel'
DEEP = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
EMPTY = dict(kinds=[], message_ids=[], conversation_ids=[], in_reply_to=[], costs=[], hold_seconds=[],
             coalition_ids=[], reasons=[], information_counts=[], chain_lengths=[], member_counts=[], value_counts=[],
             information_types=[], referent_counts=[], referents=[], chain_requesters=[], members=[], value_names=[],
             values=[])


def batch(sender, recipient, sequence, session=0, **columns):
    return AgentMessageBatch(sender=sender, recipient=recipient, sequence=sequence, session=session,
                             **{**EMPTY, **columns})


def commit_request(sender, recipient, sequence, coalition_id, cost=1.0, hold=0.0, session=0, message_id=5):
    """One COMMIT_REQUEST (kind 4) of ``sender``'s coalition with ``recipient``."""
    return batch(sender, recipient, sequence, session, kinds=[4], message_ids=[message_id], conversation_ids=[0],
                 in_reply_to=[0], costs=[cost], hold_seconds=[hold], coalition_ids=[coalition_id], reasons=[''],
                 information_counts=[0], chain_lengths=[0], member_counts=[2], value_counts=[0],
                 members=[sender, recipient])


def release(sender, recipient, sequence, coalition_id, session=0):
    return batch(sender, recipient, sequence, session, kinds=[7], message_ids=[77], conversation_ids=[0],
                 in_reply_to=[0], costs=[0.0], hold_seconds=[0.0], coalition_ids=[coalition_id], reasons=['forged'],
                 information_counts=[0], chain_lengths=[0], member_counts=[0], value_counts=[0])


def malformed_batches():
    """(batch, the kind its rejection is logged as on /coalition/batches)."""
    return [
        (commit_request(BYSTANDER, LEADER, 10 ** 9, 'robot_bystander/1', cost=math.nan),
         'malformed batch.messages.cost'),
        (commit_request(BYSTANDER, HELPER, 10 ** 9, 'robot_bystander/2', hold=math.inf),
         'malformed batch.messages.hold_seconds'),
        (commit_request('robot_ghost', LEADER, 10 ** 9, 'robot_ghost/1'), 'malformed batch.sender'),
        (batch(BYSTANDER, LEADER, 10 ** 9, kinds=[1] * 100_000), 'malformed batch.message_ids'),
        (batch(HELPER, LEADER, 10 ** 9, kinds=[4], message_ids=[1]), 'malformed batch.conversation_ids'),
    ]


def wait_until(condition, timeout, what):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.1)


def test_coalition_agents_survive_fuzzing_and_still_form(session, ros_node, files, config_dir):
    # exit_after: every agent reads robot_bystander's status (the only status subscription an agent has)
    _, agents = start_team(session, files, config_dir, 0.0, extra={'search_time': 6.0, 'exit_after': [BYSTANDER]})
    logs = {robot: process.log_path for robot, process in agents.items()}
    # While the team searches: malformed batches (one of each kind to the leader and helper), a flood.
    publisher = publish_all(ros_node, AgentMessageBatch, BATCHES, [b for b, _ in malformed_batches()], qos=DEEP,
                            subscribers=3)
    flood(publisher, malformed_batches()[0][0], 300)
    # The agents' own wire: a bundle whose batches are malformed (a short column; an unknown sender), and
    # an empty bundle; the batches in it are judged as single ones (logged on the batch topic).
    short = batch(BYSTANDER, LEADER, 10 ** 9 + 7, kinds=[7], message_ids=[3], conversation_ids=[0], in_reply_to=[0],
                  costs=[0.0], hold_seconds=[0.0], coalition_ids=['x/1'])
    publish_all(ros_node, AgentMessageBundle, BUNDLES, [
        AgentMessageBundle(batches=[short, commit_request('robot_ghost', HELPER, 1, 'robot_ghost/2')]),
        AgentMessageBundle()], qos=DEEP, subscribers=3)
    # The team searches (every agent started, announcing its session): a forged commitment request "from the
    # bystander" without a session is out of session, never held; so are 50,000 acknowledged ids.
    session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=30.0,
                             predicate=lambda m: m.state != AgentStatus.IDLE)
    time.sleep(1.0)
    publisher.publish(commit_request(BYSTANDER, HELPER, 10 ** 9 + 2, 'robot_bystander/3'))
    publisher.publish(batch(BYSTANDER, HELPER, 10 ** 9 + 1, acked_ids=list(range(1, 50_001))))
    publish_all(ros_node, AgentMessage, CHANNEL, [
        AgentMessage(message_id=1, sender='robot_ghost', receiver=LEADER, kind=AgentMessage.REQUEST,
                     label=Information(type='F_G', referents=['X'])),
        AgentMessage(message_id=2, sender=HELPER, receiver=LEADER, kind=AgentMessage.INFORMATION, coalition_id='x/1',
                     instance=Information(type='F_G', referents=[HELPER]),
                     values=[NamedValue(name='x', value=math.nan), NamedValue(name='y', value=0.0)])], subscribers=3)
    publish_all(ros_node, AgentStatus, f'/{BYSTANDER}/coalition',
                [AgentStatus(robot=BYSTANDER, state=99), AgentStatus(robot=LEADER, state=AgentStatus.COMPLETED)],
                qos=LATCHED, subscribers=3)
    nan_view = FiducialDetections(detections=[FiducialDetection(name=LEADER, x=math.nan, y=0.0, yaw=0.0)])
    publish_all(ros_node, FiducialDetections, f'/{HELPER}/fiducials', [nan_view] * 3, qos=qos_profile_sensor_data)
    nan_pose = PoseWithCovarianceStamped()
    nan_pose.pose.pose.position.x = math.inf
    publish_all(ros_node, PoseWithCovarianceStamped, f'/{HELPER}/gps', [nan_pose] * 3, qos=qos_profile_sensor_data)
    bad_clock(ros_node, subscribers=3)

    leader = session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=60.0,
                                      predicate=lambda m: m.state in (AgentStatus.COMMITTED, AgentStatus.FAILED))
    assert leader.state == AgentStatus.COMMITTED and tuple(leader.members) == (LEADER, HELPER), leader.detail
    helper = session.wait_for_message(f'/{HELPER}/coalition', STATUS, latched=True, timeout=10.0,
                                      predicate=lambda m: m.coalition_id == leader.coalition_id)
    assert [c.coalition_id for c in helper.commitments] == [leader.coalition_id]  # the forged request never held
    bystander = session.wait_for_message(f'/{BYSTANDER}/coalition', STATUS, latched=True, timeout=10.0,
                                         predicate=lambda m: m.robot == BYSTANDER and m.session != 0)

    # Set up: a RELEASE of the leader's coalition forged by the bystander (its own session) is no RELEASE
    # of the leader; batches of an earlier session of the bystander, and without one, are out of session.
    publisher.publish(release(BYSTANDER, HELPER, 10 ** 9 + 3, leader.coalition_id, session=bystander.session))
    publisher.publish(release(BYSTANDER, HELPER, 10 ** 9 + 4, leader.coalition_id))
    forged = bystander.session ^ 0x5A5A  # the bystander "restarts" for the leader, then its real session is old
    publisher.publish(batch(BYSTANDER, LEADER, 10 ** 9 + 5, session=forged))
    publisher.publish(batch(BYSTANDER, LEADER, 10 ** 9 + 6, session=bystander.session))
    time.sleep(3.0)  # the helper's heartbeats and streams keep the coalition alive meanwhile
    still = session.wait_for_message(f'/{HELPER}/coalition', STATUS, latched=True, timeout=10.0)
    assert still.state == AgentStatus.COMMITTED and still.coalition_id == leader.coalition_id
    still = session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=10.0)
    assert still.state == AgentStatus.COMMITTED and still.coalition_id == leader.coalition_id

    for robot, process in agents.items():
        assert process.poll() is None, f'{robot} exited: {process.log_tail()}'
    leader_log, helper_log = (lambda: logs[LEADER].read_text()), (lambda: logs[HELPER].read_text())
    wait_until(lambda: 'out-of-session batch' in leader_log() and 'out-of-session batch' in helper_log(), 10.0,
               'the out-of-session batches were not reported')
    assert_rejected_once_per_kind(leader_log(), BATCHES, [
        'malformed batch.messages.cost', 'malformed batch.sender', 'malformed batch.message_ids',
        'malformed batch.conversation_ids', 'malformed batch.reasons', 'out-of-session batch'])
    assert_rejected_once_per_kind(helper_log(), BATCHES, ['malformed batch.messages.hold_seconds',
                                                          'malformed batch.sender', 'out-of-session batch'])
    assert_rejected_once_per_kind(leader_log(), CHANNEL, ['malformed message.sender',
                                                          'malformed message.values.x'])
    for robot in agents:
        text = logs[robot].read_text()
        assert_rejected_once_per_kind(text, f'/{BYSTANDER}/coalition', ['bad status'])
        clock_rejections_ok(text)
        assert 'Traceback' not in text
    assert f'{BYSTANDER} restarted' in leader_log()  # the forged session: followed, said so
    assert 'malformed messages dropped so far' in leader_log()  # the flood: counted, a line at 10 and 100
    kinds = [line for line in helper_log().splitlines() if 'dropped a malformed message on /robot_helper/' in line]
    assert kinds, 'the NaN sensor reports were not dropped'
