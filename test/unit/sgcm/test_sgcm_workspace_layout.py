"""Issue 13: every grid the task format accepts is served by both arms, or refused naming the cells.

The placement (sgcm.core.workspace_layout) is checked against the bridge's own reach test
(pybullet_bridge.core.arm.definition.Arm.reach_problem, which rejects a pick or place goal) at
every cube spot and every place-region corner of every cell, with the heights the bridge uses.
"""
import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from pybullet_bridge.core import parse_scenario
from pybullet_bridge.core.arm import ARM_MODELS, Arm, ArmLimits
from pybullet_bridge.core.arm.requests import DROP_GAP, FLANGE_GAP
from sgcm.core.episode import run_greedy, run_sgcm
from sgcm.core.rearrangement import FOLLOWER, LEADER, Move, RearrangementModel
from sgcm.core.scenario_builder import build_scenario, cube_spots
from sgcm.core.task_config import TaskConfigError, parse_case, parse_cases, parse_task, task_yaml
from sgcm.core.workspace_layout import ARMS

from sgcm_tasks import small_task_data

GOALS = {'red': [0, 0], 'green': [0, 1]}


def grid_task(rows, cols, workspace=None, **kwargs):
    data = small_task_data(rows, cols, {'red': [rows - 1, 0], 'green': [rows - 1, cols - 1]}, **kwargs)
    if workspace is not None:
        data['workspace'] = workspace
    return parse_task(data)


def bridge_arms(task):
    ws = task.workspace
    limits = ArmLimits(1.5, 0.4, 2.0)
    return [Arm(name, model, ws.arm_base(robot), ws.table_height, 0.0, 0, limits, model.home, 0.005)
            for robot, (name, model) in enumerate(ARMS)]


def bridge_problems(task, arm, cell):
    """What the bridge says when ``arm`` picks any cube spot of ``cell`` or places into it."""
    ws = task.workspace
    grip = ws.cube_size / 2 + FLANGE_GAP if arm.model.grasps_from_top else 0.0
    pick_z = ws.table_height + ws.cube_size / 2 + grip
    place_z = ws.table_height + ws.cube_size / 2 + DROP_GAP + grip
    xmin, ymin, xmax, ymax = ws.cell_region(task.rows, task.cols, cell)
    points = [(x, y, pick_z) for x, y in cube_spots(task, cell)]
    points += [(x, y, place_z) for x in (xmin, xmax) for y in (ymin, ymax)]
    return [p for p in (arm.reach_problem('point', *point) for point in points) if p]


def test_the_paper_grid_keeps_its_set_up(task):
    ws = task.workspace
    assert (ws.cell_size, ws.cube_size, ws.arm_axis, ws.arm_distance) == (0.10, 0.025, 'x', 0.565)
    assert all(all(per_arm) for per_arm in ws.reach) and ws.placed
    arms = build_scenario(task, parse_case({'name': 'c', 'objects': {'red': [[0, 0]]}}, task))['arms']
    assert [a['base'] for a in arms] == [[-0.565, 0.0, 0.0], [0.565, 0.0, math.pi]]


@pytest.mark.parametrize('rows, cols, cell, axis', [
    (3, 3, 0.100, 'x'), (4, 4, 0.075, 'x'), (5, 3, 0.090, 'x'), (3, 5, 0.090, 'y'), (2, 6, 0.100, 'y'),
    (1, 10, 0.095, 'y'), (10, 1, 0.095, 'x'), (5, 5, 0.060, 'x'), (4, 8, 0.065, 'y'), (2, 2, 0.100, 'x'), (3, 4, 0.095, 'y'),
])
def test_placed_grids_are_reached_by_both_arms_as_the_bridge_checks(rows, cols, cell, axis):
    task = grid_task(rows, cols)
    ws = task.workspace
    assert (ws.cell_size, ws.arm_axis) == (pytest.approx(cell), axis)
    assert ws.cube_size == pytest.approx(min(0.025, math.floor((cell - 0.02) / 3 * 1000 + 1e-6) / 1000))
    assert all(all(per_arm) for per_arm in ws.reach)
    for arm in bridge_arms(task):
        for cell_index in range(task.cells):
            assert bridge_problems(task, arm, cell_index) == [], (arm.name, task.cell_name(cell_index))
    # The bridge accepts the scenario: pedestals clear of the table, arms inside the world.
    case = parse_case({'name': 'c', 'objects': {'red': [[0, 0]], 'green': [[rows - 1, cols - 1]]}}, task)
    scenario = parse_scenario(build_scenario(task, case), Path('.'))
    assert len(scenario.sections['arms']) == 2


