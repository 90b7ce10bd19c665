"""The kernel's tie rule (sgcm.core.fse_kernel._solve_pure) is the reference solver's choice, the planner
paths are selectable (make_planner, the leader's ``planner`` setting, LeaderRound's default), and the
benchmark stores what issue 14 asks for."""
import json
import re

import numpy as np
import pytest

from collab_tools.core.errors import ConfigurationError
from sgcm.core.fse import FSEPlanner
from sgcm.core.fse_compiled import PLANNER_PATHS, CompiledFSEPlanner, make_planner
from sgcm.core.fse_kernel import NO_ROW, _solve_pure
from sgcm.core.leader_round import LeaderRound
from sgcm.core.rearrangement import RearrangementModel
from sgcm.core.settings import LEADER_SETTINGS, LeaderSettings
from sgcm.core.stage_game import DEFAULT_TOLERANCE, solve_fast
from sgcm.core.task_config import task_of
from sgcm.experiments import CASE_OPTIONS
from sgcm.experiments.benchmark import run_benchmark


def pure(ua, ub):
    """_solve_pure as the kernel calls it: (row, column, settled)."""
    ua, ub = np.asarray(ua, dtype=float), np.asarray(ub, dtype=float)
    tol = DEFAULT_TOLERANCE * max(1.0, np.abs(ua).max(), np.abs(ub).max())
    return _solve_pure(ua, ub, ua.shape[0], ua.shape[1], tol, ub.max(axis=1), ua.max(axis=0))


def test_maximal_entry_lowest_follower_action_then_lowest_leader_action():
    # The maximum 2 is reached in columns 0, 1, 2: the lowest column (0), there the only row (1).
    u = [[1.0, 2.0, 2.0],
         [2.0, 2.0, 0.0]]
    assert pure(u, u) == (1, 0, True)
    # In column 1 rows 0 and 2 reach it: the lowest row.
    u = [[0.0, 3.0],
         [1.0, 1.0],
         [0.0, 3.0]]
    assert pure(u, u) == (0, 1, True)
    for u in ([[1.0, 2.0, 2.0], [2.0, 2.0, 0.0]], [[0.0, 3.0], [1.0, 1.0], [0.0, 3.0]]):
        solution = solve_fast(u, u)
        row, col, _ = pure(u, u)
        assert (solution.leader_action, solution.follower_action) == (row, col)


def test_differences_below_the_tolerance_are_ties():
    # 5 + 1e-12 beats 5 only by far less than 1e-9 x the payoff scale: the lower column still wins.
    u = np.array([[5.0, 5.0 + 1e-12], [0.0, 0.0]])
    assert pure(u, u)[:2] == (0, 0)
    assert solve_fast(u, u).follower_action == 0
    u = np.array([[5.0, 5.0 + 1e-6], [0.0, 0.0]])
    assert pure(u, u)[:2] == (0, 1)


@pytest.mark.parametrize('seed', range(6))
def test_random_cooperative_games_with_many_ties_match_the_solver(seed):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        m, n = rng.integers(1, 7, size=2)
        ua = rng.integers(0, 4, size=(m, n)).astype(float) * 0.3   # few distinct values: many ties
        ub = ua + rng.integers(-1, 2, size=(m, n)) * 1e-15 * (ua != 0)   # U^B = U^A up to rounding
        row, col, settled = pure(ua, ub)
        solution = solve_fast(ua, ub)
        assert settled and solution.programs_solved == 0
        assert (row, col) == (solution.leader_action, solution.follower_action)
        assert (ua[row, col], ub[row, col]) == (solution.leader_value, solution.follower_value)


def test_a_game_that_needs_an_lp_is_not_settled():
    # Matching pennies for the follower: no pure commitment reaches the leader's best column bound.
    ua = np.array([[3.0, 0.0], [0.0, 3.0]])
    ub = np.array([[0.0, 1.0], [1.0, 0.0]])
    assert pure(ua, ub) == (NO_ROW, NO_ROW, False)
    assert solve_fast(ua, ub).programs_solved > 0


def test_make_planner_and_the_defaults(model):
    assert PLANNER_PATHS == ('kernel', 'reference')
    assert isinstance(make_planner(model), CompiledFSEPlanner)
    reference = make_planner(model, 3, 'milp', 'reference')
    assert isinstance(reference, FSEPlanner) and (reference.horizon, reference.solver) == (3, 'milp')
    with pytest.raises(ValueError, match="planner: must be one of kernel, reference"):
        make_planner(model, path='numpy')
    with pytest.raises(ValueError, match='solver'):
        CompiledFSEPlanner(model, solver='gurobi')
    with pytest.raises(ValueError, match='horizon'):
        CompiledFSEPlanner(model, horizon=0)
    assert isinstance(LeaderRound(model).planner, CompiledFSEPlanner)
    assert LeaderRound(model, 'greedy').planner is None


def test_the_leader_setting_selects_the_path(task_file):
    settings = LeaderSettings.from_values(LEADER_SETTINGS.validate({'task_file': str(task_file)}))
    assert settings.planner == 'kernel'
    assert not LEADER_SETTINGS['planner'].dynamic
    settings = LeaderSettings.from_values(LEADER_SETTINGS.validate(
        {'task_file': str(task_file), 'planner': 'reference'}))
    assert settings.planner == 'reference'
    with pytest.raises(ConfigurationError,
                       match='^' + re.escape("parameter planner: must be one of kernel, reference (got 'fast')")):
        LEADER_SETTINGS.validate({'task_file': str(task_file), 'planner': 'fast'})
    option = next(o for o in CASE_OPTIONS if o.flag == '--planner')
    assert tuple(option.choices) == PLANNER_PATHS and option.default == 'kernel'


def test_the_benchmark_stores_both_paths_side_by_side(task, cases, tmp_path):
    chosen = [c for c in cases if c.name in ('case_8', 'case_10')]
    lines = []
    results = run_benchmark(task, chosen, tmp_path, horizons=(1, 2), repeats=2, milp_samples=0, log=lines.append)
    stored = json.loads((tmp_path / 'results.json').read_text())
    assert stored['round_ms_median'].keys() == {'1', '2'}
    for row in stored['round_ms_median'].values():
        assert row['kernel'] > 0 and row['reference'] > 0
        assert row['ratio'] == pytest.approx(row['reference'] / row['kernel'])
    assert results['values_identical'] and results['max_value_difference'] <= 1e-9
    assert len(lines) == 4 and all('kernel' in line and 'reference' in line for line in lines)
    for row in stored['rows']:
        model = RearrangementModel(task_of(next(c for c in chosen if c.name == row['case']), task))
        assert len(row['states_per_stage']) == row['horizon'] + 1   # |S_0| .. |S_T|
        assert row['leader_action']['kernel'] == row['leader_action']['reference']
        assert model.actions[0].size > row['leader_action']['kernel'] >= 0
