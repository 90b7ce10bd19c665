"""Task and case files: the shipped configuration and clear errors for bad input."""
import copy
import re

import numpy as np
import pytest

from collab_tools.core.errors import ConfigurationError
from sgcm.core.task_config import TaskConfigError, load_cases, load_task, parse_cases, parse_task

from sgcm_tasks import small_task_data


def test_shipped_task_matches_the_paper_set_up(task):
    assert (task.rows, task.cols, task.cell_capacity) == (3, 3, 6)
    assert task.colours == ('red', 'green', 'blue')
    assert task.goals == (6, 7, 8)                   # bottom-left, bottom-middle, bottom-right
    assert (task.leader.directions, task.follower.directions) == (8, 4)
    assert task.leader.failure_probability == task.follower.failure_probability == 0.1
    assert (task.horizon, task.discount) == (2, 0.9)
    assert (task.clutter.threshold, task.clutter.factor) == (3, 2.0)
    assert task.reward.distance == 'chebyshev'


def test_shipped_cases(cases, task):
    assert [c.name for c in cases] == [f'case_{i}' for i in range(1, 11)]
    for case in cases:
        assert 3 <= case.objects <= 7
        assert case.counts.shape == (task.cells, len(task.colours))
    # case_1: red at (0,2) twice and (1,2); green at (0,0); blue at (0,0) and (1,0).
    expected = np.zeros((9, 3), dtype=int)
    expected[2, 0], expected[5, 0], expected[0, 1], expected[0, 2], expected[3, 2] = 2, 1, 1, 1, 1
    np.testing.assert_array_equal(cases[0].counts, expected)


def test_overrides_and_failure_probability_override(task_file):
    task = load_task(task_file, {'horizon': 3, 'failure_probability': {'leader': 0.0, 'follower': 0.25}})
    assert task.horizon == 3
    assert task.leader.failure_probability == 0.0 and task.follower.failure_probability == 0.25
    assert task.leader.directions == 8   # the rest of the robot model is kept


def test_defaults_of_a_minimal_task():
    task = parse_task({'colours': {'red': {'goal': [2, 0], 'rgb': [1, 0, 0]}}})
    assert (task.rows, task.cols, task.horizon, task.discount, task.round_limit) == (3, 3, 2, 0.9, 20)
    assert task.utility.leader_own == task.utility.follower_other == 1.0


def with_change(path, value, base=None):
    """small_task_data() with one nested field set (None deletes it)."""
    data = copy.deepcopy(base or small_task_data(3, 3, {'red': [2, 0], 'green': [2, 1]}))
    node = data
    for key in path[:-1]:
        node = node.setdefault(key, {})
    if value is None:
        node.pop(path[-1], None)
    else:
        node[path[-1]] = value
    return data


@pytest.mark.parametrize('path, value, message', [
    (('robots', 'leader', 'failure_probability'), 1.5, 'robots.leader.failure_probability: must be <= 1.0'),
    (('robots', 'follower', 'failure_probability'), -0.2, 'robots.follower.failure_probability: must be >= 0.0'),
    (('game', 'failure_probability', 'follower'), 1.01, 'game.failure_probability.follower: must be <= 1.0'),
    (('robots', 'follower', 'directions'), 6, 'robots.follower.directions: must be 4 or 8 (got 6)'),
    (('robots', 'leader', 'directions'), 'eight', 'robots.leader.directions: must be an integer'),
    (('reward', 'distance'), 'euclidean',
     "reward.distance: must be one of chebyshev, manhattan (got 'euclidean')"),
    (('reward', 'scale'), 0.0, 'reward.scale: must be > 0.0'),
    (('colours',), {}, 'colours: at least one colour is required'),
    (('colours',), None, 'colours: missing required field'),
    (('colours', 'red', 'goal'), [3, 0], 'colours.red.goal: cell [3, 0] is outside the 3x3 grid'),
    (('colours', 'red', 'goal'), [1], 'colours.red.goal: must be a cell [row, col]'),
    (('colours', 'red', 'rgb'), [1, 2, 0], 'colours.red.rgb[1]: must be <= 1.0'),
    (('grid', 'rows'), 0, 'grid.rows: must be >= 1'),
    (('grid', 'cell_capacity'), 0, 'grid.cell_capacity: must be >= 1'),
    (('game', 'horizon'), 7, 'game.horizon: must be <= 6'),
    (('game', 'discount'), 0.0, 'game.discount: must be > 0.0'),
    (('cost', 'clutter_factor'), 0.5, 'cost.clutter_factor: must be >= 1.0'),
    (('cost', 'charge_failed_actions'), 'yes', 'cost.charge_failed_actions: must be true or false'),
    (('utility', 'leader', 'own_cost'), -1.0, 'utility.leader.own_cost: must be >= 0.0'),
    (('gird',), {'rows': 2}, 'gird: unknown field'),
    (('grid', 'depth'), 2, 'grid.depth: unknown field'),
    (('robots', 'leader', 'speed'), 1.0, 'robots.leader.speed: unknown field'),
    (('game', 'horizont'), 2, 'game.horizont: unknown field'),
])
def test_invalid_task_names_the_field(path, value, message):
    with pytest.raises(TaskConfigError, match='^' + re.escape(message)):
        parse_task(with_change(path, value))