@pytest.mark.parametrize('rows, cols', [(10, 10), (6, 6), (9, 9), (6, 10)])
def test_grids_no_placement_serves_are_refused_naming_the_cells(rows, cols):
    with pytest.raises(TaskConfigError) as error:
        grid_task(rows, cols)
    message = str(error.value)
    assert message.startswith(f'grid: no placement of the two arms reaches every cell of the {rows}x{cols} grid')
    named = re.findall(r'\((\d+),(\d+)\)', message)
    assert named and all(int(r) < rows and int(c) < cols for r, c in named)
    assert 'cannot reach cells' in message


def test_the_issue_grid_with_the_old_fixed_cells_is_refused_naming_the_far_corners():
    # 4x4 with 0.10 m cells: the follower's base would be too close to its near cells or too far from
    # the far corners, whatever the distance.
    with pytest.raises(TaskConfigError, match=r'^grid: no placement .* 4x4 grid \(0\.100 m cells '
                                              r'\(workspace\.cell_size\).*\(0,0\)'):
        grid_task(4, 4, workspace={'cell_size': 0.10})


def test_named_cells_are_the_ones_out_of_reach():
    with pytest.raises(TaskConfigError) as error:
        grid_task(4, 4, workspace={'cell_size': 0.10, 'arm_axis': 'x'})
    closest = re.search(r'arms along x at ([0-9.]+) m', str(error.value))
    distance = float(closest.group(1))
    fixed = {'cell_size': 0.10, 'arm_axis': 'x', 'arm_distance': distance}
    # The same placement fixed by hand: the cells the message names are out of that arm's reach.
    try:
        task = grid_task(4, 4, workspace=fixed)
    except TaskConfigError as fixed_error:   # cells neither arm reaches are refused outright
        assert 'neither arm reaches' in str(fixed_error)
        return
    for part in str(error.value).split('; '):
        robot = LEADER if 'the leader' in part else FOLLOWER
        for r, c in re.findall(r'\((\d+),(\d+)\)', part.split('cannot reach cells')[-1]):
            assert not task.workspace.reach[robot][int(r) * 4 + int(c)]


def test_workspace_fields_are_validated():
    with pytest.raises(TaskConfigError, match=r"^workspace\.arm_axis: must be one of x, y \(got 'z'\)"):
        grid_task(3, 3, workspace={'arm_axis': 'z'})
    with pytest.raises(TaskConfigError, match=r'^workspace\.cube_size: three cubes must fit along a cell'):
        grid_task(3, 3, workspace={'cell_size': 0.06, 'cube_size': 0.025})
    with pytest.raises(TaskConfigError, match=r'^workspace\.cube_size: 0\.04 m cubes need cells of at least'):
        grid_task(3, 3, workspace={'cube_size': 0.04})
    with pytest.raises(TaskConfigError, match=r"^workspace\.arm_distance: an arm's pedestal would stand on"):
        grid_task(1, 4, workspace={'arm_distance': 0.3})
    with pytest.raises(TaskConfigError, match=r'^workspace\.arm_distance: neither arm reaches cells '
                                              r'\(0,0\), \(0,1\), \(0,2\) '):
        grid_task(1, 4, workspace={'cell_size': 0.1, 'arm_distance': 0.85})
    with pytest.raises(TaskConfigError, match=r'^workspace\.reach: unknown field'):
        grid_task(3, 3, workspace={'reach': 1.0})


def test_a_move_an_arm_cannot_make_is_not_in_its_action_set():
    # Arms fixed 0.5 m from the centre of a 1x4 row of 0.10 m cells: the Panda reaches every cell,
    # the KUKA iiwa only the two far from its base (the near ones are inside its minimum reach).
    task = grid_task(1, 4, workspace={'cell_size': 0.1, 'arm_distance': 0.5})
    assert task.workspace.reach == ((True,) * 4, (True, True, False, False))
    model = RearrangementModel(task)
    follower = model.actions[FOLLOWER]
    moves = {(int(s), int(t)) for s, t in zip(follower.source[1:], follower.target[1:])}
    assert moves == {(0, 1), (1, 0)}
    with pytest.raises(ValueError, match="out of its arm's reach"):
        follower.index_of(Move(1, 2, 0))
    assert model.actions[LEADER].index_of(Move(1, 2, 0)) > 0
    state = model.state_of(parse_case({'name': 's', 'objects': {'red': [[0, 1], [0, 2]]}}, task))
    for a in model.feasible(state, FOLLOWER)[1:]:
        assert {follower.source[a], follower.target[a]} <= {0, 1}
    stage = model.stage(state)
    assert all(follower.target[b] in (0, 1) for b in stage.follower_actions[1:])
    # SGCM still ends the task (the leader carries what the follower cannot); in no episode does
    # the follower move from or to a cell he cannot reach (greedy gets stuck here, as it may).
    case = parse_case({'name': 's', 'objects': {'red': [[0, 2]], 'green': [[0, 1]]}}, task)
    assert run_sgcm(model, model.state_of(case)).completed
    for episode in (run_sgcm(model, model.state_of(case)), run_greedy(model, model.state_of(case))):
        for record in episode.records:
            assert record.follower_action == 'no move' or re.match(r'\w+ \(0,[01]\)->\(0,[01]\)',
                                                                   record.follower_action), record


