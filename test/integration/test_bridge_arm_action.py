"""The bridge serves /<arm>/pick_and_place: cubes move between table cells over ROS."""

import time

import pytest
import yaml
from action_msgs.msg import GoalStatus
from bridge_interfaces.action import PickAndPlace
from bridge_interfaces.srv import ResetScenario
from rclpy.action import ActionClient

from bridge_helpers import body_pose, bridge_spec

CELL_1_0 = [-0.15, -0.05, -0.05, 0.05]   # empty cell (row 1, col 0) next to the Panda
CUBE_EDGE = 0.03
TABLE_TOP = 0.4
TIMEOUT = 120.0  # wall s; a pick-and-place is ~7 s of simulated time


@pytest.fixture
def bridge(session, config_dir, tmp_path):
    # The file's arms fail with probability 0.1; these tests want the nominal motion.
    data = yaml.safe_load((config_dir / 'scenarios' / 'test_tabletop.yaml').read_text())
    for arm in data['arms']:
        arm['failure_probability'] = 0.0
    scenario = tmp_path / 'tabletop.yaml'
    scenario.write_text(yaml.safe_dump(data))
    session.start(bridge_spec(scenario, start_paused=False, publish_camera=False))
    session.wait_for_message('/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus',
                             timeout=30.0)
    return session


def wait(future, timeout=TIMEOUT, check=None):
    deadline = time.monotonic() + timeout
    while not future.done():
        if check is not None:
            check()
        assert time.monotonic() < deadline, 'timed out waiting for the action'
        time.sleep(0.05)
    return future.result()


def send(session, client, object_name, region, feedback=None):
    assert client.wait_for_server(timeout_sec=30.0), f'{client._action_name} is not served'
    goal = PickAndPlace.Goal(object_name=object_name, place_region=[float(v) for v in region])
    handle = wait(client.send_goal_async(goal, feedback_callback=feedback), check=session.check_alive)
    assert handle.accepted, 'goals are accepted and judged when they start'
    return handle


def test_pick_and_place_moves_the_cube_into_the_region(bridge, ros_node):
    client = ActionClient(ros_node, PickAndPlace, '/leader_arm/pick_and_place')
    joint_state = bridge.wait_for_message('/leader_arm/joint_states', 'sensor_msgs/msg/JointState')
    assert len(joint_state.name) == 9 and joint_state.name[0] == 'panda_joint1'

    phases = []
    handle = send(bridge, client, 'red_1', CELL_1_0,
                  feedback=lambda msg: phases.append((msg.feedback.phase, msg.feedback.progress)))
    response = wait(handle.get_result_async(), check=bridge.check_alive)
    result = response.result
    assert response.status == GoalStatus.STATUS_SUCCEEDED
    assert (result.outcome, result.success) == (PickAndPlace.Result.PLACED, True), result.message
    assert "'red_1' placed at" in result.message

    names = [phase for phase, _ in phases]
    seen = [name for i, name in enumerate(names) if i == 0 or names[i - 1] != name]
    assert seen == ['approach', 'grasp', 'lift', 'transport', 'place', 'release', 'retreat']
    progress = [value for _, value in phases]
    assert progress == sorted(progress) and progress[-1] > 0.8

    # Ground truth agrees with the result: the whole cube lies in the region, on the table.
    time.sleep(0.5)  # let a fresh ground-truth message out
    x, y, body = body_pose(bridge, 'red_1')
    xmin, ymin, xmax, ymax = CELL_1_0
    half = CUBE_EDGE / 2
    assert xmin + half <= x <= xmax - half and ymin + half <= y <= ymax - half
    assert body.pose.position.z == pytest.approx(TABLE_TOP + half, abs=2e-3)
    assert (result.placed_position.x, result.placed_position.y) == pytest.approx((x, y), abs=2e-3)


def test_bad_goal_is_rejected_with_a_reason_and_cancel_puts_the_cube_back(bridge, ros_node):
    client = ActionClient(ros_node, PickAndPlace, '/leader_arm/pick_and_place')
    handle = send(bridge, client, 'no_such_cube', CELL_1_0)
    response = wait(handle.get_result_async())
    assert response.status == GoalStatus.STATUS_ABORTED
    assert response.result.outcome == PickAndPlace.Result.REJECTED and not response.result.success
    assert "unknown object 'no_such_cube'" in response.result.message
    bridge.check_alive()

    x0, y0, _ = body_pose(bridge, 'green_1')
    phases = []
    handle = send(bridge, client, 'green_1', CELL_1_0, feedback=lambda msg: phases.append(msg.feedback.phase))
    deadline = time.monotonic() + TIMEOUT
    while 'transport' not in phases:
        assert time.monotonic() < deadline, f'no transport phase: {phases}'
        time.sleep(0.02)
    cancel = wait(handle.cancel_goal_async())
    assert len(cancel.goals_canceling) == 1
    response = wait(handle.get_result_async(), check=bridge.check_alive)
    assert response.status == GoalStatus.STATUS_CANCELED
    assert response.result.outcome == PickAndPlace.Result.ABORTED and 'put back' in response.result.message
    time.sleep(0.5)
    x1, y1, _ = body_pose(bridge, 'green_1')
    assert abs(x1 - x0) < 5e-3 and abs(y1 - y0) < 5e-3


def test_reset_while_moving_aborts_the_goal_and_the_server_keeps_working(bridge, ros_node):
    client = ActionClient(ros_node, PickAndPlace, '/follower_arm/pick_and_place')
    phases = []
    handle = send(bridge, client, 'blue_1', [0.05, -0.05, 0.15, 0.05],
                  feedback=lambda msg: phases.append(msg.feedback.phase))
    deadline = time.monotonic() + TIMEOUT
    while 'lift' not in phases:
        assert time.monotonic() < deadline, f'no lift phase: {phases}'
        time.sleep(0.02)
    reset = bridge.call_service('/pybullet_bridge/reset', 'bridge_interfaces/srv/ResetScenario',
                                ResetScenario.Request())
    assert reset.success, reset.message
    response = wait(handle.get_result_async(), check=bridge.check_alive)
    assert response.status == GoalStatus.STATUS_ABORTED
    assert response.result.outcome == PickAndPlace.Result.ABORTED and 'reset' in response.result.message

    # Same arm in the reloaded scene: the server answers and the arm works again.
    handle = send(bridge, client, 'blue_1', [0.05, -0.05, 0.15, 0.05])
    response = wait(handle.get_result_async(), check=bridge.check_alive)
    assert response.status == GoalStatus.STATUS_SUCCEEDED
    assert response.result.outcome == PickAndPlace.Result.PLACED and response.result.success
    assert "'blue_1' placed at" in response.result.message
