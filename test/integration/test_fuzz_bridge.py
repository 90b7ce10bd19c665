"""Fuzzing the bridge (issue 16): non-finite and huge commands, a flood, bad service requests. The
bridge stays up, counts every dropped command in ~/status, logs each kind once, and still drives."""

import math
import time

from bridge_interfaces.srv import GetCameraFrame, SetSensorActive
from geometry_msgs.msg import Twist
from rclpy.qos import QoSProfile, ReliabilityPolicy

from bridge_helpers import body_pose, bridge_spec, drive, step, wait_for_subscriber
from fuzz_helpers import assert_rejected_once_per_kind, flood


def twist(linear=0.0, angular=0.0):
    msg = Twist()
    msg.linear.x, msg.angular.z = linear, angular
    return msg


def test_bridge_survives_fuzzed_commands_and_requests_and_still_drives(session, ros_node, config_dir):
    began = time.monotonic()
    process = session.start(bridge_spec(config_dir / 'scenarios' / 'test_sensors.yaml'))   # robots with sensors
    session.wait_for_message('/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus', timeout=30.0)
    cmd = ros_node.create_publisher(Twist, '/robot_1/cmd_vel', QoSProfile(depth=10,
                                                                        reliability=ReliabilityPolicy.RELIABLE))
    wait_for_subscriber(cmd)
    x0, y0, _ = body_pose(session, 'robot_1')

    # NaN / inf in both fields, one after the other, with the simulation stepping in between.
    for bad in (math.nan, math.inf, -math.inf):
        cmd.publish(twist(bad, 0.0))
        cmd.publish(twist(0.0, bad))
        time.sleep(0.05)
    assert step(session, 24).success
    # A short flood of NaN commands (best effort input: some may be lost on the way, none may crash it).
    flood(cmd, twist(math.nan, math.nan), 300, seconds=1.0)
    # Bad requests: answered, not fatal.
    assert not step(session, 0).success
    assert not step(session, 2**32 - 1).success
    answer = session.call_service('/robot_1/set_sensor_active', 'bridge_interfaces/srv/SetSensorActive',
                                  SetSensorActive.Request(sensor='x' * 10_000, active=True))
    assert not answer.success and len(answer.message) < 11_000
    frame = session.call_service('/top_camera/get_frame', 'bridge_interfaces/srv/GetCameraFrame',
                                 GetCameraFrame.Request(with_labels=True))
    assert frame.success and frame.image.width > 0
    session.check_alive()

    # Nothing moved the robot; every command dropped is counted, each kind logged once.
    x1, y1, _ = body_pose(session, 'robot_1')
    assert math.hypot(x1 - x0, y1 - y0) < 1e-3
    status = session.wait_for_message('/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus',
                                      predicate=lambda s: s.rejected_messages >= 6 + 100)
    log = process.log_path.read_text()
    assert_rejected_once_per_kind(log, '/robot_1/cmd_vel', ['non-finite velocity'])
    assert '/robot_1/cmd_vel: 100 malformed messages dropped so far' in log
    assert 'Traceback' not in log

    # And it still does its task: a valid command drives the robot as before.
    drive(session, cmd, 0.4, 0.0, seconds=1.0)
    x2, y2, _ = body_pose(session, 'robot_1')
    assert 0.2 < math.hypot(x2 - x1, y2 - y1) < 0.5
    session.check_alive()
    print(f'bridge fuzz: {status.rejected_messages} commands dropped; {time.monotonic() - began:.0f} s (wall)')


def test_arm_action_refuses_fuzzed_goals_and_still_places(session, ros_node, config_dir, tmp_path):
    """pick_and_place goals with unknown, huge or empty names and NaN, inf, empty or huge regions end
    unsuccessfully with a reason; the arm then places a cube as asked."""
    import yaml
    from action_msgs.msg import GoalStatus
    from bridge_interfaces.action import PickAndPlace
    from rclpy.action import ActionClient

    from test_bridge_arm_action import CELL_1_0, send, wait

    data = yaml.safe_load((config_dir / 'scenarios' / 'test_tabletop.yaml').read_text())
    for arm in data['arms']:
        arm['failure_probability'] = 0.0
    scenario = tmp_path / 'tabletop.yaml'
    scenario.write_text(yaml.safe_dump(data))
    process = session.start(bridge_spec(scenario, start_paused=False, publish_camera=False))
    client = ActionClient(ros_node, PickAndPlace, '/leader_arm/pick_and_place')
    bad_goals = [('no_such_cube', CELL_1_0), ('x' * 100_000, CELL_1_0), ('', CELL_1_0),
                 ('red_1', [math.nan] * 4), ('red_1', [math.inf, 0.0, -math.inf, 0.0]), ('red_1', []),
                 ('red_1', [0.0] * 1000), ('red_1', [0.1, 0.1, -0.1, -0.1]), ('red_1', [1e308] * 4)]
    for name, region in bad_goals:
        response = wait(send(session, client, name, region).get_result_async(), check=session.check_alive)
        assert not response.result.success and response.result.message, (name[:20], region[:4])
        assert len(response.result.message) < 2_000                      # a capped echo of the name
    response = wait(send(session, client, 'red_1', CELL_1_0).get_result_async(), check=session.check_alive)
    assert response.status == GoalStatus.STATUS_SUCCEEDED and response.result.success, response.result.message
    log = process.log_path.read_text()
    assert 'Traceback' not in log
    assert max(len(line) for line in log.splitlines()) < 3_000         # the log lines echo a capped name
