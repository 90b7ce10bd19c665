"""Feedback Stackelberg equilibrium over a horizon T (Section IV-A, Algorithm 1 lines 3-18).

Forward prediction builds the reachable sets S_0 = {s_0}, S_1, ..., S_T (every outcome
of every feasible action pair, duplicates merged); backward dynamic programming then
solves, for t = T-1 .. 0 and every s in S_t, the stage game with

    U^i_t[a, b] = u^i(s, a, b) + gamma * sum_{s'} p(s' | s, a, b) v^i_{t+1}(s')    (Q_t^A, Q_t^B)

and sets v^i_t(s) to the equilibrium values; v^i_T(s) = u^i_T(s) = r(s). The discount
gamma multiplies the next stage's value because J^i weighs stage t by gamma^t.

The last stage never materialises S_T: the reward is linear in the state (plus a goal
bonus on the misplaced-object count, also linear), so r of every outcome follows from
r(s) and per-action deltas. Earlier stages look successors up by their linear state
keys (see rearrangement.py).

This is the reference path (numpy per state, a stage-game solver per state). The leader plans on
the compiled kernel by default (:mod:`.fse_compiled`, same values and actions); this planner stays
selectable (``make_planner(..., path='reference')``, the leader's ``planner`` setting) and is
what the kernel is checked against (``scripts/bench sgcm``, test_sgcm_kernel*.py).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel, StageMatrices
from .stage_game import SOLVERS, StageSolution


@dataclass
class FSEResult:
    """The first-stage equilibrium at s_0 and what it took to compute it."""

    leader_policy: np.ndarray          # over leader action-table indices with nonzero weight
    leader_actions: np.ndarray         # action-table indices matching leader_policy
    leader_action: int                 # the action the leader executes (most probable)
    follower_action: int               # recommended follower action (pi_0^{B*}, pure)
    leader_value: float                # v_0^A(s_0)
    follower_value: float              # v_0^B(s_0)
    states_per_stage: list[int] = field(default_factory=list)   # |S_0| .. |S_T-1| (|S_T| if counted)
    stage_games: int = 0
    programs_solved: int = 0
    seconds: float = 0.0
    stage_game_samples: list = field(default_factory=list, repr=False)


def planner_horizon(model: RearrangementModel, horizon: int | None, solver: str) -> int:
    """A planner's horizon (the task's when None), after checking it and the solver's name."""
    if solver not in SOLVERS:
        raise ValueError(f"solver: must be one of {', '.join(SOLVERS)} (got '{solver}')")
    horizon = model.task.horizon if horizon is None else int(horizon)
    if horizon < 1:
        raise ValueError(f'horizon: must be >= 1 (got {horizon})')
    return horizon


