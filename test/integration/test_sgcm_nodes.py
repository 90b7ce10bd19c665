"""leader_planner and follower_executor drive both arms through the bridge until the goal.

Only topics connect them: the camera (state estimate), /sgcm/guidance (leader -> follower),
/sgcm/follower_report (round over) and the arms' pick_and_place actions.
"""

import time

import numpy as np
import pytest
import yaml
from sgcm_interfaces.msg import Guidance, GridState, Move

from collab_tools.orchestration.node_process import NodeSpec
from bridge_helpers import bridge_spec, wait_for_subscriber
from sgcm.core.rearrangement import RearrangementModel
from sgcm.core.scenario_builder import build_scenario
from sgcm.core.task_config import load_cases, load_task


@pytest.fixture
def task_file(config_dir):
    return config_dir / 'sgcm' / 'task.yaml'


def start_case(session, tmp_path, task_file, config_dir, case_name, follower_params=None):
    task = load_task(task_file)
    case = next(c for c in load_cases(config_dir / 'sgcm' / 'cases.yaml', task) if c.name == case_name)
    scenario = tmp_path / 'scenario.yaml'
    scenario.write_text(yaml.safe_dump(build_scenario(task, case, execution_failures=False)))
    session.start(bridge_spec(scenario, ground_truth_rate=5.0, start_paused=False))
    session.start(NodeSpec('sgcm', 'leader_planner', name='leader_planner',
                           parameters=[{'task_file': str(task_file)}], required=False))
    session.start(NodeSpec('sgcm', 'follower_executor', name='follower_executor',
                           parameters=[{'task_file': str(task_file), **(follower_params or {})}],
                           required=False))
    return task, case


def test_leader_and_follower_complete_a_case_through_topics(session, tmp_path, task_file, config_dir):
    task, case = start_case(session, tmp_path, task_file, config_dir, 'case_8')
    model = RearrangementModel(task)
    guidance = []
    session.observer.node.create_subscription(Guidance, '/sgcm/guidance', guidance.append, 10)
    final = session.wait_for_message('/sgcm/guidance', 'sgcm_interfaces/msg/Guidance',
                                     predicate=lambda m: m.task_complete or bool(m.status), timeout=240)
    assert final.task_complete, final.status
    assert session.wait_for_exit('leader_planner', 30) == 0
    # The rounds announced the leader's moves and a recommendation; the last estimate is the goal.
    rounds = [g for g in guidance if not g.task_complete]
    assert 1 <= len(rounds) <= 4
    assert all(g.strategy == 'sgcm' and g.stage_games > 0 for g in rounds)
    start = model.state_of(case)
    assert np.array_equal(np.array(rounds[0].state.counts), start), 'first estimate is the initial case'
    assert np.array_equal(np.array(final.state.counts), model.goal_state(start))
    # Ground truth agrees with the camera estimate: every cube is in its colour's goal cell.
    bodies = session.wait_for_message('/ground_truth/bodies', 'bridge_interfaces/msg/BodyStates',
                                      timeout=20, latched=True)
    for body in bodies.bodies:
        if body.kind == 'cube':
            colour = task.colours.index(body.name.rsplit('_', 1)[0])
            cell = task.workspace.cell_of_point(task.rows, task.cols, body.pose.position.x,
                                                body.pose.position.y)
            assert cell == task.goals[colour], f'{body.name} ended in cell {cell}'


def test_follower_drops_malformed_guidance_and_keeps_working(session, tmp_path, task_file, config_dir):
    start_case(session, tmp_path, task_file, config_dir, 'case_8')
    publisher = session.observer.node.create_publisher(Guidance, '/sgcm/guidance', 10)
    wait_for_subscriber(publisher)
    bad = Guidance(round=1000, state=GridState(rows=3, cols=3, colours=['red'], counts=[1]),
                   leader_move=Move(empty=False, source_cell=99, target_cell=0, colour='purple'))
    publisher.publish(bad)
    time.sleep(1.0)
    # The real task still completes: the bad message neither crashed the follower nor
    # made it skip the leader's rounds.
    final = session.wait_for_message('/sgcm/guidance', 'sgcm_interfaces/msg/Guidance',
                                     predicate=lambda m: m.task_complete or bool(m.status), timeout=240)
    assert final.task_complete, final.status
    log = (session.run_dir / 'logs' / 'follower_executor.log').read_text()
    assert 'dropped malformed guidance for round 1000' in log


@pytest.mark.parametrize('executable, parameters, expected', [
    ('leader_planner', {}, 'parameter task_file: required'),
    ('leader_planner', {'strategy': 'telepathy'}, 'parameter strategy: must be one of sgcm, greedy'),
    ('leader_planner', {'solver': 'oracle'}, "parameter solver: must be one of fast, milp"),
    ('follower_executor', {'behaviour': 'sneaky'}, 'parameter behaviour: must be one of'),
    ('follower_executor', {'deviation_probability': 1.5}, 'deviation_probability: must be in [0, 1]'),
])
def test_bad_parameters_stop_the_node_with_a_message(session, task_file, executable, parameters, expected):
    if parameters:
        parameters = {'task_file': str(task_file), **parameters}
    process = session.start(NodeSpec('sgcm', executable, name=executable, parameters=[parameters]))
    assert session.wait_for_exit(executable, timeout=60.0) == 2
    assert expected in process.log_path.read_text()


def test_bad_task_file_names_the_field(session, tmp_path):
    bad = tmp_path / 'task.yaml'
    bad.write_text('colours: {red: {goal: [5, 0], rgb: [1, 0, 0]}}\n')
    process = session.start(NodeSpec('sgcm', 'leader_planner', name='leader_planner',
                                     parameters=[{'task_file': str(bad)}]))
    assert session.wait_for_exit('leader_planner', timeout=60.0) == 2
    assert 'colours.red.goal: cell [5, 0] is outside the 3x3 grid' in process.log_path.read_text()
