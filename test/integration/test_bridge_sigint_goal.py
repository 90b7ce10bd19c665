"""SIGINT stops the bridge cleanly (exit 0, no traceback) while a pick_and_place goal runs.

The failure this guards against: SIGINT shut the context down, then the bridge's clean-up
destroyed its arm adapters, and a server with a goal in flight created a timer (to keep itself
until the aborted goal's result was out) on the dead context: RCLError traceback, exit 1, and the
orchestration marked the run failed. The goal's client must also learn the goal is over rather
than hang: an aborted result if it still arrives, or the server vanishing.
"""

import time

import yaml
from bridge_interfaces.action import PickAndPlace
from rclpy.action import ActionClient

from bridge_helpers import bridge_spec

REGION = [0.05, -0.05, 0.15, 0.05]   # the free cell in front of the follower arm
TIMEOUT = 60.0                        # wall s; a pick-and-place is ~7 s of simulated time


def start_bridge(session, config_dir, tmp_path, name):
    data = yaml.safe_load((config_dir / 'scenarios' / 'test_tabletop.yaml').read_text())
    for arm in data['arms']:
        arm['failure_probability'] = 0.0   # the nominal motion: the goal is surely still running
    scenario = tmp_path / f'{name}.yaml'
    scenario.write_text(yaml.safe_dump(data))
    spec = bridge_spec(scenario, start_paused=False, publish_camera=False, real_time_factor=1.0)
    spec.name = name
    process = session.start(spec)
    session.wait_for_message(f'/{name}/status', 'bridge_interfaces/msg/SimulationStatus', timeout=30.0)
    return process


def wait_until(condition, what, timeout=TIMEOUT):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f'timed out waiting for {what}'
        time.sleep(0.02)


def assert_clean_exit(process, code):
    log = process.log_path.read_text(errors='replace')
    assert code == 0, f'{process.name}: exit {code}\n{log[-3000:]}'
    assert 'Traceback' not in log and 'RCLError' not in log, log[-3000:]


def test_sigint_while_an_arm_goal_runs_exits_0_without_a_traceback(session, ros_node, config_dir, tmp_path):
    for phase_at_stop in ('approach', 'transport'):   # before and after the cube was picked
        name = f'bridge_{phase_at_stop}'
        bridge = start_bridge(session, config_dir, tmp_path, name)
        client = ActionClient(ros_node, PickAndPlace, '/follower_arm/pick_and_place')
        assert client.wait_for_server(timeout_sec=30.0), 'pick_and_place is not served'
        phases = []
        goal = PickAndPlace.Goal(object_name='blue_1', place_region=[float(v) for v in REGION])
        sent = client.send_goal_async(goal, feedback_callback=lambda msg: phases.append(msg.feedback.phase))
        wait_until(lambda: phase_at_stop in phases, f'the {phase_at_stop} phase (saw {phases})')
        handle = sent.result()
        result = handle.get_result_async()

        assert_clean_exit(bridge, session.stop(bridge.name))
        assert phases[-1] != 'retreat', f'the goal ended before the signal: {phases}'
        assert not bridge.ended_badly(), bridge.outcome()
        # The client is not left waiting on a live server: the result came (aborted), or the
        # server is gone.
        wait_until(lambda: result.done() or not client.server_is_ready(), 'the client to see the goal end')
        if result.done():
            assert not result.result().result.success
        client.destroy()