def test_colour_names_must_be_identifiers():
    data = small_task_data(3, 3, {'dark red': [2, 0]})
    with pytest.raises(TaskConfigError, match=r'^colours\.dark red: colour names must be identifiers'):
        parse_task(data)


def test_single_cell_grid_is_rejected():
    with pytest.raises(TaskConfigError, match='^grid: needs at least two cells'):
        parse_task(small_task_data(1, 1, {'red': [0, 0]}))


def cases_of(*objects, names=None):
    names = names or [f'c{i}' for i in range(len(objects))]
    return {'cases': [{'name': n, 'objects': o} for n, o in zip(names, objects)]}


@pytest.mark.parametrize('data, message', [
    (cases_of({'purple': [[0, 0]]}), "cases[0].objects.purple: unknown colour 'purple' (known: red, green, blue)"),
    (cases_of({'red': [[0, 0]]}, {'red': [[3, 1]]}),
     'cases[1].objects.red[0]: cell [3, 1] is outside the 3x3 grid'),
    (cases_of({'red': [[0, 3]]}), 'cases[0].objects.red[0]: cell [0, 3] is outside the 3x3 grid'),
    (cases_of({'red': [[-1, 0]]}), 'cases[0].objects.red[0][0]: must be >= 0'),
    (cases_of({'red': [[0, 0, 0]]}), 'cases[0].objects.red[0]: must be a cell [row, col]'),
    (cases_of({'red': [[0, 0]] * 4, 'blue': [[0, 0]] * 3}),
     'cases[0].objects: cell (0,0) holds 7 objects, more than grid.cell_capacity = 6'),
    (cases_of({'red': [[0, 0], [0, 1], [0, 2], [1, 0], [1, 1], [1, 2], [2, 1]]}),
     'cases[0].objects: the goal cell (2,0) would have to hold 7 objects, more than grid.cell_capacity = 6'),
    (cases_of({'red': [[0, 0]]}, {'green': [[1, 1]]}, names=['same', 'same']),
     "cases[1].name: duplicate case name 'same'"),
    (cases_of({}), 'cases[0].objects: the case has no objects'),
    (cases_of({'red': [[0, 0]]}, names=['']), 'cases[0].name: must be a non-empty string'),
    ({'cases': []}, 'cases: at least one case is required'),
    ({'cases': [{'name': 'a', 'objects': {'red': [[0, 0]]}, 'colour': 'red'}]}, 'cases[0].colour: unknown field'),
    ({'case': []}, 'case: unknown field'),
    ({'cases': {'name': 'a'}}, 'cases: must be a list'),
])
def test_invalid_cases_name_the_field(task, data, message):
    with pytest.raises(TaskConfigError, match='^' + re.escape(message)):
        parse_cases(data, task)


def test_errors_from_files_name_the_file(tmp_path, task):
    bad = tmp_path / 'task.yaml'
    bad.write_text('grid: {rows: 2}\ncolours: {red: {goal: [5, 0], rgb: [1, 0, 0]}}\n')
    with pytest.raises(TaskConfigError, match=r'^colours\.red\.goal: .*outside.*\(in .*task\.yaml\)$'):
        load_task(bad)
    broken = tmp_path / 'broken.yaml'
    broken.write_text('grid: [1, 2\n')
    with pytest.raises(TaskConfigError, match='invalid YAML'):
        load_task(broken)
    empty = tmp_path / 'empty.yaml'
    empty.write_text('')
    with pytest.raises(TaskConfigError, match='file is empty'):
        load_cases(empty, task)
    # The shared reader (collab_tools.core.fields) names a missing file so.
    with pytest.raises(TaskConfigError, match=r"^task file '.*missing\.yaml': does not exist"):
        load_task(tmp_path / 'missing.yaml')
    cases = tmp_path / 'cases.yaml'
    cases.write_text('cases:\n  - {name: a, objects: {pink: [[0, 0]]}}\n')
    with pytest.raises(TaskConfigError,
                       match=r"^cases\[0\]\.objects\.pink: unknown colour .*\(in .*cases\.yaml\)$"):
        load_cases(cases, task)
    assert issubclass(TaskConfigError, ConfigurationError) and issubclass(TaskConfigError, ValueError)
