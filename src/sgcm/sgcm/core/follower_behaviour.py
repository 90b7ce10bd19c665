"""How the follower picks his move after hearing the leader's guidance (Section V-B).

The follower only hears the leader (one-way communication) and senses the current
state; he never plans ahead. Behaviours:

- ``obedient``: executes the recommended action pi_0^{B*}.
- ``myopic``: best response to the leader's announced action in the one-stage game,
  maximising r(state after both moves) - own cost, ignoring the recommendation.
- ``zero_trust``: ignores the guidance entirely and moves greedily on the state he sees
  after the leader's move (the greedy baseline's follower).
- ``random``: obedient, except in disturbed rounds (each round with probability
  ``deviation_probability``, and every round listed in ``deviation_rounds``) where he
  takes a uniformly random feasible move.
- ``adversarial``: picks the move that lowers the team's one-stage utility the most.

Ties in the greedy rules prefer the empty action (no pointless motion), then the lowest
action index, so runs are reproducible.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .rearrangement import EMPTY, FOLLOWER, RearrangementModel

BEHAVIOURS = ('obedient', 'myopic', 'zero_trust', 'random', 'adversarial')


@dataclass(frozen=True)
class FollowerSettings:
    behaviour: str = 'obedient'
    deviation_probability: float = 0.0
    deviation_rounds: tuple[int, ...] = field(default_factory=tuple)

    def __post_init__(self):
        if self.behaviour not in BEHAVIOURS:
            raise ValueError(f"behaviour: must be one of {', '.join(BEHAVIOURS)} (got '{self.behaviour}')")
        if not 0.0 <= self.deviation_probability <= 1.0:
            raise ValueError(f'deviation_probability: must be in [0, 1] (got {self.deviation_probability})')
        if any(int(r) < 1 for r in self.deviation_rounds):
            raise ValueError(f'deviation_rounds: rounds are numbered from 1 (got {list(self.deviation_rounds)})')


@dataclass(frozen=True)
class FollowerChoice:
    action: int
    deviated: bool          # did not follow the recommendation
    reason: str
    by_chance: bool = False  # a random draw decided it (the random behaviour, every round)


def greedy_action(model: RearrangementModel, state: np.ndarray, robot: int, sign: float = 1.0) -> int:
    """argmax over feasible moves of sign * r(state after the move) - own cost (one stage)."""
    actions = model.feasible(state, robot)
    table = model.actions[robot]
    values = sign * table.reward_delta[actions] - model.cost(state, robot, actions)
    goal_bonus = model.task.reward.goal_bonus
    if goal_bonus:
        misplaced = model.misplaced(state) + table.misplaced_delta[actions]
        values = values + sign * goal_bonus * (misplaced == 0)
    # values[0] is the empty action: a move must be strictly better to be chosen.
    best = int(np.argmax(values))
    if values[best] <= values[0] + 1e-12:
        return EMPTY
    return int(actions[best])


def best_response(model: RearrangementModel, state: np.ndarray, leader_action: int) -> int:
    """The follower's one-stage best response to the leader's announced move.

    Maximises his one-stage utility in the game's own terms: the expected reward of the
    next state over the four failure outcomes minus his expected cost, taking the
    leader's announced move as given; no look-ahead and no recommendation.
    """
    stage = model.stage(state)
    rows = np.flatnonzero(stage.leader_actions == leader_action)
    if len(rows) == 0:
        raise ValueError(f'leader action {model.describe(0, leader_action)} is not feasible in this state')
    row = rows[0]
    _, follower_cost = model.expected_costs(stage)
    values = model.outcome_rewards(state, stage)[row] @ stage.outcome_probability - follower_cost[row]
    best = int(np.argmax(values))
    return EMPTY if values[best] <= values[0] + 1e-12 else int(stage.follower_actions[best])


class Follower:
    """Chooses the follower's move each round according to his settings."""

    def __init__(self, model: RearrangementModel, settings: FollowerSettings, seed: int | None = None):
        self.model = model
        self.settings = settings
        self.rng = np.random.default_rng(seed)

    def choose(self, round_number: int, state_seen: np.ndarray, round_state: np.ndarray,
               leader_action: int, recommended: int) -> FollowerChoice:
        """``state_seen``: after the leader's move; ``round_state``: at the round's start."""
        s = self.settings
        model = self.model
        if s.behaviour == 'obedient':
            return FollowerChoice(recommended, False, 'follows the recommendation')
        if s.behaviour == 'myopic':
            action = best_response(model, round_state, leader_action)
            return FollowerChoice(action, action != recommended, 'one-stage best response to the leader')
        if s.behaviour == 'zero_trust':
            action = greedy_action(model, state_seen, FOLLOWER)
            return FollowerChoice(action, action != recommended, 'greedy, ignoring the guidance')
        if s.behaviour == 'adversarial':
            action = greedy_action(model, state_seen, FOLLOWER, sign=-1.0)
            return FollowerChoice(action, action != recommended, 'adversarial')
        # random: disturbed rounds pick a random feasible move
        draw = self.rng.random()  # drawn every round so the sequence does not depend on the plan
        if round_number in s.deviation_rounds or draw < s.deviation_probability:
            feasible = model.feasible(state_seen, FOLLOWER)
            moves = feasible[feasible != EMPTY]
            pool = moves if len(moves) else feasible
            action = int(self.rng.choice(pool))
            return FollowerChoice(action, action != recommended, 'disturbance: random move', by_chance=True)
        return FollowerChoice(recommended, False, 'follows the recommendation', by_chance=True)
