"""set_parameters on the SGCM nodes: every dynamic parameter changes what the node does, every
other one is refused (read-only), and so is a value of the wrong type or out of range.

Times are compared in simulated time (message stamps), so a slow machine cannot fail them.
"""

import time

import pytest
import rclpy
import yaml
from rclpy.time import Time
from sgcm_interfaces.msg import FollowerReport, Guidance, Move

from collab_tools.orchestration.node_process import NodeSpec
from collab_tools.qos import RELIABLE
from bridge_helpers import FAST_SIM, bridge_spec, set_paused, wait_for_subscriber
from parameter_client import check_parameter_contract, get_values, set_one, set_parameters
from sgcm.core.rearrangement import RearrangementModel
from sgcm.core.scenario_builder import build_scenario
from sgcm.core.task_config import load_cases, load_task
from sgcm.ros_conversions import grid_state_msg

LEADER = '/leader_arm/leader_planner'
FOLLOWER = '/follower_arm/follower_executor'
ARM_DYNAMIC = {'arm_goal_timeout', 'arm_server_lost_after'}      # sgcm.arm_client; test_sgcm_restarts
LEADER_DYNAMIC = {'horizon', 'round_limit', 'follower_timeout', 'settle_time', 'perception_fault_after', *ARM_DYNAMIC}
FOLLOWER_DYNAMIC = {'settle_time', 'perception_fault_after', *ARM_DYNAMIC}   # perception_fault_after: test_fuzz_sgcm


def leader_spec(task_file, **parameters) -> NodeSpec:
    return NodeSpec('sgcm', 'leader_planner', name='leader_planner', namespace='/leader_arm',
                    parameters=[{'task_file': str(task_file), **parameters}], required=False)


def follower_spec(task_file, **parameters) -> NodeSpec:
    return NodeSpec('sgcm', 'follower_executor', name='follower_executor', namespace='/follower_arm',
                    parameters=[{'task_file': str(task_file), **parameters}], required=False)


@pytest.fixture
def task_file(config_dir):
    return config_dir / 'sgcm' / 'task.yaml'


@pytest.fixture
def silent_follower(session):
    """The test as a follower that hears the guidance and never reports (a node named as the leader's
    follower, spun with the session's observer): the leader publishes each round once it has matched,
    not after waiting ANNOUNCE_WAIT (5 s) for a follower that is not there, and the round still ends by
    her follower_timeout. Returns the guidance it heard."""
    node = rclpy.create_node('follower_executor', namespace='/follower_arm', context=session.observer.context,
                             start_parameter_services=False)
    heard = []
    node.create_subscription(Guidance, '/sgcm/guidance', heard.append, RELIABLE)
    session.observer.executor.add_node(node)
    yield heard
    session.observer.executor.remove_node(node)
    node.destroy_node()


def start_bridge(session, tmp_path, task_file, config_dir, case_name='case_8', **parameters):
    task = load_task(task_file)
    case = next(c for c in load_cases(config_dir / 'sgcm' / 'cases.yaml', task) if c.name == case_name)
    scenario = tmp_path / 'scenario.yaml'
    scenario.write_text(yaml.safe_dump(build_scenario(task, case, execution_failures=False)))
    session.start(bridge_spec(scenario, ground_truth_rate=5.0, **FAST_SIM, **parameters))
    return task, case


def stamp_seconds(msg) -> float:
    return Time.from_msg(msg.header.stamp).nanoseconds / 1e9


def wait_for(items, predicate, what, session, timeout=240.0):
    deadline = time.monotonic() + timeout
    while True:
        found = [item for item in items if predicate(item)]
        if found:
            return found[0]
        assert time.monotonic() < deadline, f'timed out waiting for {what}'
        session.check_alive()
        time.sleep(0.1)


