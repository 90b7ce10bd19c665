"""The rearrangement game as flat integer and float arrays, for the compiled FSE kernel (:mod:`.fse_kernel`).

State encoding (the same as :mod:`.rearrangement`): a state is the int64 vector of object counts,
index ``cell * colours + colour``; a level S_t is an (N, dim) int64 array with one 64-bit linear key
per state (key(s) = sum_i s_i h_i mod 2^64, the model's own hash weights, so a successor's key is
key(s) + k(a^A) + k(a^B) and both paths name every state by the same key).

An action table becomes rows of an int64 array (``fse_kernel.TAKE`` .. ``MISPLACED``; the empty
action is index 0, with clipped placeholder cells and zero deltas), a float64 array
(``BASE_COST``, ``REWARD_DELTA``) and its uint64 key deltas. (The row and entry indices live in
:mod:`.fse_kernel`: numba's on-disk cache is keyed by that file only.) Every number is taken from
the model (costs, reward deltas, outcome probabilities, the clutter multiplier per cell total),
so the kernel does the same floating-point operations as the reference on the same inputs.

:func:`is_cooperative`: u^A = r - w^A_own c^A - w^A_other c^B and u^B = r - w^B_own c^B - w^B_other c^A
are the same function (and so U^A = U^B in every stage game) exactly when w^A_own = w^B_other and
w^A_other = w^B_own; the default all-ones weights are the team utility of Section III-A.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .fse_kernel import BASE_COST, MISPLACED, PUT, REWARD_DELTA, SOURCE, TAKE, TARGET
from .rearrangement import RearrangementModel
from .task_config import TaskConfig


def is_cooperative(task: TaskConfig) -> bool:
    """U^A = U^B in every stage game (see the module docstring)."""
    w = task.utility
    return w.leader_own == w.follower_other and w.leader_other == w.follower_own


def _robot_tables(table) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ints = np.zeros((5, table.size), dtype=np.int64)
    ints[TAKE] = table.take
    ints[PUT] = table.put
    ints[SOURCE] = np.maximum(table.source, 0)
    ints[TARGET] = np.maximum(table.target, 0)
    ints[MISPLACED] = table.misplaced_delta
    floats = np.zeros((2, table.size), dtype=np.float64)
    floats[BASE_COST] = table.base_cost
    floats[REWARD_DELTA] = table.reward_delta
    return ints, floats, np.ascontiguousarray(table.key_delta, dtype=np.uint64)


@dataclass(frozen=True)
class GameTables:
    """Everything the kernel reads about one task's game (read-only arrays)."""

    floats: np.ndarray          # (14,) fse_kernel.P_BOTH .. TOLERANCE
    ints: np.ndarray            # (3,) fse_kernel.CAPACITY .. COLOURS
    object_value: np.ndarray    # (dim,) reward of one object per slot
    in_goal: np.ndarray         # (dim,) int64, 1 where the slot is its colour's goal cell
    hash_weights: np.ndarray    # (dim,) uint64
    leader: tuple[np.ndarray, np.ndarray, np.ndarray]     # ints (5, size), floats (2, size), key deltas
    follower: tuple[np.ndarray, np.ndarray, np.ndarray]
    model: RearrangementModel

    @classmethod
    def of(cls, model: RearrangementModel, tolerance: float) -> 'GameTables':
        task = model.task
        w = task.utility
        p_a = 1.0 - task.leader.failure_probability
        p_b = 1.0 - task.follower.failure_probability
        floats = np.array([*model.outcome_probability, p_a, 1.0 - p_a, p_b, w.leader_own, w.leader_other,
                           w.follower_own, w.follower_other, task.discount, task.reward.goal_bonus, tolerance],
                          dtype=np.float64)
        ints = np.array([task.cell_capacity, int(task.charge_failed_actions), model.colours], dtype=np.int64)
        return cls(floats, ints, np.ascontiguousarray(model.object_value, dtype=np.float64),
                   model.in_goal.astype(np.int64), np.ascontiguousarray(model.hash_weights, dtype=np.uint64),
                   _robot_tables(model.actions[0]), _robot_tables(model.actions[1]), model)

    def clutter_multipliers(self, objects: int) -> np.ndarray:
        """multiplier(n) for n = 0 .. objects + 1, from the task's own ClutterRule (same numbers)."""
        return np.asarray(self.model.task.clutter.multiplier(np.arange(objects + 2)), dtype=np.float64)

    def kernel_arguments(self, objects: int) -> tuple:
        """The tuple every kernel takes (``game``), for states holding ``objects`` objects."""
        return (self.floats, self.ints, self.object_value, self.in_goal, self.hash_weights,
                self.clutter_multipliers(objects), *self.leader, *self.follower)
