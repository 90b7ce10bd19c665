"""Follower behaviours (Section V-B) and the one-stage greedy rule."""
import numpy as np
import pytest

from sgcm.core.follower_behaviour import Follower, FollowerSettings, best_response, greedy_action
from sgcm.core.rearrangement import EMPTY, FOLLOWER, LEADER, Move, RearrangementModel


def test_obedient_follower_returns_the_recommendation(model, cases):
    follower = Follower(model, FollowerSettings('obedient'))
    state = model.state_of(cases[0])
    for recommended in (EMPTY, 5, 17, 40):
        choice = follower.choose(1, state, state, EMPTY, recommended)
        assert choice.action == recommended and not choice.deviated


def test_zero_trust_follower_moves_greedily_on_the_state_he_sees(model, cases):
    follower = Follower(model, FollowerSettings('zero_trust'))
    differs = 0
    for case in cases:
        state = model.state_of(case)
        for leader_action in model.feasible(state, LEADER)[::3]:
            seen = model.apply(state, LEADER, leader_action)
            choice = follower.choose(1, seen, state, leader_action, EMPTY)
            assert choice.action == greedy_action(model, seen, FOLLOWER)
            assert choice.deviated == (choice.action != EMPTY)
            differs += choice.action != greedy_action(model, state, FOLLOWER)
    assert differs > 0   # the leader's move matters: he acts on the state after it


def test_greedy_rule_by_hand(small_task, state_of):
    # 1x3 line, red at (0,1), goal (0,2), scale 1: moving right gains 1 in reward.
    def choose(move_cost, goal_bonus=0.0, sign=1.0):
        task = small_task(1, 3, {'red': [0, 2]}, robots={'follower': {'move_cost': move_cost}},
                          reward={'scale': 1.0, 'goal_bonus': goal_bonus})
        model = RearrangementModel(task)
        action = greedy_action(model, state_of(model, {'red': [[0, 1]]}), FOLLOWER, sign=sign)
        return model.describe(FOLLOWER, action)

    assert choose(0.5) == 'red (0,1)->(0,2)'            # 1 - 0.5 > 0
    assert choose(1.0) == 'no move'                     # 1 - 1 = 0: a tie prefers not moving
    assert choose(1.0, goal_bonus=1.0) == 'red (0,1)->(0,2)'   # 1 + 1 - 1 > 0
    assert choose(0.5, sign=-1.0) == 'red (0,1)->(0,0)'  # adversarial: -(-1) - 0.5 > 0


def test_random_follower_deviates_exactly_in_the_listed_round(model, cases):
    follower = Follower(model, FollowerSettings('random', 0.0, (2,)), seed=3)
    state = model.state_of(cases[1])
    recommended = model.feasible(state, FOLLOWER)[1]
    for round_number in range(1, 8):
        for rec in (EMPTY, recommended):
            choice = follower.choose(round_number, state, state, EMPTY, rec)
            if round_number == 2 and rec == EMPTY:
                # a random feasible move (never the empty one while a move exists)
                assert choice.deviated and choice.action in model.feasible(state, FOLLOWER)[1:]
            elif round_number != 2:
                assert choice.action == rec and not choice.deviated


def test_random_follower_deviation_rate(model, cases):
    state = model.state_of(cases[2])
    always = Follower(model, FollowerSettings('random', 1.0), seed=1)
    assert all(always.choose(r, state, state, EMPTY, EMPTY).deviated for r in range(1, 30))
    half = Follower(model, FollowerSettings('random', 0.5), seed=1)
    rate = np.mean([half.choose(r, state, state, EMPTY, EMPTY).deviated for r in range(1, 801)])
    assert rate == pytest.approx(0.5, abs=0.06)
    # Seeded: the same seed gives the same choices.
    a, b = (Follower(model, FollowerSettings('random', 0.3), seed=9) for _ in range(2))
    assert [a.choose(r, state, state, EMPTY, EMPTY).action for r in range(1, 40)] == \
        [b.choose(r, state, state, EMPTY, EMPTY).action for r in range(1, 40)]


def test_myopic_follower_best_responds_to_the_announced_move(small_task, state_of):
    # 1x3, red at (0,0), goal (0,2), p_fail 0.1 each, follower move cost 0.5, leader moves it to
    # the middle. Relay: E[r'] = 0.81 * 2 + 0.09 * 1 = 1.71, E[c] = 0.9 * 0.5 -> 1.26;
    # idle: E[r'] = 0.9 -> 0.9; his own move from (0,0) (blocked if hers succeeded):
    # E[r'] = 0.81 + 0.09 + 0.09 = 0.99, E[c] = 0.1 * 0.5 -> 0.94.
    task = small_task(1, 3, {'red': [0, 2]}, robots={'follower': {'move_cost': 0.5}},
                      reward={'scale': 1.0, 'goal_bonus': 0.0})
    model = RearrangementModel(task)
    state = state_of(model, {'red': [[0, 0]]})
    leader_move = model.actions[LEADER].index_of(Move(0, 1, 0))
    relay = model.actions[FOLLOWER].index_of(Move(1, 2, 0))
    assert best_response(model, state, leader_move) == relay
    choice = Follower(model, FollowerSettings('myopic')).choose(
        1, model.apply(state, LEADER, leader_move), state, leader_move, EMPTY)
    assert choice.action == relay and choice.deviated
    with pytest.raises(ValueError, match='not feasible'):
        best_response(model, state, model.actions[LEADER].index_of(Move(1, 2, 0)))


def test_adversarial_follower_undoes_progress(model, state_of):
    state = state_of(model, {'red': [[2, 0], [1, 0]], 'green': [[2, 1]]})
    choice = Follower(model, FollowerSettings('adversarial')).choose(1, state, state, EMPTY, EMPTY)
    after = model.apply(state, FOLLOWER, choice.action)
    assert float(model.reward(after)) < float(model.reward(state))
    assert choice.action == greedy_action(model, state, FOLLOWER, sign=-1.0)


@pytest.mark.parametrize('kwargs, field', [
    (dict(behaviour='lazy'), 'behaviour'),
    (dict(behaviour='random', deviation_probability=1.5), 'deviation_probability'),
    (dict(behaviour='random', deviation_probability=-0.1), 'deviation_probability'),
    (dict(behaviour='random', deviation_rounds=(0,)), 'deviation_rounds'),
])
def test_invalid_follower_settings_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=f'^{field}: '):
        FollowerSettings(**kwargs)
