"""Whole episodes on the shipped task and cases: SGCM, the greedy baseline, the centralised bound."""
import math

import numpy as np
import pytest

from sgcm.core.centralized import CentralizedPlanner
from sgcm.core.episode import run_greedy, run_sgcm
from sgcm.core.follower_behaviour import FollowerSettings
from sgcm.core.fse import FSEPlanner
from sgcm.core.rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel
from sgcm.core.task_config import parse_case, parse_task

from sgcm_tasks import small_task_data


class MemoPlanner(FSEPlanner):
    """The FSE planner with its plans remembered per state (plan() is deterministic).

    The episodes of this module revisit many states (every run starts at a case's initial
    state); remembering the plans only saves time.
    """

    def __init__(self, model):
        super().__init__(model)
        self.plans = {}

    def plan(self, state):
        key = np.asarray(state, dtype=np.int64).tobytes()
        if key not in self.plans:
            self.plans[key] = super().plan(state)
        return self.plans[key]


@pytest.fixture(scope='module')
def planner(model):
    return MemoPlanner(model)


@pytest.fixture(scope='module')
def sgcm_runs(model, cases, planner):
    return {case.name: run_sgcm(model, case, planner=planner) for case in cases}


@pytest.fixture(scope='module')
def greedy_runs(model, cases):
    return {case.name: run_greedy(model, case) for case in cases}


def final_reward(model, result):
    return float(model.reward(np.array(result.final_state)))


def rounds_to_finish(result):
    return result.rounds if result.completed else math.inf


def action_index(model, robot):
    return {model.describe(robot, a): a for a in range(model.actions[robot].size)}


# --- no failures, obedient follower -------------------------------------------------------

def test_sgcm_completes_every_case(sgcm_runs, task):
    assert len(sgcm_runs) == 10
    for name, result in sgcm_runs.items():
        assert result.completed and not result.stuck, name
        assert result.rounds <= task.round_limit
        assert not any(r.follower_deviated for r in result.records)


def test_greedy_gets_stuck(greedy_runs):
    stuck = [name for name, result in greedy_runs.items() if result.stuck]
    assert stuck, 'the greedy pair finished every case'
    for name in stuck:
        assert not greedy_runs[name].completed
        records = greedy_runs[name].records
        # Stuck means the last round led back to a state seen before (chattering).
        seen = [records[0].state] + [r.next_state for r in records[:-1]]
        assert records[-1].next_state in seen


def test_sgcm_never_needs_more_rounds_than_greedy(sgcm_runs, greedy_runs):
    for name, sgcm in sgcm_runs.items():
        assert rounds_to_finish(sgcm) <= rounds_to_finish(greedy_runs[name]), name


def test_sgcm_utility_is_at_least_greedy(model, sgcm_runs, greedy_runs):
    # Table I: both summed over SGCM's rounds (greedy padded with idle rounds if it ended sooner).
    better = 0
    for name, sgcm in sgcm_runs.items():
        greedy = greedy_runs[name]
        ours = sgcm.utility_over(sgcm.rounds, final_reward(model, sgcm))
        theirs = greedy.utility_over(sgcm.rounds, final_reward(model, greedy))
        assert ours >= theirs - 1e-9, name
        better += ours > theirs + 1e-9
    assert better >= 1


def test_round_records_are_consistent(model, sgcm_runs, greedy_runs):
    leader_index, follower_index = action_index(model, LEADER), action_index(model, FOLLOWER)
    for result in list(sgcm_runs.values()) + list(greedy_runs.values()):
        state = None
        for record in result.records:
            if state is not None:
                assert record.state == state.tolist()
            state = np.array(record.state)
            a, b = leader_index[record.leader_action], follower_index[record.follower_action]
            after_leader = model.apply(state, LEADER, a)
            assert record.leader_succeeded
            assert record.leader_cost == float(model.cost(state, LEADER, a))
            expected_follower_cost = (float(model.cost(after_leader, FOLLOWER, b))
                                      if b != EMPTY and model.can_apply(after_leader, FOLLOWER, b) else 0.0)
            assert record.follower_cost == expected_follower_cost
            state = model.step(state, a, b)
            assert record.next_state == state.tolist()
            assert record.reward == float(model.reward(state))
            assert record.stage_utility == pytest.approx(record.reward - record.leader_cost - record.follower_cost)
        assert result.final_state == state.tolist()
        if result.completed:
            np.testing.assert_array_equal(state, model.goal_state(state))


def test_utility_over_pads_with_the_final_reward(sgcm_runs, model):
    result = sgcm_runs['case_8']
    total = sum(result.stage_utilities)
    final = final_reward(model, result)
    assert result.utility_over(result.rounds, final) == pytest.approx(total)
    assert result.utility_over(result.rounds + 3, final) == pytest.approx(total + 3 * final)
    assert result.utility_over(1, final) == pytest.approx(result.stage_utilities[0])


# --- the centralised planner ------------------------------------------------------------------