def test_a_case_whose_objects_no_arm_can_bring_home_is_refused():
    # 0.70 m from the centre the Panda reaches cells 0-1 only and the iiwa cells 2-3 only: nothing crosses.
    task = grid_task(1, 4, workspace={'cell_size': 0.1, 'arm_distance': 0.7})
    assert task.workspace.reach == ((True, True, False, False), (False, False, True, True))
    with pytest.raises(TaskConfigError, match=r'^case\.objects\.green: no sequence of moves the arms can make '
                                              r'brings the object\(s\) in \(0,0\) to the goal \(0,3\)'):
        parse_case({'name': 's', 'objects': {'green': [[0, 0]]}}, task)
    assert parse_case({'name': 's', 'objects': {'green': [[0, 2]]}}, task).objects == 1


# --- cases with their own grid and goals ------------------------------------------------------

def test_a_case_carries_its_own_grid_and_goals(task):
    cases = parse_cases({'cases': [
        {'name': 'square', 'grid': {'rows': 4, 'cols': 4}, 'goals': {'red': [3, 0], 'green': [3, 3], 'blue': [0, 3]},
         'objects': {'red': [[0, 3]], 'green': [[0, 0]]}},
        {'name': 'wide', 'grid': {'rows': 2, 'cols': 6, 'cell_capacity': 4},
         'goals': {'red': [1, 0], 'green': [1, 5], 'blue': [0, 5]}, 'objects': {'blue': [[1, 1]]}},
        {'name': 'tall', 'grid': {'rows': 5}, 'objects': {'green': [[4, 2]]}},     # keeps the task's goals
        {'name': 'goals_only', 'goals': {'red': [0, 0]}, 'objects': {'red': [[2, 2]]}},
        {'name': 'plain', 'objects': {'red': [[0, 0]]}},
    ]}, task)
    square, wide, tall, goals_only, plain = cases
    assert (square.task.rows, square.task.cols, square.task.goals) == (4, 4, (12, 15, 3))
    assert square.counts.shape == (16, 3) and square.task.workspace.cell_size == pytest.approx(0.075)
    assert (wide.task.rows, wide.task.cols, wide.task.cell_capacity, wide.task.workspace.arm_axis) == (2, 6, 4, 'y')
    assert (tall.task.rows, tall.task.cols, tall.task.goals) == (5, 3, task.goals)
    assert goals_only.task.goals == (0, 7, 8) and goals_only.task.rows == 3
    assert plain.task is task
    # The rest of the task is the file's.
    assert square.task.horizon == task.horizon and square.task.leader == task.leader
    # The nodes read the case's task from the file the simulation writes: the same task.
    for case in (square, wide):
        again = parse_task(yaml.safe_load(task_yaml(case.task)), source=case.task.source)
        assert again == case.task
    model = RearrangementModel(square.task)
    assert run_sgcm(model, model.state_of(square)).completed


def test_a_case_scenario_is_built_on_its_own_grid(task):
    case = parse_case({'name': 'wide', 'grid': {'rows': 2, 'cols': 6}, 'goals': {'red': [1, 0], 'green': [1, 5],
                                                                                 'blue': [0, 5]},
                       'objects': {'red': [[0, 5]], 'blue': [[1, 0], [1, 0]]}}, task)
    scenario = build_scenario(task, case)
    assert scenario['tables'][0]['size'] == [pytest.approx(0.6), pytest.approx(0.2)]
    assert scenario['tables'][0]['grid'] == {'rows': 2, 'cols': 6}
    assert [a['base'][:2] for a in scenario['arms']] == [[0.0, -case.task.workspace.arm_distance],
                                                          [0.0, case.task.workspace.arm_distance]]
    assert len(scenario['cubes']) == 3
    parse_scenario(scenario, Path('.'))


