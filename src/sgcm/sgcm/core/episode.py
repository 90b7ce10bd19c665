"""Whole rearrangement episodes in the abstract game: SGCM (Algorithm 1) and the greedy baseline.

Both run round by round: the leader moves first, then the follower, each move failing
with its p_fail when ``simulate_failures`` is on (seeded). The leader re-observes the
state at every round and never assumes the follower obeyed.

Accounting for Table I (Section V-A): the stage-wise utility of a round is "the current
state reward minus the total cost of two robots after each round of manipulation",
i.e. r(state after the round) minus both robots' costs in that round (costs of the
moves actually attempted, on the state each robot acted on). An episode's utility is
the sum over SGCM's number of rounds; a greedy episode is summed over the same number
of rounds (:func:`utility_over`), padded with idle rounds at its final state if greedy
ended sooner, and regardless of whether it completed.

A greedy episode is *stuck* when, without failures, a round leaves the state unchanged
or returns to an earlier state: the deterministic greedy rules then repeat forever
(the paper's chattering). SGCM episodes use the same detection when failures are off.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from .follower_behaviour import Follower, FollowerChoice, FollowerSettings, greedy_action
from .fse import FSEPlanner
from .rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel


@dataclass
class RoundRecord:
    round: int
    state: list[int]              # at the round's start
    reward: float                 # r(state after the round)
    leader_action: str
    leader_succeeded: bool
    recommended_action: str       # '' for the greedy baseline
    follower_action: str
    follower_succeeded: bool
    follower_deviated: bool
    leader_cost: float
    follower_cost: float
    stage_utility: float          # reward - leader_cost - follower_cost
    next_state: list[int] = field(default_factory=list)   # after the round
    predicted_leader_value: float | None = None
    predicted_follower_value: float | None = None
    planning_seconds: float = 0.0


@dataclass
class EpisodeResult:
    method: str
    completed: bool
    stuck: bool
    rounds: int
    records: list[RoundRecord] = field(default_factory=list)
    final_state: list[int] = field(default_factory=list)

    @property
    def stage_utilities(self) -> list[float]:
        return [r.stage_utility for r in self.records]

    def stage_utilities_over(self, rounds: int, final_reward: float) -> list[float]:
        """The first ``rounds`` stage utilities.

        An episode that ended sooner (at the goal, or stuck with both robots idle) is
        padded with idle rounds at its final state, worth ``final_reward`` = r(final state).
        """
        values = self.stage_utilities[:rounds]
        return values + [final_reward] * (rounds - len(values))

    def utility_over(self, rounds: int, final_reward: float) -> float:
        """Sum of :meth:`stage_utilities_over` (Table I's accounting)."""
        return float(sum(self.stage_utilities_over(rounds, final_reward)))

    def to_dict(self) -> dict:
        return {'method': self.method, 'completed': self.completed, 'stuck': self.stuck,
                'rounds': self.rounds, 'final_state': self.final_state,
                'records': [asdict(r) for r in self.records]}


class _Executor:
    """Applies moves with sampled failures and charges costs."""

    def __init__(self, model: RearrangementModel, simulate_failures: bool, rng: np.random.Generator):
        self.model = model
        self.simulate_failures = simulate_failures
        self.rng = rng

    def attempt(self, state: np.ndarray, robot: int, action: int) -> tuple[np.ndarray, bool, float]:
        """(new state, succeeded, cost) of one robot's move on ``state``."""
        model = self.model
        p_fail = (model.task.leader if robot == LEADER else model.task.follower).failure_probability
        draw = self.rng.random()  # drawn even for empty moves: keeps random streams aligned
        if action == EMPTY:
            return state, True, 0.0
        cost = float(model.cost(state, robot, action))
        if not model.can_apply(state, robot, action):
            return state, False, 0.0  # nothing to grasp or no room: no motion, no cost
        succeeded = not (self.simulate_failures and draw < p_fail)
        if not succeeded and not model.task.charge_failed_actions:
            cost = 0.0
        return (model.apply(state, robot, action) if succeeded else state), succeeded, cost


def _stuck(history: list[bytes], state: np.ndarray, simulate_failures: bool) -> bool:
    return not simulate_failures and state.tobytes() in history


@dataclass(frozen=True)
class _LeaderTurn:
    action: int
    recommended: int | None = None       # None: no guidance (greedy baseline)
    leader_value: float | None = None
    follower_value: float | None = None
    planning_seconds: float = 0.0


def _play(model: RearrangementModel, method: str, initial: np.ndarray, leader_turn, follower_turn,
          simulate_failures: bool, seed: int, round_limit: int | None, progress=None) -> EpisodeResult:
    """The round loop shared by SGCM and the baseline: leader, then follower, then observe."""
    rng = np.random.default_rng(seed)
    executor = _Executor(model, simulate_failures, rng)
    state = model.state_of(initial)
    goal = model.goal_state(state)
    limit = model.task.round_limit if round_limit is None else round_limit
    result = EpisodeResult(method, completed=np.array_equal(state, goal), stuck=False, rounds=0)
    history = [state.tobytes()]
    while not result.completed and result.rounds < limit:
        number = result.rounds + 1
        turn = leader_turn(number, state, rng)
        after_leader, leader_ok, leader_cost = executor.attempt(state, LEADER, turn.action)
        choice = follower_turn(number, after_leader, state, turn)
        after, follower_ok, follower_cost = executor.attempt(after_leader, FOLLOWER, choice.action)
        reward = float(model.reward(after))
        result.records.append(RoundRecord(
            round=number, state=state.tolist(), reward=reward,
            leader_action=model.describe(LEADER, turn.action), leader_succeeded=leader_ok,
            recommended_action='' if turn.recommended is None else model.describe(FOLLOWER, turn.recommended),
            follower_action=model.describe(FOLLOWER, choice.action), follower_succeeded=follower_ok,
            follower_deviated=choice.deviated, leader_cost=leader_cost, follower_cost=follower_cost,
            stage_utility=reward - leader_cost - follower_cost,
            predicted_leader_value=turn.leader_value, predicted_follower_value=turn.follower_value,
            planning_seconds=turn.planning_seconds, next_state=after.tolist()))
        result.rounds = number
        state = after
        result.completed = bool(np.array_equal(state, goal))
        if progress:
            progress(number, result.records[-1])
        if not result.completed and _stuck(history, state, simulate_failures):
            result.stuck = True
            break
        history.append(state.tobytes())
    result.final_state = state.tolist()
    return result


def run_sgcm(model: RearrangementModel, initial: np.ndarray, follower: FollowerSettings | None = None,
             planner: FSEPlanner | None = None, simulate_failures: bool = False, seed: int = 0,
             round_limit: int | None = None, progress=None) -> EpisodeResult:
    """Algorithm 1: plan the FSE at the observed state, leader moves, follower responds, repeat."""
    planner = planner or FSEPlanner(model)
    follower_model = Follower(model, follower or FollowerSettings(), seed=seed + 1)

    def leader_turn(number, state, rng):
        plan = planner.plan(state)
        action = plan.leader_action
        if len(plan.leader_actions) > 1:  # a mixed commitment: the leader samples it
            action = int(rng.choice(plan.leader_actions, p=plan.leader_policy))
        return _LeaderTurn(action, plan.follower_action, plan.leader_value, plan.follower_value, plan.seconds)

    def follower_turn(number, seen, round_state, turn):
        return follower_model.choose(number, seen, round_state, turn.action, turn.recommended)

    return _play(model, 'sgcm', initial, leader_turn, follower_turn, simulate_failures, seed, round_limit,
                 progress)


def run_greedy(model: RearrangementModel, initial: np.ndarray, simulate_failures: bool = False,
               seed: int = 0, round_limit: int | None = None) -> EpisodeResult:
    """Section V-A baseline: each robot in turn maximises its own one-stage utility."""
    return _play(model, 'greedy', initial,
                 lambda number, state, rng: _LeaderTurn(greedy_action(model, state, LEADER)),
                 lambda number, seen, round_state, turn: FollowerChoice(
                     greedy_action(model, seen, FOLLOWER), False, 'greedy'),
                 simulate_failures, seed, round_limit)
