"""Fuzzing the SGCM leader and follower (issue 16 items 1-3).

While the arms play case_8 through the bridge, each node gets what used to end it or fake its
result: guidance and reports with negative, out-of-range and far-ahead stamps, empty and huge
arrays, unknown colours and cells, a flood of them, a bad /clock, camera images with invalid stamps,
an empty 0x0 frame and a NaN camera pose. Both stay up, count and log each kind once, and the task
still completes at the goal. A leader whose camera shows only garbage never reports the goal: it
ends with a perception fault (exit code 1) after ``perception_fault_after``.
"""

import math
import time

import pytest
from bridge_interfaces.msg import BodyLabel, LabelLegend
from bridge_interfaces.srv import GetCameraFrame
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from rclpy.qos import qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image
from sgcm_interfaces.msg import FollowerReport, GridState, Guidance, Move

from collab_tools.orchestration.node_process import NodeSpec
from parameter_client import set_one
from fuzz_helpers import BAD_STAMPS, HUGE, LATCHED, NEGATIVE, assert_rejected_once_per_kind, bad_clock, \
    clock_rejections_ok, flood, publish_all, rejections
from test_sgcm_nodes import FOLLOWER_NS, LEADER_NS, resume_once_heard, start_case


@pytest.fixture
def task_file(config_dir):
    return config_dir / 'sgcm' / 'task.yaml'


def guidance(round_, stamp=None, **fields):
    values = {'state': GridState(rows=3, cols=3, colours=['red', 'green', 'blue'], counts=[0] * 27),
              'leader_move': Move(empty=True), 'recommended_follower_move': Move(empty=True), **fields}
    msg = Guidance(round=round_, strategy='sgcm', **values)
    if stamp is not None:
        msg.header.stamp = stamp
    return msg


def malformed_guidance(now: Time):
    """Guidance for rounds far ahead (never a duplicate), each with one thing wrong."""
    bad = [guidance(1000 + i, stamp) for i, stamp in enumerate(BAD_STAMPS)]
    bad += [
        guidance(1100, now, state=GridState(rows=3, cols=3, colours=['red', 'green', 'blue'], counts=[])),
        guidance(1101, now, state=GridState(rows=3, cols=3, colours=['red', 'green', 'blue'], counts=[1] * 100_000)),
        guidance(1102, now, leader_move=Move(empty=False, source_cell=0, target_cell=1, colour='purple')),
        guidance(1103, now, recommended_follower_move=Move(empty=False, source_cell=2**16 - 1, target_cell=0,
                                                            colour='red')),
        guidance(1104, now, predicted_leader_value=math.nan, leader_policy_probabilities=[math.inf] * 10_000,
                 state=GridState(rows=3, cols=3, colours=['red'], counts=[1])),
    ]
    return bad


def bad_images(now: Time):
    """Camera images with invalid stamps, and an empty 0x0 frame (image and labels) at ``now``."""
    images = [Image(encoding='rgb8', height=0, width=0, step=0) for _ in BAD_STAMPS]
    for image, stamp in zip(images, BAD_STAMPS):
        image.header.stamp = stamp
    empty_rgb = Image(encoding='rgb8', height=0, width=0, step=0)
    empty_rgb.header.stamp = now
    return images, empty_rgb


def test_leader_and_follower_survive_fuzzing_and_complete_the_case(session, ros_node, tmp_path, task_file,
                                                                  config_dir):
    began = time.monotonic()
    heard = []
    subscription = ros_node.create_subscription(Guidance, '/sgcm/guidance', heard.append, 10)
    # The follower streams the camera (its images can be fuzzed); the leader asks for frames.
    start_case(session, tmp_path, task_file, config_dir, 'case_8', start_paused=True,
               follower_params={'camera_on_demand': False})
    session.wait_for_nodes([f'{LEADER_NS}/leader_planner', f'{FOLLOWER_NS}/follower_executor'], 60.0)
    resume_once_heard(session, subscription)
    clock = session.wait_for_message('/clock', 'rosgraph_msgs/msg/Clock', predicate=lambda c: c.clock.sec >= 1,
                                     timeout=60.0)
    now = clock.clock

    # The follower's inputs: guidance, streamed images and labels.
    publisher = publish_all(ros_node, Guidance, '/sgcm/guidance', malformed_guidance(now), subscribers=2)
    flood(publisher, guidance(1200, NEGATIVE), 200, seconds=1.0)
    images, empty = bad_images(now)
    for topic in ('/top_camera/image_raw', '/top_camera/labels'):
        camera = publish_all(ros_node, Image, topic, images, qos=qos_profile_sensor_data)
        empty.encoding = 'rgb8' if topic.endswith('image_raw') else '16UC1'
        camera.publish(empty)
    # The leader's: reports with invalid stamps and absurd fields, for the round it may be waiting for.
    reports = [FollowerReport(round=1, behaviour='obedient', move=Move(empty=True), succeeded=True)
               for _ in BAD_STAMPS]
    for report, stamp in zip(reports, BAD_STAMPS):
        report.header.stamp = stamp
    publish_all(ros_node, FollowerReport, '/sgcm/follower_report', reports)
    # Both: a NaN camera pose (latched: it must not replace the good one) and a bad /clock.
    nan_pose = PoseStamped()
    nan_pose.header.stamp = now
    nan_pose.pose.position.x = math.nan
    nan_pose.pose.orientation.w = math.inf
    publish_all(ros_node, PoseStamped, '/top_camera/pose', [nan_pose], qos=LATCHED, subscribers=2)
    clock_publisher = bad_clock(ros_node, subscribers=2)
    flood(clock_publisher, Clock(clock=HUGE), 30, 0.3)
    session.check_alive()

    final = session.wait_for_message('/sgcm/guidance', 'sgcm_interfaces/msg/Guidance',
                                     predicate=lambda m: m.task_complete or bool(m.status), timeout=240)
    assert final.task_complete and final.status == 'goal reached', final.status
    assert session.wait_for_exit('leader_arm/leader_planner', 30) == 0
    assert session.wait_for_exit('follower_arm/follower_executor', 30) == 0
    rounds = [g for g in heard if not g.task_complete and g.round < 1000]
    assert 1 <= len(rounds) <= 6 and [g.round for g in rounds] == list(range(1, len(rounds) + 1))

    follower = (session.run_dir / 'logs' / 'follower_arm' / 'follower_executor.log').read_text()
    assert_rejected_once_per_kind(follower, '/sgcm/guidance', [
        'header.stamp: negative', 'header.stamp: nanosec out of range', 'header.stamp: far ahead'])
    assert len(rejections(follower, '/sgcm/guidance')) >= 7     # the stamps, the arrays, the colours, cells
    assert '/sgcm/guidance: 100 malformed messages dropped so far [header.stamp: negative]' in follower
    assert_rejected_once_per_kind(follower, '/top_camera/image_raw', ['header.stamp: negative'])
    assert_rejected_once_per_kind(follower, '/top_camera/pose', ['camera pose: not finite'])
    clock_rejections_ok(follower)
    leader = (session.run_dir / 'logs' / 'leader_arm' / 'leader_planner.log').read_text()
    assert_rejected_once_per_kind(leader, '/sgcm/follower_report', [
        'header.stamp: negative', 'header.stamp: nanosec out of range'])
    assert_rejected_once_per_kind(leader, '/top_camera/pose', ['camera pose: not finite'])
    clock_rejections_ok(leader)
    print(f'SGCM fuzz: {len(rounds)} rounds, {time.monotonic() - began:.0f} s (wall)')


