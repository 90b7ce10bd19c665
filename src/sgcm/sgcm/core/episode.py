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

Each round is one :class:`~.leader_round.LeaderRound` (observe, goal / stuck / round limit,
plan), the same the leader_planner node runs, so an episode ends here as it ends in simulation.
An episode is *stuck* by :mod:`.stuck_rule`: the state comes back after rounds in which nothing
was left to chance (without failures: the greedy pair's chattering, the paper's stuck case;
with or without: a round in which neither arm moved).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from .follower_behaviour import Follower, FollowerChoice, FollowerSettings, greedy_action
from .fse import FSEPlanner
from .fse_compiled import CompiledFSEPlanner
from .leader_round import Ending, LeaderRound, LeaderTurn, TaskEnd
from .rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel
from .stuck_rule import MoveOutcome


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


class MoveExecutor:
    """Applies moves in the abstract game with sampled failures and charges costs."""

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


FollowerTurn = Callable[[int, np.ndarray, np.ndarray, LeaderTurn], FollowerChoice]


def _play(leader: LeaderRound, method: str, initial: np.ndarray, follower_turn: FollowerTurn,
          executor: MoveExecutor, progress=None) -> EpisodeResult:
    """The round loop shared by SGCM and the baseline: the leader's round (observe, end or plan),
    her move, the follower's, repeated until the leader ends the task."""
    model = leader.model
    state = model.state_of(initial)
    result = EpisodeResult(method, completed=False, stuck=False, rounds=0)
    while True:
        turn = leader.observe(state)
        if isinstance(turn, TaskEnd):
            break
        after_leader, leader_ok, leader_cost = executor.attempt(state, LEADER, turn.action)
        choice = follower_turn(turn.round, after_leader, state, turn)
        after, follower_ok, follower_cost = executor.attempt(after_leader, FOLLOWER, choice.action)
        leader.round_over(leader_ok, MoveOutcome(choice.action != EMPTY, follower_ok), choice.by_chance)
        reward = float(model.reward(after))
        result.records.append(RoundRecord(
            round=turn.round, state=state.tolist(), reward=reward,
            leader_action=model.describe(LEADER, turn.action), leader_succeeded=leader_ok,
            recommended_action='' if turn.recommended is None else model.describe(FOLLOWER, turn.recommended),
            follower_action=model.describe(FOLLOWER, choice.action), follower_succeeded=follower_ok,
            follower_deviated=choice.deviated, leader_cost=leader_cost, follower_cost=follower_cost,
            stage_utility=reward - leader_cost - follower_cost,
            predicted_leader_value=turn.leader_value, predicted_follower_value=turn.follower_value,
            planning_seconds=turn.planning_seconds, next_state=after.tolist()))
        result.rounds = turn.round
        state = after
        if progress:
            progress(turn.round, result.records[-1])
    result.completed = turn.complete
    result.stuck = turn.ending is Ending.STUCK
    result.final_state = state.tolist()
    return result


def run_sgcm(model: RearrangementModel, initial: np.ndarray, follower: FollowerSettings | None = None,
             planner: CompiledFSEPlanner | FSEPlanner | None = None, simulate_failures: bool = False,
             seed: int = 0, round_limit: int | None = None, progress=None) -> EpisodeResult:
    """Algorithm 1: plan the FSE at the observed state, leader moves, follower responds, repeat."""
    rng = np.random.default_rng(seed)  # one stream: mixed commitments and move failures, in round order
    leader = LeaderRound(model, 'sgcm', planner, rng, round_limit,   # None: the kernel path
                         moves_can_fail=simulate_failures)
    follower_model = Follower(model, follower or FollowerSettings(), seed=seed + 1)

    def follower_turn(number, seen, round_state, turn):
        return follower_model.choose(number, seen, round_state, turn.action, turn.recommended)

    return _play(leader, 'sgcm', initial, follower_turn, MoveExecutor(model, simulate_failures, rng), progress)


def run_greedy(model: RearrangementModel, initial: np.ndarray, simulate_failures: bool = False,
               seed: int = 0, round_limit: int | None = None) -> EpisodeResult:
    """Section V-A baseline: each robot in turn maximises its own one-stage utility."""
    rng = np.random.default_rng(seed)
    leader = LeaderRound(model, 'greedy', rng=rng, round_limit=round_limit, moves_can_fail=simulate_failures)
    return _play(leader, 'greedy', initial,
                 lambda number, seen, round_state, turn: FollowerChoice(
                     greedy_action(model, seen, FOLLOWER), False, 'greedy'),
                 MoveExecutor(model, simulate_failures, rng))