def test_centralized_rounds_bound_sgcm(model, cases, sgcm_runs):
    planner = CentralizedPlanner(model)
    leader_index, follower_index = action_index(model, LEADER), action_index(model, FOLLOWER)
    for case in cases:
        plan = planner.plan(case)
        assert plan.rounds is not None, case.name
        assert plan.rounds <= sgcm_runs[case.name].rounds, case.name
        # The joint plan is executable and reaches the goal in exactly that many rounds.
        state = model.state_of(case)
        assert len(plan.moves) == plan.rounds
        for leader_move, follower_move in plan.moves:
            a = leader_index[leader_move]
            assert a in model.feasible(state, LEADER)
            state = model.step(state, a, follower_index[follower_move])
        np.testing.assert_array_equal(state, model.goal_state(state))


def breadth_first_rounds(model, start):
    """Fewest rounds to the goal by breadth-first search over model.step (no failures)."""
    goal = model.goal_state(start).tobytes()
    frontier, seen, depth = [start], {start.tobytes()}, 0
    while frontier:
        if any(s.tobytes() == goal for s in frontier):
            return depth
        successors = []
        for state in frontier:
            for a in model.feasible(state, LEADER):
                for b in range(model.actions[FOLLOWER].size):
                    nxt = model.step(state, a, b)
                    if nxt.tobytes() not in seen:
                        seen.add(nxt.tobytes())
                        successors.append(nxt)
        frontier, depth = successors, depth + 1
    return None


def test_centralized_planner_is_optimal_on_small_tasks():
    rng = np.random.default_rng(12)
    checked = 0
    while checked < 12:
        rows, cols = int(rng.integers(1, 4)), int(rng.integers(2, 5))
        names = ['red', 'green'][:int(rng.integers(1, 3))]
        goals = {name: [int(rng.integers(rows)), int(rng.integers(cols))] for name in names}
        task = parse_task(small_task_data(rows, cols, goals))
        objects = {}
        for _ in range(int(rng.integers(1, 4))):
            objects.setdefault(names[int(rng.integers(len(names)))], []).append(
                [int(rng.integers(rows)), int(rng.integers(cols))])
        model = RearrangementModel(task)
        start = model.state_of(parse_case({'name': 'random', 'objects': objects}, task))
        planner = CentralizedPlanner(model)
        expected = breadth_first_rounds(model, start)
        assert planner.plan(start).rounds == expected, (rows, cols, goals, objects)
        assert planner.heuristic(start)[0] <= expected
        checked += 1


def test_centralized_heuristic_is_admissible_for_relays(small_task, state_of):
    # One object two cells from its goal: she moves it one cell and he carries it on (relay),
    # so one round suffices and the heuristic must not claim two.
    model = RearrangementModel(small_task(3, 1, {'red': [2, 0]}))
    state = state_of(model, {'red': [[0, 0]]})
    assert breadth_first_rounds(model, state) == 1
    assert CentralizedPlanner(model).heuristic(state)[0] <= 1
    assert CentralizedPlanner(model).plan(state).rounds == 1


# --- failures, disturbances, trust ----------------------------------------------------------

def test_sgcm_completes_with_failures_and_a_random_follower(model, cases, planner):
    failures = deviations = 0
    for index, case in enumerate(cases):
        result = run_sgcm(model, case, follower=FollowerSettings('random', 0.2), planner=planner,
                          simulate_failures=True, seed=100 + index, round_limit=40)
        assert result.completed, case.name
        failures += sum((not r.leader_succeeded) + (not r.follower_succeeded) for r in result.records)
        deviations += sum(r.follower_deviated for r in result.records)
    assert failures > 0 and deviations > 0   # the disturbances really happened


def test_sgcm_completes_with_a_zero_trust_follower(model, cases, planner):
    deviations = 0
    for index, case in enumerate(cases):
        result = run_sgcm(model, case, follower=FollowerSettings('zero_trust'), planner=planner,
                          simulate_failures=True, seed=200 + index, round_limit=40)
        assert result.completed, case.name
        deviations += sum(r.follower_deviated for r in result.records)
    assert deviations > 0


def test_adversarial_follower_runs_and_the_leader_replans(model, cases, planner):
    for index in (0, 4):
        result = run_sgcm(model, cases[index], follower=FollowerSettings('adversarial'), planner=planner,
                          simulate_failures=True, seed=300 + index, round_limit=8)
        assert result.rounds == 8 or result.completed
        assert any(r.follower_deviated for r in result.records)
        # Every round the leader planned from the state she observed (never from her prediction).
        fresh = FSEPlanner(model)
        for record in result.records[:4]:
            plan = fresh.plan(np.array(record.state))
            assert record.predicted_leader_value == pytest.approx(plan.leader_value)
            assert record.recommended_action == model.describe(FOLLOWER, plan.follower_action)
    # Without failures the deterministic pair returns to an earlier state and is declared stuck.
    result = run_sgcm(model, cases[0], follower=FollowerSettings('adversarial'), planner=planner)
    assert result.stuck and not result.completed
