"""FSE dynamic programming (Section IV-A, Algorithm 1) against brute-force enumeration."""
import numpy as np
import pytest

from sgcm.core.fse import FSEPlanner
from sgcm.core.rearrangement import FOLLOWER, LEADER, Move, RearrangementModel
from sgcm.core.task_config import parse_case, parse_task

from sgcm_tasks import small_task_data
from sgcm_reference import BruteForceFSE

# Tiny tasks small enough to enumerate every state up to T = 3.
INSTANCES = {
    # Team utility (the default weights): U^A = U^B, so every stage game is solved by its max entry.
    'line_cooperative': dict(
        task=small_task_data(1, 3, {'red': [0, 2]}, capacity=3,
                             robots={'leader': {'failure_probability': 0.1},
                                     'follower': {'failure_probability': 0.2}},
                             reward={'scale': 1.0, 'goal_bonus': 3.0}, game={'discount': 0.9}),
        objects={'red': [[0, 0], [0, 0]]}, cooperative=True),
    # Different utilities, a cell capacity that blocks moves, Manhattan reward, uncharged failures.
    'square_selfish': dict(
        task=small_task_data(2, 2, {'red': [1, 0], 'green': [0, 1]}, capacity=2,
                             robots={'leader': {'failure_probability': 0.2, 'diagonal_cost': 1.5},
                                     'follower': {'failure_probability': 0.1, 'move_cost': 0.5}},
                             cost={'charge_failed_actions': False},
                             reward={'scale': 1.0, 'distance': 'manhattan', 'goal_bonus': 2.0},
                             # a follower who minds his own cost three times as much: the leader
                             # commits to mixed strategies in some stage games
                             utility={'leader': {'own_cost': 1.0, 'other_cost': 1.0},
                                      'follower': {'own_cost': 3.0, 'other_cost': 0.0}},
                             game={'discount': 0.8}),
        objects={'red': [[0, 1]], 'green': [[1, 0]]}, cooperative=False),
}


def build(name):
    spec = INSTANCES[name]
    task = parse_task(spec['task'])
    model = RearrangementModel(task)
    return model, model.state_of(parse_case({'name': name, 'objects': spec['objects']}, task)), spec['cooperative']


def first_stage_check(plan, rows, cols, big_ua, big_ub, va, vb):
    """The planner's first-stage (pi_0^A, a_0^B) is an equilibrium of the brute-force root game."""
    x = np.zeros(len(rows))
    for action, p in zip(plan.leader_actions, plan.leader_policy):
        x[rows.index(int(action))] = p
    assert x.sum() == pytest.approx(1.0, abs=1e-9)
    j = cols.index(plan.follower_action)
    assert float(x @ big_ua[:, j]) == pytest.approx(va, abs=1e-6)
    assert float(x @ big_ub[:, j]) == pytest.approx(vb, abs=1e-6)
    assert float(x @ big_ub[:, j]) >= float((x @ big_ub).max()) - 1e-6   # a best response
    assert plan.leader_action == int(plan.leader_actions[np.argmax(plan.leader_policy)])


@pytest.mark.parametrize('horizon', [1, 2, 3])
@pytest.mark.parametrize('name', list(INSTANCES))
def test_fse_values_equal_brute_force(name, horizon):
    model, state, cooperative = build(name)
    reference = BruteForceFSE(model, horizon, cooperative)
    va, vb = reference.value(state, 0)
    rows, cols, big_ua, big_ub = reference.matrices(state, 0)
    sizes = [len(reference.reachable[t]) for t in range(horizon + 1)]
    assert sizes[-1] > 1
    plans = {}
    for solver in ('fast', 'milp'):
        plan = FSEPlanner(model, horizon=horizon, solver=solver, count_terminal_states=True).plan(state)
        assert plan.leader_value == pytest.approx(va, abs=1e-6), solver
        assert plan.follower_value == pytest.approx(vb, abs=1e-6), solver
        first_stage_check(plan, rows, cols, big_ua, big_ub, va, vb)
        assert plan.states_per_stage == sizes   # forward prediction: |S_0| .. |S_T|
        assert plan.stage_games == sum(sizes[:-1])
        plans[solver] = plan
    if name == 'square_selfish' and horizon >= 2:
        # The leader's commitment at s_0 is mixed here: the LP path of the stage solvers is used.
        assert len(plans['fast'].leader_actions) > 1 and plans['fast'].programs_solved > 0
    assert plans['fast'].leader_action == plans['milp'].leader_action
    assert plans['fast'].follower_action == plans['milp'].follower_action
    if cooperative:
        assert va == pytest.approx(vb, abs=1e-9)


