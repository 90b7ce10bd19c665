"""The compiled FSE kernel (sgcm.core.fse_compiled / fse_kernel) against the reference (sgcm.core.fse) and
against hand-computed and brute-force values: same reachable sets, values, chosen actions."""
import numpy as np
import pytest

from sgcm.core.fse import FSEPlanner
from sgcm.core.fse_compiled import CompiledFSEPlanner
from sgcm.core.game_tables import is_cooperative
from sgcm.core.rearrangement import FOLLOWER, LEADER, Move, RearrangementModel
from sgcm.core.task_config import parse_task, task_of

from sgcm_reference import BruteForceFSE
from sgcm_tasks import small_task_data

VALUES = 1e-9   # the kernel repeats the reference's arithmetic: equal to a few ulps


def assert_same_plan(kernel, reference):
    assert kernel.leader_value == pytest.approx(reference.leader_value, abs=VALUES, rel=0)
    assert kernel.follower_value == pytest.approx(reference.follower_value, abs=VALUES, rel=0)
    assert (kernel.leader_action, kernel.follower_action) == (reference.leader_action, reference.follower_action)
    np.testing.assert_array_equal(kernel.leader_actions, reference.leader_actions)
    np.testing.assert_allclose(kernel.leader_policy, reference.leader_policy, atol=1e-9)
    assert kernel.states_per_stage == reference.states_per_stage
    assert kernel.stage_games == reference.stage_games


def relay_line(**sections):
    return parse_task(small_task_data(1, 3, {'red': [0, 2]},
                                      robots={'leader': {'failure_probability': 0.1},
                                              'follower': {'failure_probability': 0.2}},
                                      reward={'scale': 1.0, 'goal_bonus': 3.0}, game={'discount': 0.9}, **sections))


def test_horizon_one_relay_by_hand(state_of):
    # test_sgcm_fse's hand check on the kernel: she moves the object to the middle and he carries it on,
    # U = -1.9 + 0.9 * (0.72 * (2 + 3) + 0.18 * 1) = 1.502 (she alone -0.19, he alone -0.28, idle 0).
    model = RearrangementModel(relay_line())
    assert is_cooperative(model.task)
    plan = CompiledFSEPlanner(model, horizon=1).plan(state_of(model, {'red': [[0, 0]]}))
    assert plan.leader_action == model.actions[LEADER].index_of(Move(0, 1, 0))
    assert plan.follower_action == model.actions[FOLLOWER].index_of(Move(1, 2, 0))
    assert plan.leader_value == pytest.approx(1.502, abs=1e-12)
    assert plan.follower_value == pytest.approx(1.502, abs=1e-12)
    np.testing.assert_array_equal(plan.leader_policy, [1.0])
    assert plan.programs_solved == 0   # cooperative: settled in the kernel, no stage-game solver


def test_idle_is_the_lowest_action_among_equals(state_of):
    # Every object home: every move only costs, so nobody moves (EMPTY, index 0, for both).
    model = RearrangementModel(relay_line())
    plan = CompiledFSEPlanner(model, horizon=2).plan(state_of(model, {'red': [[0, 2], [0, 2]]}))
    assert (plan.leader_action, plan.follower_action) == (0, 0)
    # r = 2 * 2 + 3 (bonus) each stage: 7 + 0.9 * 7 + 0.81 * 7
    assert plan.leader_value == pytest.approx(7 * (1 + 0.9 + 0.81), abs=1e-12)


INSTANCES = {
    'line_two_objects': (dict(rows=1, cols=3, colours={'red': [0, 2]}, capacity=3,
                              robots={'leader': {'failure_probability': 0.1},
                                      'follower': {'failure_probability': 0.2}},
                              reward={'scale': 1.0, 'goal_bonus': 3.0}), {'red': [[0, 0], [0, 0]]}),
    'square_crowded': (dict(rows=2, cols=2, colours={'red': [1, 0], 'green': [0, 1]}, capacity=2,
                            robots={'leader': {'failure_probability': 0.2, 'diagonal_cost': 1.5},
                                    'follower': {'failure_probability': 0.1, 'move_cost': 0.5}},
                            cost={'charge_failed_actions': False, 'clutter_threshold': 2, 'clutter_factor': 3.0},
                            reward={'scale': 1.0, 'distance': 'manhattan', 'goal_bonus': 2.0},
                            game={'discount': 0.8}), {'red': [[0, 1], [0, 1]], 'green': [[1, 0]]}),
}


@pytest.mark.parametrize('horizon', [1, 2, 3])
@pytest.mark.parametrize('name', list(INSTANCES))
def test_kernel_equals_brute_force_and_reference(name, horizon, state_of):
    data, objects = INSTANCES[name]
    model = RearrangementModel(parse_task(small_task_data(**data)))
    state = state_of(model, objects)
    va, vb = BruteForceFSE(model, horizon, True).value(state, 0)
    kernel = CompiledFSEPlanner(model, horizon=horizon, count_terminal_states=True).plan(state)
    reference = FSEPlanner(model, horizon=horizon, count_terminal_states=True).plan(state)
    assert kernel.leader_value == pytest.approx(va, abs=1e-9)
    assert kernel.follower_value == pytest.approx(vb, abs=1e-9)
    assert_same_plan(kernel, reference)


