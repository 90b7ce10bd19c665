"""One round of the SGCM leader: observe the state -> goal / stuck / round limit -> plan -> her move
and the recommended follower move (Algorithm 1, lines 2-20, once; Section IV-A).

The same :class:`LeaderRound` drives the abstract episode loop (:mod:`.episode`) and the
leader_planner node (through :mod:`.leader_rounds`), so both end a task by the same rules, in
this order, each time the leader observes the state at the start of a round:

1. the goal state: the task is complete;
2. stuck (:mod:`.stuck_rule`, the one rule for both);
3. the round limit reached: the task ends incomplete;
4. otherwise she plans: the FSE over the rolling horizon T at the observed state (``sgcm``;
   a mixed commitment is sampled with her seeded generator) or, for the Section V-A baseline
   (``greedy``), her own one-stage greedy move and no guidance.

Her planner is the compiled kernel by default (:mod:`.fse_compiled`); the reference
(:class:`.fse.FSEPlanner`: numpy and a stage-game solver per state) gives the same values and
actions and stays selectable (:func:`.fse_compiled.make_planner`, the node's ``planner`` setting).

After the follower's part she reports the round's outcome (:meth:`LeaderRound.round_over`).
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from .follower_behaviour import greedy_action
from .fse import FSEPlanner, FSEResult
from .fse_compiled import CompiledFSEPlanner, make_planner
from .rearrangement import EMPTY, LEADER, RearrangementModel
from .stuck_rule import MoveOutcome, RoundCertainty, StuckRule

#: sgcm: Algorithm 1 (guidance); greedy: the Section V-A baseline (no guidance).
STRATEGIES = ('sgcm', 'greedy')


class Ending(Enum):
    GOAL = 'goal reached'
    STUCK = 'stuck'
    ROUND_LIMIT = 'round limit reached'
    PERCEPTION_FAULT = 'perception fault'    # the camera gave no evidence of the table (.perception_check)


@dataclass(frozen=True)
class TaskEnd:
    """The task is over: why, after how many rounds, at which observed state."""

    ending: Ending
    rounds: int
    state: np.ndarray
    reason: str           # the status text: 'goal reached', 'stuck: ...', 'round limit 20 reached'

    @property
    def complete(self) -> bool:
        return self.ending is Ending.GOAL


@dataclass(frozen=True)
class LeaderTurn:
    """The leader's decision for one round."""

    round: int
    state: np.ndarray                # observed at the round's start
    action: int                      # her move (leader action-table index; EMPTY = stand still)
    recommended: int | None          # pi_0^{B*} for the follower; None: no guidance (greedy)
    plan: FSEResult | None = None    # None for the greedy baseline
    sampled: bool = False            # drawn from a mixed commitment

    @property
    def leader_value(self) -> float | None:
        return None if self.plan is None else self.plan.leader_value

    @property
    def follower_value(self) -> float | None:
        return None if self.plan is None else self.plan.follower_value

    @property
    def planning_seconds(self) -> float:
        return 0.0 if self.plan is None else self.plan.seconds


class LeaderRound:
    """The leader's side of the rounds of one task; see the module docstring.

    planner: the FSE planner (``sgcm``; replaceable between rounds, e.g. a new horizon; default: the
    kernel path at the task's horizon);
    rng: samples mixed commitments; round_limit: None = the task file's game.round_limit;
    moves_can_fail: whether moves may fail by chance (see :mod:`.stuck_rule`).
    """

    def __init__(self, model: RearrangementModel, strategy: str = 'sgcm',
                 planner: CompiledFSEPlanner | FSEPlanner | None = None,
                 rng: np.random.Generator | None = None, round_limit: int | None = None,
                 moves_can_fail: bool = False):
        if strategy not in STRATEGIES:
            raise ValueError(f"strategy: must be one of {', '.join(STRATEGIES)} (got '{strategy}')")
        self.model = model
        self.strategy = strategy
        self.planner = planner or (make_planner(model) if strategy == 'sgcm' else None)
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.round_limit = round_limit
        self.stuck_rule = StuckRule(moves_can_fail)
        self.rounds = 0                       # rounds started
        self.turn: LeaderTurn | None = None   # the round in progress

    @property
    def limit(self) -> int:
        return self.model.task.round_limit if self.round_limit is None else self.round_limit

    def observe(self, state: np.ndarray) -> LeaderTurn | TaskEnd:
        """The state at the start of the next round: the task's end, or the leader's turn."""
        model = self.model
        state = np.asarray(state)
        if np.array_equal(state, model.goal_state(state)):
            return TaskEnd(Ending.GOAL, self.rounds, state, Ending.GOAL.value)
        stuck = self.stuck_rule.observe(state, self.rounds + 1)
        if stuck is not None:
            return TaskEnd(Ending.STUCK, self.rounds, state, stuck)
        if self.rounds >= self.limit:
            return TaskEnd(Ending.ROUND_LIMIT, self.rounds, state, f'round limit {self.limit} reached')
        self.rounds += 1
        if self.strategy == 'greedy':
            self.turn = LeaderTurn(self.rounds, state, greedy_action(model, state, LEADER), None)
            return self.turn
        plan = self.planner.plan(state)
        action, sampled = plan.leader_action, len(plan.leader_actions) > 1
        if sampled:  # a mixed commitment: the leader samples it
            action = int(self.rng.choice(plan.leader_actions, p=plan.leader_policy))
        self.turn = LeaderTurn(self.rounds, state, action, plan.follower_action, plan, sampled)
        return self.turn

    def round_over(self, leader_succeeded: bool, follower: MoveOutcome | None,
                   follower_by_chance: bool = False) -> None:
        """The round in progress ended: her move's outcome and the follower's (None: unknown)."""
        turn = self.turn
        leader = MoveOutcome(attempted=turn.action != EMPTY, took_effect=leader_succeeded)
        self.stuck_rule.round_ended(turn.round, RoundCertainty(leader, follower, turn.sampled, follower_by_chance))
        self.turn = None