def test_horizon_one_recommends_the_relay(small_task, state_of):
    # One red object two cells from its goal (1x3 line), T = 1, p_fail 0.1 / 0.2, bonus 3:
    #   she moves it to the middle (cost 1) and he carries it on (cost 1 when her move succeeded):
    #   u = 0 - 1 - 0.9, E[r'] = 0.72 * (2 + 3) + 0.18 * 1 = 3.78, U = -1.9 + 0.9 * 3.78 = 1.502;
    #   she alone: -1 + 0.9 * 0.9 = -0.19; he alone: -1 + 0.9 * 0.8 = -0.28; nobody moves: 0.
    task = parse_task(small_task_data(1, 3, {'red': [0, 2]},
                                      robots={'leader': {'failure_probability': 0.1},
                                              'follower': {'failure_probability': 0.2}},
                                      reward={'scale': 1.0, 'goal_bonus': 3.0}, game={'discount': 0.9}))
    model = RearrangementModel(task)
    state = state_of(model, {'red': [[0, 0]]})
    for solver in ('fast', 'milp'):
        plan = FSEPlanner(model, horizon=1, solver=solver).plan(state)
        assert plan.leader_action == model.actions[LEADER].index_of(Move(0, 1, 0))
        assert plan.follower_action == model.actions[FOLLOWER].index_of(Move(1, 2, 0))
        assert plan.leader_value == pytest.approx(1.502, abs=1e-9)
        assert plan.follower_value == pytest.approx(1.502, abs=1e-9)
        np.testing.assert_allclose(plan.leader_policy, [1.0])


def test_discount_weighs_the_future(small_task, state_of):
    # T = 2 from a 1x3 line state, gamma = 1 vs 0.5: discounting makes the future reward worth less
    # than the moves' costs (u counts r(s) of the stage's own state).
    base = dict(robots={'leader': {'failure_probability': 0.0}, 'follower': {'failure_probability': 0.0}},
                reward={'scale': 1.0, 'goal_bonus': 0.0})
    values = {}
    for gamma in (1.0, 0.5):
        task = parse_task(small_task_data(1, 3, {'red': [0, 2]}, game={'discount': gamma}, **base))
        model = RearrangementModel(task)
        values[gamma] = FSEPlanner(model, horizon=2).plan(state_of(model, {'red': [[0, 0]]})).leader_value
    # Without failures, r(s) = 0 now, 1 with the object in the middle, 2 at the goal; moves cost 1.
    #   relay now:       u_0 = -2, then idle at the goal: v_1 = 2 + gamma * 2
    #   one cell now:    u_0 = -1, then idle (v_1 = 1 + gamma) or finish (v_1 = 0 + 2 gamma)
    #   idle now:        u_0 = 0, then v_1(s) = max(0, -2 + 2 gamma, -1 + gamma)
    # gamma = 1:   relay 2, one cell -1 + 2 = 1, idle 0                      -> 2
    # gamma = 0.5: relay -2 + 1.5 = -0.5, one cell -1 + 0.75 = -0.25, idle 0 -> 0 (idling wins)
    assert values[1.0] == pytest.approx(2.0)
    assert values[0.5] == pytest.approx(0.0)


def test_planner_rejects_bad_arguments(model):
    with pytest.raises(ValueError, match='solver'):
        FSEPlanner(model, solver='gurobi')
    with pytest.raises(ValueError, match='horizon'):
        FSEPlanner(model, horizon=0)
    assert FSEPlanner(model).horizon == model.task.horizon
