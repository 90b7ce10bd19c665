"""Centralised joint planner: the fewest rounds to the goal, a lower bound for SGCM.

Both robots' moves are chosen together by one planner and never fail, so a round goes
from s to step(s, a^A, a^B) for any feasible pair. A* over states with the admissible
(and consistent) heuristic max(ceil(D / 2), ceil(M / (m^A + m^B))): in one round each
robot moves one object by one cell, so the total Chebyshev distance D of the objects to
their goals drops by at most 2, and the total Manhattan distance M by at most m^A + m^B,
where a robot's move shortens it by m = 2 with diagonal moves (8 directions), else 1.
The follower may carry on the object the leader just put down (relay), so one object can
travel two cells in a round: the farthest object alone bounds the rounds only by half its
distance, which ceil(D / 2) already covers. Among frontier entries of equal f the deeper
one is expanded first; with a tight heuristic this reaches the goal without sweeping
the whole plateau of equal-f states.
"""
from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass

import numpy as np

from .rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel


@dataclass(frozen=True)
class JointPlan:
    rounds: int | None               # None if the goal is unreachable within the node limit
    moves: list[tuple[str, str]]     # (leader move, follower move) per round
    expanded: int


class CentralizedPlanner:
    def __init__(self, model: RearrangementModel, node_limit: int = 200_000):
        self.model = model
        self.node_limit = node_limit
        t = model.task
        rows, cols = np.divmod(np.arange(t.cells), t.cols)
        cheb = np.maximum(np.abs(rows[:, None] - rows[None, :]), np.abs(cols[:, None] - cols[None, :]))
        self._distance = np.zeros(model.dim, dtype=np.int64)  # per (cell, colour) slot
        for colour, goal in enumerate(t.goals):
            self._distance[np.arange(t.cells) * model.colours + colour] = cheb[:, goal]
        manhattan = np.abs(rows[:, None] - rows[None, :]) + np.abs(cols[:, None] - cols[None, :])
        self._manhattan = np.zeros(model.dim, dtype=np.int64)
        for colour, goal in enumerate(t.goals):
            self._manhattan[np.arange(t.cells) * model.colours + colour] = manhattan[:, goal]
        # Largest drop of the total Manhattan distance in one round (a diagonal move: 2).
        self._manhattan_per_round = sum(2 if r.directions == 8 else 1 for r in (t.leader, t.follower))

    def heuristic(self, states: np.ndarray) -> np.ndarray:
        states = np.atleast_2d(states)
        chebyshev = states @ self._distance
        manhattan = states @ self._manhattan
        return np.maximum(-(-chebyshev // 2), -(-manhattan // self._manhattan_per_round))

    def plan(self, initial: np.ndarray) -> JointPlan:
        model = self.model
        start = model.state_of(initial)
        goal_key = model.key(model.goal_state(start))
        counter = itertools.count()
        start_key = model.key(start)
        # Entries (f, -g, tie, key): equal f pops the deeper state first.
        frontier = [(int(self.heuristic(start)[0]), 0, next(counter), start_key)]
        states = {start_key: start}
        cost = {start_key: 0}
        parent: dict = {start_key: None}
        expanded = 0
        while frontier and expanded < self.node_limit:
            _, depth, _, key = heapq.heappop(frontier)
            g = -depth
            if g > cost[key]:
                continue
            if key == goal_key:
                return JointPlan(g, self._moves(parent, key), expanded)
            expanded += 1
            state = states[key]
            stage = model.stage(state, key)
            a = stage.leader_actions
            b = stage.follower_actions
            successors = (state + model.move_vectors(LEADER)[a][:, None, :]
                          + np.where(stage.blocked[:, :, None], 0,
                                     model.move_vectors(FOLLOWER)[b][None, :, :]))
            keys = stage.outcome_keys[:, :, 0].reshape(-1)
            flat = successors.reshape(-1, model.dim)
            h = self.heuristic(flat)
            for index in range(len(keys)):
                child = keys[index]
                if child in cost and cost[child] <= g + 1:
                    continue
                cost[child] = g + 1
                states[child] = flat[index].copy()  # a view would keep all of `successors` alive
                ai, bi = divmod(index, len(b))
                parent[child] = (key, int(a[ai]), int(b[bi]))
                heapq.heappush(frontier, (g + 1 + int(h[index]), -(g + 1), next(counter), child))
        return JointPlan(None, [], expanded)

    def _moves(self, parent, key) -> list[tuple[str, str]]:
        moves = []
        while parent[key] is not None:
            key, a, b = parent[key]
            moves.append((self.model.describe(LEADER, a), self.model.describe(FOLLOWER, b)))
        return moves[::-1]


__all__ = ['CentralizedPlanner', 'JointPlan', 'EMPTY']