class FSEPlanner:
    """Computes pi_0^{A*}, pi_0^{B*} from an observed state (one rolling-horizon step)."""

    def __init__(self, model: RearrangementModel, horizon: int | None = None, solver: str = 'fast',
                 keep_stage_games: int = 0, count_terminal_states: bool = False):
        self.model = model
        self.horizon = planner_horizon(model, horizon, solver)
        self.solve_stage = SOLVERS[solver]
        self.solver = solver
        # Benchmarks re-solve a sample of the very same stage games with the other method.
        self.keep_stage_games = keep_stage_games
        self.count_terminal_states = count_terminal_states

    # --- forward prediction -----------------------------------------------------------
    def _expand(self, states: np.ndarray, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """S_{t+1} (states, sorted keys) from S_t."""
        model = self.model
        parts_key, parts_parent, parts_a, parts_b, parts_o = [], [], [], [], []
        for index in range(len(states)):
            stage = model.stage(states[index], keys[index])
            flat = stage.outcome_keys.reshape(-1)
            unique, first = np.unique(flat, return_index=True)
            a_row, rest = np.divmod(first, stage.outcome_keys.shape[1] * 4)
            b_col, outcome = np.divmod(rest, 4)
            parts_key.append(unique)
            parts_parent.append(np.full(len(unique), index))
            parts_a.append(stage.leader_actions[a_row])
            # A blocked follower move changes nothing: record it as the empty action.
            blocked = np.where(outcome == 0, stage.blocked[a_row, b_col], stage.blocked_alone[b_col])
            parts_b.append(np.where(blocked, EMPTY, stage.follower_actions[b_col]))
            parts_o.append(outcome)
        all_keys = np.concatenate(parts_key)
        unique, first = np.unique(all_keys, return_index=True)
        parent = np.concatenate(parts_parent)[first]
        a = np.concatenate(parts_a)[first]
        b = np.concatenate(parts_b)[first]
        outcome = np.concatenate(parts_o)[first]
        use_a = (outcome == 0) | (outcome == 1)
        use_b = (outcome == 0) | (outcome == 2)
        new_states = (states[parent]
                      + np.where(use_a[:, None], model.move_vectors(LEADER)[a], 0)
                      + np.where(use_b[:, None], model.move_vectors(FOLLOWER)[b], 0))
        self._check_keys(new_states, unique)
        return new_states, unique

    def _check_keys(self, states: np.ndarray, keys: np.ndarray) -> None:
        # Keys are a hash: make sure distinct keys came from consistent states.
        if not np.array_equal(self.model.keys(states), keys):
            raise RuntimeError('state key mismatch in forward prediction (internal error)')
        if (states < 0).any():
            raise RuntimeError('negative object count in forward prediction (internal error)')

    # --- backward dynamic programming ------------------------------------------------------
    def _solve_state(self, state, key, next_keys, next_values) -> tuple[StageSolution, StageMatrices,
                                                                          np.ndarray, np.ndarray]:
        model = self.model
        stage = model.stage(state, key)
        reward = float(model.reward(state))
        ua, ub = model.stage_utilities(reward, stage)
        p = stage.outcome_probability
        if next_keys is None:
            terminal = model.outcome_rewards(state, stage)
            expected_a = expected_b = terminal @ p
        else:
            position = np.searchsorted(next_keys, stage.outcome_keys)
            values_a, values_b = next_values
            expected_a = values_a[position] @ p
            expected_b = values_b[position] @ p
        gamma = model.task.discount
        big_ua = ua + gamma * expected_a
        big_ub = ub + gamma * expected_b
        return self.solve_stage(big_ua, big_ub), stage, big_ua, big_ub

    def plan(self, state: np.ndarray) -> FSEResult:
        start = time.perf_counter()
        model = self.model
        state = np.asarray(state, dtype=np.int64)
        levels = [(state[None, :], np.array([model.key(state)], dtype=np.uint64))]
        for _ in range(self.horizon - 1):  # S_T is never materialised (see module docstring)
            levels.append(self._expand(*levels[-1]))
        games = programs = 0
        samples = []
        next_keys = next_values = None
        root = None
        for t in range(self.horizon - 1, -1, -1):
            states, keys = levels[t]
            values_a = np.empty(len(states))
            values_b = np.empty(len(states))
            for i in range(len(states)):
                solution, stage, big_ua, big_ub = self._solve_state(states[i], keys[i], next_keys, next_values)
                values_a[i], values_b[i] = solution.leader_value, solution.follower_value
                games += 1
                programs += solution.programs_solved
                if len(samples) < self.keep_stage_games:
                    samples.append((big_ua, big_ub))
                if t == 0:
                    root = (solution, stage)
            next_keys, next_values = keys, (values_a, values_b)
        solution, stage = root
        support = np.flatnonzero(solution.leader_policy > 1e-12)
        sizes = [len(k) for _, k in levels]
        if self.count_terminal_states:
            sizes.append(self._count_terminal(levels[-1]))
        return FSEResult(
            leader_policy=solution.leader_policy[support],
            leader_actions=stage.leader_actions[support],
            leader_action=int(stage.leader_actions[solution.leader_action]),
            follower_action=int(stage.follower_actions[solution.follower_action]),
            leader_value=solution.leader_value, follower_value=solution.follower_value,
            states_per_stage=sizes, stage_games=games, programs_solved=programs,
            seconds=time.perf_counter() - start, stage_game_samples=samples)

    def _count_terminal(self, level) -> int:
        """|S_T| by hashing the last stage's outcome keys (cheap; reported by the benchmark)."""
        states, keys = level
        seen = [np.unique(self.model.stage(states[i], keys[i]).outcome_keys) for i in range(len(states))]
        return int(len(np.unique(np.concatenate(seen))))
