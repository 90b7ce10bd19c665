"""Rules of the rearrangement game: actions, feasibility, costs, rewards, outcomes, relays."""
import numpy as np
import pytest

from sgcm.core.episode import MoveExecutor
from sgcm.core.rearrangement import EMPTY, FOLLOWER, LEADER, Move, RearrangementModel
from sgcm.core.task_config import ClutterRule


def moves_of(model, robot, actions):
    return {model.describe(robot, int(a)) for a in actions}


def random_states(model, count, seed):
    """Valid states: 1..7 objects of random colours in random cells below capacity."""
    rng = np.random.default_rng(seed)
    task = model.task
    states = []
    while len(states) < count:
        counts = np.zeros((task.cells, model.colours), dtype=np.int64)
        for _ in range(int(rng.integers(1, 8))):
            counts[rng.integers(task.cells), rng.integers(model.colours)] += 1
        if counts.sum(axis=1).max() <= task.cell_capacity:
            states.append(model.state_of(counts))
    return states


# --- actions ----------------------------------------------------------------------------

def test_action_tables_on_the_3x3_grid(model):
    leader, follower = model.actions
    # 8 directions: corners have 3 neighbours, edge cells 5, the centre 8 -> 40 directed moves;
    # 4 directions: 2, 3 and 4 -> 24; each for 3 colours, plus the empty action.
    assert leader.size == 1 + 40 * 3
    assert follower.size == 1 + 24 * 3
    np.testing.assert_array_equal(np.bincount(leader.source[1:], minlength=9) // 3, [3, 5, 3, 5, 8, 5, 3, 5, 3])
    np.testing.assert_array_equal(np.bincount(follower.source[1:], minlength=9) // 3, [2, 3, 2, 3, 4, 3, 2, 3, 2])
    for table, is_neighbour in ((leader, lambda dr, dc: max(dr, dc) == 1),
                                (follower, lambda dr, dc: dr + dc == 1)):
        assert table.move(EMPTY).is_empty and table.base_cost[EMPTY] == 0.0
        rows_s, cols_s = np.divmod(table.source[1:], 3)
        rows_t, cols_t = np.divmod(table.target[1:], 3)
        dr, dc = np.abs(rows_s - rows_t), np.abs(cols_s - cols_t)
        assert all(is_neighbour(r, c) for r, c in zip(dr, dc))
        triples = set(zip(table.source[1:], table.target[1:], table.colour[1:]))
        assert len(triples) == table.size - 1
        for index in range(table.size):
            assert table.index_of(table.move(index)) == index
    assert leader.diagonal.sum() == 16 * 3 and not follower.diagonal.any()
    with pytest.raises(ValueError, match='not an action of this robot'):
        follower.index_of(Move(0, 4, 0))   # (0,0) -> (1,1) is diagonal


def test_direction_count_and_costs_come_from_the_task(small_task):
    task = small_task(3, 3, robots={'leader': {'directions': 4, 'move_cost': 2.0},
                                    'follower': {'directions': 8, 'move_cost': 0.5, 'diagonal_cost': 0.75}})
    leader, follower = RearrangementModel(task).actions
    assert leader.size == 1 + 24 and follower.size == 1 + 40
    np.testing.assert_array_equal(leader.base_cost[1:], 2.0)
    np.testing.assert_array_equal(follower.base_cost[1:], np.where(follower.diagonal[1:], 0.75, 0.5))


def test_feasibility_needs_an_object_and_room_in_the_destination(small_task, state_of):
    # 1x3 grid, capacity 2: red at (0,0), two green at (0,1) (full).
    model = RearrangementModel(small_task(1, 3, {'red': [0, 2], 'green': [0, 0]}, capacity=2))
    state = state_of(model, {'red': [[0, 0]], 'green': [[0, 1], [0, 1]]})
    expected = {'no move', 'green (0,1)->(0,0)', 'green (0,1)->(0,2)'}
    for robot in (LEADER, FOLLOWER):
        feasible = model.feasible(state, robot)
        assert feasible[0] == EMPTY
        assert moves_of(model, robot, feasible) == expected   # red (0,0)->(0,1): (0,1) is full


def test_feasible_equals_can_apply_on_random_states(model):
    for state in random_states(model, 30, seed=3):
        for robot in (LEADER, FOLLOWER):
            expected = [a for a in range(model.actions[robot].size) if model.can_apply(state, robot, a)]
            np.testing.assert_array_equal(model.feasible(state, robot), expected)


# --- costs ------------------------------------------------------------------------------

def test_clutter_multiplier_values():
    # factor ** floor(n / threshold): 1-2 objects base price, 3-5 twice, 6-8 four times, 9 eight.
    np.testing.assert_array_equal(ClutterRule(3, 2.0).multiplier(np.arange(1, 10)), [1, 1, 2, 2, 2, 4, 4, 4, 8])
    np.testing.assert_array_equal(ClutterRule(2, 3.0).multiplier(np.arange(1, 6)), [1, 3, 3, 9, 9])
    assert ClutterRule(1, 1.0).multiplier(7) == 1.0


def test_costs_use_the_source_cell_crowd(small_task, state_of):
    task = small_task(3, 3, {'red': [2, 0], 'green': [2, 1]},
                      robots={'leader': {'move_cost': 1.0, 'diagonal_cost': 1.5}, 'follower': {'move_cost': 0.5}})
    model = RearrangementModel(task)

    def cost(state, robot, source, target, colour):
        table = model.actions[robot]
        return float(model.cost(state, robot, table.index_of(Move(source, target, colour))))

    # (1,1) = cell 4 holds 1 red + 2 green: n = 3 -> multiplier 2 for every colour taken from it.
    crowded = state_of(model, {'red': [[1, 1], [0, 0]], 'green': [[1, 1], [1, 1]]})
    assert cost(crowded, LEADER, 4, 6, 0) == 1.5 * 2      # diagonal
    assert cost(crowded, LEADER, 4, 7, 0) == 1.0 * 2
    assert cost(crowded, LEADER, 4, 7, 1) == 1.0 * 2
    assert cost(crowded, FOLLOWER, 4, 7, 0) == 0.5 * 2
    # Taking from the uncrowded (0,0) into the crowded centre costs the base price.
    assert cost(crowded, LEADER, 0, 4, 0) == 1.5
    # Six objects: multiplier 4.
    packed = state_of(model, {'red': [[1, 1]] * 3, 'green': [[1, 1]] * 3})
    assert cost(packed, LEADER, 4, 6, 0) == 1.5 * 4
    assert cost(packed, FOLLOWER, 4, 5, 1) == 0.5 * 4
    assert float(model.cost(packed, LEADER, EMPTY)) == 0.0


# --- rewards ----------------------------------------------------------------------------

def test_reward_formula_and_goal_bonus(model, state_of):
    # task.yaml: scale 1.5, Chebyshev distance (d_max = 2 on 3x3), goal bonus 5;
    # goals red (2,0), green (2,1), blue (2,2).
    mixed = state_of(model, {'red': [[0, 2]], 'green': [[1, 1]], 'blue': [[2, 2]]})
    # red d=2 -> 0, green d=1 -> 1.5, blue d=0 -> 3
    assert float(model.reward(mixed)) == pytest.approx(4.5)
    home = state_of(model, {'red': [[2, 0]], 'green': [[2, 1]], 'blue': [[2, 2]]})
    assert float(model.reward(home)) == pytest.approx(3 * 3.0 + 5.0)
    np.testing.assert_array_equal(model.goal_state(mixed), home)
    almost = state_of(model, {'red': [[2, 0], [2, 0]], 'green': [[2, 1]], 'blue': [[1, 2]]})
    assert float(model.reward(almost)) == pytest.approx(3 * 3.0 + 1.5)   # no bonus: blue is not home
    assert int(model.misplaced(almost)) == 1
    np.testing.assert_allclose(model.reward(np.stack([mixed, home, almost])), [4.5, 14.0, 10.5])


def test_reward_with_manhattan_distance(small_task, state_of):
    task = small_task(3, 3, {'red': [2, 0], 'green': [2, 1], 'blue': [2, 2]},
                      reward={'scale': 1.0, 'distance': 'manhattan', 'goal_bonus': 2.0})
    model = RearrangementModel(task)
    # d_max = 4: red (0,2) d=4 -> 0, green (1,1) d=1 -> 3, blue home -> 4.
    assert float(model.reward(state_of(model, {'red': [[0, 2]], 'green': [[1, 1]], 'blue': [[2, 2]]}))) == 7.0
    assert float(model.reward(state_of(model, {'red': [[2, 0]], 'green': [[2, 1]]}))) == 4 + 4 + 2.0


# --- stage matrices ---------------------------------------------------------------------

def sample_states(model, cases):
    return [model.state_of(case) for case in cases] + random_states(model, 10, seed=8)


def test_linear_keys_equal_keys_of_the_successor_states(model, cases):
    for state in sample_states(model, cases):
        stage = model.stage(state)
        successors = model.successor_states(state, stage)
        flat = successors.reshape(-1, model.dim)
        np.testing.assert_array_equal(model.keys(flat), stage.outcome_keys.reshape(-1))
        # Distinct successor states have distinct keys (no collision among them).
        assert len(np.unique(flat, axis=0)) == len(np.unique(stage.outcome_keys))
        assert (flat >= 0).all()


def test_outcome_rewards_equal_rewards_of_the_successor_states(model, cases):
    for state in sample_states(model, cases):
        stage = model.stage(state)
        successors = model.successor_states(state, stage)
        np.testing.assert_allclose(model.outcome_rewards(state, stage), model.reward(successors), atol=1e-12)


def test_successor_states_follow_the_step_rules(model, cases):
    # Every action pair and outcome of a few states, against model.step one by one.
    flags = ((True, True), (True, False), (False, True), (False, False))
    for state in [model.state_of(cases[0]), model.state_of(cases[5])] + random_states(model, 1, seed=21):
        stage = model.stage(state)
        successors = model.successor_states(state, stage)
        for i, a in enumerate(stage.leader_actions):
            for k, b in enumerate(stage.follower_actions):
                for o, (leader_ok, follower_ok) in enumerate(flags):
                    expected = model.step(state, int(a), int(b), leader_ok, follower_ok)
                    np.testing.assert_array_equal(successors[i, k, o], expected)


def test_stage_costs_match_costs_on_the_acted_on_state(model, cases):
    for state in sample_states(model, cases)[:6]:
        stage = model.stage(state)
        np.testing.assert_allclose(stage.leader_cost, model.cost(state, LEADER, stage.leader_actions))
        for k, b in enumerate(stage.follower_actions):
            alone = float(model.cost(state, FOLLOWER, b)) if model.can_apply(state, FOLLOWER, b) else 0.0
            assert stage.follower_cost_alone[k] == alone
            assert stage.blocked_alone[k] == (not model.can_apply(state, FOLLOWER, b))
        for i, a in enumerate(stage.leader_actions):
            after = model.apply(state, LEADER, int(a))   # the state the follower acts on
            for k, b in enumerate(stage.follower_actions):
                ok = model.can_apply(after, FOLLOWER, b)
                assert stage.blocked[i, k] == (not ok)
                assert stage.follower_cost[i, k] == (float(model.cost(after, FOLLOWER, b)) if ok else 0.0)


def test_follower_candidates_are_every_move_that_may_find_its_object(model, cases):
    for state in sample_states(model, cases)[:6]:
        stage = model.stage(state)
        np.testing.assert_array_equal(stage.leader_actions, model.feasible(state, LEADER))
        may_find = {b for b in range(model.actions[FOLLOWER].size)
                    if any(model.apply(state, LEADER, int(a))[model.actions[FOLLOWER].take[b]] > 0
                           for a in stage.leader_actions)}
        assert set(stage.follower_actions[1:].tolist()) == may_find - {EMPTY}
        assert stage.follower_actions[0] == EMPTY


def test_outcome_probabilities(small_task, model):
    np.testing.assert_allclose(model.outcome_probability, [0.81, 0.09, 0.09, 0.01])
    task = small_task(robots={'leader': {'failure_probability': 0.1}, 'follower': {'failure_probability': 0.3}})
    custom = RearrangementModel(task)
    # (both succeed, leader only, follower only, neither) with independent failures
    np.testing.assert_allclose(custom.outcome_probability, [0.9 * 0.7, 0.9 * 0.3, 0.1 * 0.7, 0.1 * 0.3])
    assert custom.outcome_probability.sum() == pytest.approx(1.0)
    certain = RearrangementModel(small_task(game={'failure_probability': {'leader': 0.0, 'follower': 0.0}}))
    np.testing.assert_array_equal(certain.outcome_probability, [1, 0, 0, 0])
    state = np.zeros(custom.dim, dtype=np.int64)
    state[0] = 1
    np.testing.assert_array_equal(custom.stage(state).outcome_probability, custom.outcome_probability)


def test_simulated_failures_happen_at_the_configured_rate(small_task, state_of):
    task = small_task(robots={'leader': {'failure_probability': 0.1}, 'follower': {'failure_probability': 0.3}})
    model = RearrangementModel(task)
    state = state_of(model, {'red': [[0, 1]]})
    executor = MoveExecutor(model, True, np.random.default_rng(4))
    for robot, p_fail in ((LEADER, 0.1), (FOLLOWER, 0.3)):
        action = model.actions[robot].index_of(Move(1, 2, 0))
        results = [executor.attempt(state, robot, action) for _ in range(4000)]
        failures = sum(not ok for _, ok, _ in results)
        assert failures / 4000 == pytest.approx(p_fail, abs=0.025)
        # A failed move leaves the state as it was and is still charged (charge_failed_actions).
        for after, ok, cost in results[:50]:
            np.testing.assert_array_equal(after, state if not ok else model.apply(state, robot, action))
            assert cost == 1.0
    leader_move = model.actions[LEADER].index_of(Move(1, 2, 0))
    no_failures = MoveExecutor(model, False, np.random.default_rng(4))
    assert all(no_failures.attempt(state, LEADER, leader_move)[1] for _ in range(200))


# --- relays and blocked moves -----------------------------------------------------------

@pytest.fixture
def line_model(small_task):
    """1x3 grid, red goal (0,2), green goal (0,0), p_fail 0.1 / 0.2, capacity 3."""
    return RearrangementModel(small_task(1, 3, {'red': [0, 2], 'green': [0, 0]}, capacity=3,
                                         robots={'leader': {'failure_probability': 0.1},
                                                 'follower': {'failure_probability': 0.2}}))


def position(array, value):
    found = np.flatnonzero(np.asarray(array) == value)
    assert len(found) == 1, f'{value} not in {array}'
    return int(found[0])


def test_follower_relays_the_object_the_leader_put_down(line_model, state_of):
    model = line_model
    la, lb = model.actions
    state = state_of(model, {'red': [[0, 0]], 'green': [[0, 1], [0, 1]]})
    leader_move = la.index_of(Move(0, 1, 0))   # red (0,0)->(0,1): (0,1) then holds 3 objects
    relay = lb.index_of(Move(1, 2, 0))         # red (0,1)->(0,2): no red in (0,1) before her move
    stage = model.stage(state)
    i, k = position(stage.leader_actions, leader_move), position(stage.follower_actions, relay)
    assert not stage.blocked[i, k] and stage.blocked_alone[k] and stage.blocked[0, k]
    # Costs on the state he acts on: after her move (0,1) holds 3 -> clutter multiplier 2.
    assert stage.follower_cost[i, k] == 2.0 and stage.follower_cost_alone[k] == 0.0
    green_out = position(stage.follower_actions, lb.index_of(Move(1, 2, 1)))
    assert stage.follower_cost_alone[green_out] == 1.0 and stage.follower_cost[i, green_out] == 2.0
    done = state_of(model, {'red': [[0, 2]], 'green': [[0, 1], [0, 1]]})
    half = state_of(model, {'red': [[0, 1]], 'green': [[0, 1], [0, 1]]})
    np.testing.assert_array_equal(model.step(state, leader_move, relay), done)
    np.testing.assert_array_equal(model.step(state, leader_move, relay, follower_ok=False), half)
    np.testing.assert_array_equal(model.step(state, leader_move, relay, leader_ok=False), state)
    successors = model.successor_states(state, stage)[i, k]
    for got, expected in zip(successors, (done, half, state, state)):
        np.testing.assert_array_equal(got, expected)


def test_blocked_follower_moves_have_no_effect_and_no_cost(line_model, state_of):
    model = line_model
    la, lb = model.actions
    # (0,1) full (capacity 3): red (0,0)->(0,1) is blocked unless the leader makes room.
    state = state_of(model, {'red': [[0, 0]], 'green': [[0, 1], [0, 1], [0, 1]]})
    into_full = lb.index_of(Move(0, 1, 0))
    make_room = la.index_of(Move(1, 2, 1))     # green (0,1)->(0,2)
    stage = model.stage(state)
    i, k = position(stage.leader_actions, make_room), position(stage.follower_actions, into_full)
    assert stage.blocked[0, k] and stage.blocked_alone[k]
    assert stage.follower_cost[0, k] == 0.0 and stage.follower_cost_alone[k] == 0.0
    assert not stage.blocked[i, k] and stage.follower_cost[i, k] == 1.0
    np.testing.assert_array_equal(model.step(state, EMPTY, into_full), state)
    # A move that can never find its object is no candidate at all and changes nothing.
    nothing = lb.index_of(Move(2, 1, 0))      # red (0,2)->(0,1): no red can be at (0,2)
    assert nothing not in stage.follower_actions
    np.testing.assert_array_equal(model.step(state, EMPTY, nothing), state)
    # Executing such moves: nothing happens, nothing is charged.
    executor = MoveExecutor(model, False, np.random.default_rng(0))
    for action in (into_full, nothing):
        after, ok, cost = executor.attempt(state, FOLLOWER, action)
        np.testing.assert_array_equal(after, state)
        assert not ok and cost == 0.0


def test_expected_costs_and_stage_utilities_by_hand(small_task, state_of):
    # 1x3, red at (0,0), goal (0,2), scale 1 -> r(s) = 0; p_fail 0.1 / 0.2.
    # Leader red (0,0)->(0,1) costs 1; the relay costs 1 if her move succeeded, else nothing:
    # E[c^B] = 0.9. u^A = 0 - 1*1 - 0.5*0.9 = -1.45, u^B = 0 - 2*0.9 - 0.25*1 = -2.05.
    data = dict(robots={'leader': {'failure_probability': 0.1}, 'follower': {'failure_probability': 0.2}},
                utility={'leader': {'own_cost': 1.0, 'other_cost': 0.5},
                         'follower': {'own_cost': 2.0, 'other_cost': 0.25}})
    for charge_failed, ua_expected, ub_expected in ((True, -1.45, -2.05),
                                                    # not charged: c^A = 0.9 * 1, c^B = 0.8 * 0.9
                                                    (False, -0.9 - 0.5 * 0.72, -2 * 0.72 - 0.25 * 0.9)):
        model = RearrangementModel(small_task(cost={'charge_failed_actions': charge_failed}, **data))
        state = state_of(model, {'red': [[0, 0]]})
        stage = model.stage(state)
        i = position(stage.leader_actions, model.actions[LEADER].index_of(Move(0, 1, 0)))
        k = position(stage.follower_actions, model.actions[FOLLOWER].index_of(Move(1, 2, 0)))
        ua, ub = model.stage_utilities(float(model.reward(state)), stage)
        assert ua[i, k] == pytest.approx(ua_expected) and ub[i, k] == pytest.approx(ub_expected)
        assert ua[0, 0] == 0.0 and ub[0, 0] == 0.0
        # r of the outcomes: relay done (d=0 -> 2), leader only (1), follower only / none (0).
        np.testing.assert_allclose(model.outcome_rewards(state, stage)[i, k], [2.0, 1.0, 0.0, 0.0])