class GarbageCamera:
    """A top camera whose frames show nothing: latched pose and a legend naming nine cubes, and a get_frame
    service answering empty 0x0 frames (what a camera looking elsewhere or a broken driver gives)."""

    def __init__(self, node):
        pose = PoseStamped()
        pose.header.frame_id = 'top_camera'
        pose.pose.position.z = 2.0
        pose.pose.orientation.x = 1.0          # looking down
        legend = LabelLegend(entries=[BodyLabel(label=10 + i, name=f'red_{i}', kind='cube') for i in range(9)])
        self.pose_pub = node.create_publisher(PoseStamped, '/top_camera/pose', LATCHED)
        self.legend_pub = node.create_publisher(LabelLegend, '/top_camera/label_legend', LATCHED)
        self.pose_pub.publish(pose)
        self.legend_pub.publish(legend)
        self.requests = 0
        self.service = node.create_service(GetCameraFrame, '/top_camera/get_frame', self._frame)
        self.node = node

    def _frame(self, request, response):
        self.requests += 1
        stamp = self.node.get_clock().now().to_msg()
        response.image = Image(encoding='rgb8', height=0, width=0, step=0)
        response.labels = Image(encoding='16UC1', height=0, width=0, step=0)
        response.image.header.stamp = response.labels.header.stamp = stamp
        response.camera_info.k = [100.0, 0.0, 0.0, 0.0, 100.0, 0.0, 0.0, 0.0, 1.0]
        response.success = True
        return response


def test_a_leader_seeing_only_garbage_never_reports_the_goal(session, ros_node, task_file):
    from bridge_interfaces.action import PickAndPlace
    from rclpy.action import ActionServer

    camera = GarbageCamera(ros_node)
    # Her arm's action server, so she gets as far as looking (it is never sent a goal).
    arm = ActionServer(ros_node, PickAndPlace, '/leader_arm/pick_and_place', lambda handle: PickAndPlace.Result())
    try:
        # Started with a bound she would wait out for an hour; set to 2 s at run time, it applies at once.
        process = session.start(NodeSpec('sgcm', 'leader_planner', name='leader_planner', namespace=LEADER_NS,
                                         use_sim_time=False, required=False,
                                         parameters=[{'task_file': str(task_file), 'perception_fault_after': 3600.0}]))
        session.wait_for_nodes([f'{LEADER_NS}/leader_planner'], 60.0)
        deadline = time.monotonic() + 30.0
        while camera.requests < 2:           # she looks, and the frames are rejected
            assert time.monotonic() < deadline, 'the leader never asked for a frame'
            time.sleep(0.1)
        assert set_one(session, f'{LEADER_NS}/leader_planner', 'perception_fault_after', 2.0).successful
        final = session.wait_for_message('/sgcm/guidance', 'sgcm_interfaces/msg/Guidance',
                                         predicate=lambda m: m.task_complete or bool(m.status), timeout=60)
        assert not final.task_complete and final.status.startswith('perception fault: 0 of the 9 cubes'), \
            final.status
        assert session.wait_for_exit(process.name, 30) == 1
        log = process.log_path.read_text()
        assert 'goal reached' not in log and 'perception fault' in log and 'Traceback' not in log
        assert camera.requests >= 3          # she looked again while the frames were rejected
    finally:
        arm.destroy()
