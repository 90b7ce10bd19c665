"""Fuzzing the tool nodes on simulated time (issue 16): a bad /clock (negative, nanosec out of range,
68 years ahead, and a short flood of them) killed every sim-time node and left the recorder's bag
unreadable. The scripted driver and the recorder drop, count and log each kind once, the driver
still plays its plan, and the recorder closes a bag that reads back."""

import math
import time

from rosgraph_msgs.msg import Clock
from std_msgs.msg import Bool

from bridge_helpers import body_pose, bridge_spec, collect
from collab_tools.core.bag_analysis import summarize_bag
from collab_tools.core.bag_check import check_bag
from collab_tools.orchestration.node_process import NodeSpec
from fuzz_helpers import HUGE, NEGATIVE, bad_clock, clock_rejections_ok, flood


def test_driver_and_recorder_survive_a_bad_clock_and_finish(session, ros_node, config_dir, tmp_path):
    began = time.monotonic()
    plan = tmp_path / 'plan.yaml'
    plan.write_text('robots:\n  robot_1:\n    - {linear: 0.3, angular: 0.0, duration: 2.0}\n')
    bag = tmp_path / 'bag'
    session.start(bridge_spec(config_dir / 'scenarios' / 'test_single_robot.yaml', real_time_factor=1.0))
    recorder = session.start(NodeSpec('collab_tools', 'bag_recorder', name='bag_recorder', parameters=[
        {'output': str(bag), 'topics': ['/robot_1/cmd_vel', '/ground_truth/bodies']}]))
    session.wait_for_nodes(['/bag_recorder'], timeout=30.0)
    x0, y0, _ = body_pose(session, 'robot_1')

    # The bad clock comes while the plan plays.
    clock = collect(ros_node, Clock, '/clock', reliable=True)
    driver = session.start(NodeSpec('collab_tools', 'scripted_driver', parameters=[{'plan_file': str(plan)}]))
    session.wait_for_nodes(['/scripted_driver'], timeout=30.0)
    deadline = time.monotonic() + 30.0                    # the recorder has found the driver's topic
    while not any(info.node_name == 'bag_recorder'
                  for info in ros_node.get_subscriptions_info_by_topic('/robot_1/cmd_vel')):
        assert time.monotonic() < deadline, 'the recorder never subscribed to /robot_1/cmd_vel'
        session.check_alive()
        time.sleep(0.1)
    assert session.call_service('/pybullet_bridge/pause', 'std_srvs/srv/SetBool', _resume()).success
    deadline = time.monotonic() + 20.0
    while not clock and time.monotonic() < deadline:
        time.sleep(0.05)
    publisher = bad_clock(ros_node, subscribers=2)          # the driver and the recorder (best effort)
    flood(publisher, Clock(clock=NEGATIVE), 200, seconds=0.5)
    flood(publisher, Clock(clock=HUGE), 50, seconds=0.25)
    session.check_alive()

    done = session.wait_for_message('/scripted_driver/done', 'std_msgs/msg/Bool', predicate=lambda m: m.data,
                                    timeout=40.0, latched=True)
    assert isinstance(done, Bool)
    x1, y1, _ = body_pose(session, 'robot_1')
    assert 0.3 < math.hypot(x1 - x0, y1 - y0) < 0.9, 'the plan drove 2 s at 0.3 m/s'
    for process in (driver, recorder):
        log = process.log_path.read_text()
        clock_rejections_ok(log)
        assert '/clock: 100 malformed messages dropped so far [clock: negative]' in log, process.name
    # The recorder closes its bag as always; it reads back.
    assert session.stop(recorder.name) == 0
    summary = summarize_bag(bag)
    assert summary.topic('/robot_1/cmd_vel').count > 10
    assert check_bag(bag) == []
    print(f'recorder/driver fuzz: {time.monotonic() - began:.0f} s (wall)')


def _resume():
    from std_srvs.srv import SetBool
    return SetBool.Request(data=False)