@pytest.mark.parametrize('horizon', [1, 2])
def test_the_ten_cases_at_small_horizons(task, cases, horizon):
    for case in cases:
        model = RearrangementModel(task_of(case, task))
        state = model.state_of(case)
        assert_same_plan(CompiledFSEPlanner(model, horizon=horizon).plan(state),
                         FSEPlanner(model, horizon=horizon).plan(state))


def test_a_case_at_horizon_three_and_its_levels(task, cases):
    case = next(c for c in cases if c.name == 'case_8')   # the smallest: |S_2| = 625
    model = RearrangementModel(task_of(case, task))
    state = model.state_of(case)
    kernel_planner = CompiledFSEPlanner(model, horizon=3, count_terminal_states=True)
    kernel = kernel_planner.plan(state)
    assert_same_plan(kernel, FSEPlanner(model, horizon=3, count_terminal_states=True).plan(state))
    assert kernel_planner.terminal_states(state) == kernel.states_per_stage[-1]
    # The levels are the reference's reachable sets, each state under its key, no count negative.
    reference = FSEPlanner(model, horizon=3)
    levels = [(state[None, :], np.array([model.key(state)], dtype=np.uint64))]
    for _ in range(2):
        levels.append(reference._expand(*levels[-1]))
    for (states, keys, _), (ref_states, ref_keys) in zip(kernel_planner.levels(state), levels):
        order = np.argsort(keys)
        np.testing.assert_array_equal(keys[order], ref_keys)
        np.testing.assert_array_equal(states[order], ref_states)
        np.testing.assert_array_equal(model.keys(states), keys)
        assert (states >= 0).all()


def selfish_task(**game):
    # The follower minds his own cost three times as much: U^A != U^B, mixed commitments appear.
    return parse_task(small_task_data(2, 2, {'red': [1, 0], 'green': [0, 1]}, capacity=2,
                                      robots={'leader': {'failure_probability': 0.2, 'diagonal_cost': 1.5},
                                              'follower': {'failure_probability': 0.1, 'move_cost': 0.5}},
                                      cost={'charge_failed_actions': False},
                                      reward={'scale': 1.0, 'distance': 'manhattan', 'goal_bonus': 2.0},
                                      utility={'leader': {'own_cost': 1.0, 'other_cost': 1.0},
                                               'follower': {'own_cost': 3.0, 'other_cost': 0.0}},
                                      game={'discount': 0.8, **game}))


@pytest.mark.parametrize('solver, horizon', [('fast', 1), ('fast', 2), ('milp', 1)])
def test_general_sum_games_go_through_the_stage_game_solver(state_of, solver, horizon):
    model = RearrangementModel(selfish_task())
    state = state_of(model, {'red': [[0, 1]], 'green': [[1, 0]]})
    planner = CompiledFSEPlanner(model, horizon=horizon, solver=solver)
    assert not planner.cooperative
    calls = []
    solve = planner.solve_stage

    def spy(ua, ub):
        calls.append((ua.copy(), ub.copy()))
        return solve(ua, ub)
    planner.solve_stage = spy
    kernel = planner.plan(state)
    reference = FSEPlanner(model, horizon=horizon, solver=solver, keep_stage_games=10 ** 6).plan(state)
    assert len(calls) == kernel.stage_games == reference.stage_games   # one solver call per state
    assert kernel.programs_solved == reference.programs_solved
    assert_same_plan(kernel, reference)
    # The kernel hands the solver the reference's matrices (same values; states in another order).
    ours = sorted((ua.shape, ua.round(9).tobytes(), ub.round(9).tobytes()) for ua, ub in calls)
    theirs = sorted((ua.shape, ua.round(9).tobytes(), ub.round(9).tobytes())
                    for ua, ub in reference.stage_game_samples)
    assert ours == theirs
    if horizon == 2 and solver == 'fast':
        assert len(kernel.leader_actions) > 1   # a mixed commitment at s_0, as in the reference


def test_cooperative_games_never_call_the_solver(task, cases):
    case = cases[0]
    model = RearrangementModel(task_of(case, task))
    planner = CompiledFSEPlanner(model, horizon=2)
    assert planner.cooperative

    def refuse(ua, ub):
        raise AssertionError('a cooperative stage game went to the solver')
    planner.solve_stage = refuse
    assert planner.plan(model.state_of(case)).programs_solved == 0


def test_cooperative_means_equal_weights_crosswise():
    assert is_cooperative(relay_line())
    assert is_cooperative(relay_line(utility={'leader': {'own_cost': 2.0, 'other_cost': 0.5},
                                              'follower': {'own_cost': 0.5, 'other_cost': 2.0}}))
    assert not is_cooperative(selfish_task())


def test_states_the_kernel_cannot_settle_go_to_the_solver(state_of):
    # Forced through the cooperative shortcut, a general-sum game still equals the reference: states a pure
    # commitment settles get the solver's choice, the others (mixed commitments) are handed to the solver.
    model = RearrangementModel(selfish_task())
    state = state_of(model, {'red': [[0, 1]], 'green': [[1, 0]]})
    planner = CompiledFSEPlanner(model, horizon=2)
    planner.cooperative = True
    calls = []
    solve = planner.solve_stage
    planner.solve_stage = lambda ua, ub: calls.append(ua.shape) or solve(ua, ub)
    kernel = planner.plan(state)
    reference = FSEPlanner(model, horizon=2).plan(state)
    assert 0 < len(calls) < kernel.stage_games
    assert_same_plan(kernel, reference)