def test_leader_parameters_are_applied_or_refused(session, tmp_path, task_file, config_dir, silent_follower):
    """A follower that never reports: the leader's rounds end by its follower_timeout.

    Started with a follower_timeout it would wait out for hours of simulated time, horizon and
    round_limit from the task file (2, 20) and a 0.5 s settle; the values set at run time decide
    the run: horizon 1 in every guidance, 30 s settling plus the 2 s timeout between the two
    rounds, and the end at round 2.
    """
    task, _ = start_bridge(session, tmp_path, task_file, config_dir, start_paused=True)
    session.start(leader_spec(task_file, follower_timeout=100000.0))
    session.wait_for_nodes([LEADER], 60.0)
    guidance = silent_follower
    found = check_parameter_contract(session, LEADER, LEADER_DYNAMIC, refuse_negative=True)
    assert (found['horizon'].integer_range[0].from_value, found['horizon'].integer_range[0].to_value) == (0, 6)
    assert not set_one(session, LEADER, 'horizon', 7).successful
    assert task.horizon == 2 and task.round_limit > 2

    results = set_parameters(session, LEADER, horizon=1, round_limit=2, settle_time=30.0)
    assert all(r.successful for r in results), [r.reason for r in results]
    assert get_values(session, LEADER, ['horizon', 'round_limit', 'settle_time']) == \
        {'horizon': 1, 'round_limit': 2, 'settle_time': 30.0}
    assert set_paused(session, False).success

    first = wait_for(guidance, lambda g: g.round == 1 and not g.status, 'round 1 guidance', session)
    assert first.horizon == 1 and first.stage_games > 0
    # The round in progress waits for the follower until the new timeout.
    assert set_one(session, LEADER, 'follower_timeout', 2.0).successful
    second = wait_for(guidance, lambda g: g.round == 2 and not g.status, 'round 2 guidance', session)
    assert second.horizon == 1
    assert stamp_seconds(second) - stamp_seconds(first) >= 2.0 + 30.0
    final = wait_for(guidance, lambda g: bool(g.status) or g.task_complete, 'the final guidance', session)
    assert final.status == 'round limit 2 reached' and not final.task_complete
    assert session.wait_for_exit('leader_arm/leader_planner', 60.0) == 0
    log = (session.run_dir / 'logs' / 'leader_arm' / 'leader_planner.log').read_text()
    assert 'round 1: no follower report within 2 s' in log


def test_follower_parameters_are_applied_or_refused(session, tmp_path, task_file, config_dir):
    """The test is the leader: its guidance recommends no move, so the follower only observes.

    Its report comes once the camera shows the table settle_time after the guidance: 30 s of
    simulated time after it is set to 30 at run time (it started with 0.5).
    """
    task, case = start_bridge(session, tmp_path, task_file, config_dir, start_paused=False)
    session.start(follower_spec(task_file))
    session.wait_for_nodes([FOLLOWER], 60.0)
    node = session.observer.node
    reports = []
    node.create_subscription(FollowerReport, '/sgcm/follower_report', reports.append, RELIABLE)
    publisher = node.create_publisher(Guidance, '/sgcm/guidance', RELIABLE)
    check_parameter_contract(session, FOLLOWER, FOLLOWER_DYNAMIC, refuse_negative=True)
    assert get_values(session, FOLLOWER, ['settle_time']) == {'settle_time': 0.5}
    assert set_one(session, FOLLOWER, 'settle_time', 30.0).successful
    wait_for_subscriber(publisher)

    model = RearrangementModel(task)
    clock = session.wait_for_message('/clock', 'rosgraph_msgs/msg/Clock', timeout=30)
    msg = Guidance(sender='/leader_arm/leader_planner', session=1, round=1, horizon=task.horizon, strategy='sgcm',
                   state=grid_state_msg(task, model.state_of(case)), leader_move=Move(empty=True),
                   leader_move_succeeded=True, recommended_follower_move=Move(empty=True))
    msg.header.stamp = clock.clock
    publisher.publish(msg)
    report = wait_for(reports, lambda r: r.round == 1, 'the round 1 report', session)
    assert report.move.empty and report.succeeded
    assert stamp_seconds(report) - stamp_seconds(msg) >= 30.0