def cases_with(**fields):
    return {'cases': [{'name': 'c', 'objects': {'red': [[0, 0]]}, **fields}]}


@pytest.mark.parametrize('fields, message', [
    ({'grid': {'rows': 11}}, 'cases[0].grid.rows: must be <= 10'),
    ({'grid': {'rows': 1, 'cols': 1}}, 'cases[0].grid: needs at least two cells'),
    ({'grid': {'depth': 2}}, 'cases[0].grid.depth: unknown field'),
    ({'grid': [4, 4]}, 'cases[0].grid: must be a mapping'),
    ({'grid': {'rows': 2}}, "cases[0].goals: the task's goal of red [2, 0] is outside the case's 2x3 grid; "
                            'give cases[0].goals.red'),
    ({'goals': {'red': [3, 0]}}, 'cases[0].goals.red: cell [3, 0] is outside the 3x3 grid'),
    ({'goals': {'purple': [0, 0]}}, "cases[0].goals.purple: unknown colour 'purple' (known: red, green, blue)"),
    ({'goals': {'red': 'bottom'}}, 'cases[0].goals.red: must be a cell [row, col]'),
    ({'goals': [[0, 0]]}, 'cases[0].goals: must be a mapping'),
    ({'grid': {'rows': 10, 'cols': 10}, 'goals': {'red': [9, 0], 'green': [9, 1], 'blue': [9, 2]}},
     'cases[0].grid: no placement of the two arms reaches every cell of the 10x10 grid'),
    ({'grid': {'rows': 4, 'cols': 4}, 'goals': {'red': [3, 0]}, 'objects': {'red': [[4, 0]]}},
     'cases[0].objects.red[0]: cell [4, 0] is outside the 4x4 grid'),
])
def test_invalid_case_grids_and_goals_name_the_field(task, fields, message):
    with pytest.raises(TaskConfigError, match='^' + re.escape(message)):
        parse_cases(cases_with(**fields), task)


def test_the_shipped_grid_cases_load(task):
    cases = parse_cases(yaml.safe_load((Path(__file__).resolve().parents[3] / 'config' / 'sgcm'
                                        / 'cases_grids.yaml').read_text()), task)
    assert [(c.task.rows, c.task.cols) for c in cases] == [(4, 4), (5, 3)]
    for case in cases:
        assert all(all(per_arm) for per_arm in case.task.workspace.reach)
        model = RearrangementModel(case.task)
        assert np.array_equal(model.state_of(case).reshape(-1, 3).sum(axis=0), case.counts.sum(axis=0))


def test_arm_models_used_are_the_bridge_catalogue():
    assert [model for _, model in ARMS] == [ARM_MODELS['panda'], ARM_MODELS['kuka_iiwa']]


def test_a_task_whose_cells_hold_more_cubes_than_a_simulated_cell_is_refused_for_simulation():
    task = parse_task(small_task_data(3, 3, {'red': [2, 0]}, capacity=12))
    case = parse_case({'name': 'c', 'objects': {'red': [[0, 0]]}}, task)
    with pytest.raises(TaskConfigError, match=r'^grid\.cell_capacity: 12 is more than the 9 cubes a simulated cell'):
        build_scenario(task, case)


def test_table1_plays_each_case_on_its_own_grid(task):
    from sgcm.experiments.table1 import core_episodes, play_cases, table1_results
    cases = parse_cases({'cases': [
        {'name': 'plain', 'objects': {'red': [[1, 0]]}},
        {'name': 'square', 'grid': {'rows': 4, 'cols': 4}, 'goals': {'red': [3, 0], 'green': [3, 3]},
         'objects': {'red': [[0, 1]], 'green': [[1, 3]]}},
    ]}, task)
    outcomes = play_cases(task, cases, core_episodes(task), log=lambda _line: None)
    assert all(o.sgcm.completed and o.centralized_rounds <= o.sgcm.rounds for o in outcomes)
    data, _ = table1_results(outcomes, task, 'core', cases)
    assert 'layout' not in data['cases'][0]
    layout = data['cases'][1]['layout']
    assert (layout['rows'], layout['cols'], layout['goals']['red'], layout['arm_axis']) == (4, 4, [3, 0], 'x')
    assert layout['cell_size'] == pytest.approx(0.075)
