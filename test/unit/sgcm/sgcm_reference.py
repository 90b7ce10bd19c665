"""Independent reference computations for the SGCM tests (not used by the core).

- :func:`reference_sse`: strong Stackelberg equilibrium values by one LP per follower action,
  without the fast method's shortcuts (bounds, pure-commitment short cuts, cooperative case).
- :func:`brute_force_fse`: backward induction over every reachable state, with successors
  built one by one by ``model.step`` for every action pair and success outcome, and costs
  taken from ``model.cost`` on the state each robot acts on. It never touches the planner's
  state keys, stage matrices or vectorised outcome tables.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import linprog

from sgcm.core.rearrangement import FOLLOWER, LEADER


def reference_sse(ua, ub, tolerance: float = 1e-9) -> tuple[float, float]:
    """(leader value, follower value) of the strong Stackelberg equilibrium.

    For each follower action j: the best leader value over commitments x to which j is a best
    response (an LP); the leader value is the best of these. Among the actions reaching it,
    the follower value is the best U^B_j . x with U^A_j . x held at that value (second LP).
    """
    ua = np.asarray(ua, dtype=float)
    ub = np.asarray(ub, dtype=float)
    m, n = ua.shape
    tol = tolerance * max(1.0, np.abs(ua).max(), np.abs(ub).max())
    values = {}
    for j in range(n):
        a_ub = (ub - ub[:, [j]]).T   # U^B_k . x <= U^B_j . x for every k
        result = linprog(-ua[:, j], A_ub=a_ub, b_ub=np.zeros(n), A_eq=np.ones((1, m)), b_eq=[1.0],
                         bounds=(0, None), method='highs')
        if result.status == 0:
            values[j] = -result.fun
    leader = max(values.values())
    follower = -np.inf
    for j, value in values.items():
        if value < leader - tol:
            continue
        a_ub = np.vstack([(ub - ub[:, [j]]).T, -ua[:, j]])
        b_ub = np.append(np.zeros(n), -(leader - tol))
        result = linprog(-ub[:, j], A_ub=a_ub, b_ub=b_ub, A_eq=np.ones((1, m)), b_eq=[1.0],
                         bounds=(0, None), method='highs')
        if result.status == 0:
            follower = max(follower, -result.fun)
    return float(leader), float(follower)


OUTCOMES = ((True, True), (True, False), (False, True), (False, False))


class BruteForceFSE:
    """v_t^A, v_t^B by explicit enumeration (see the module docstring)."""

    def __init__(self, model, horizon: int, cooperative: bool):
        self.model = model
        self.horizon = horizon
        self.cooperative = cooperative
        task = model.task
        self.p_leader = 1.0 - task.leader.failure_probability
        self.p_follower = 1.0 - task.follower.failure_probability
        self.memo: dict = {}
        self.reachable = [set() for _ in range(horizon + 1)]

    def outcome_probability(self, leader_ok: bool, follower_ok: bool) -> float:
        pa = self.p_leader if leader_ok else 1.0 - self.p_leader
        pb = self.p_follower if follower_ok else 1.0 - self.p_follower
        return pa * pb

    def leader_actions(self, state) -> list[int]:
        return [a for a in range(self.model.actions[LEADER].size) if self.model.can_apply(state, LEADER, a)]

    def follower_actions(self) -> list[int]:
        # Every follower action of the table: one that finds no object is a no-op column.
        return list(range(self.model.actions[FOLLOWER].size))

    def _follower_cost(self, state, action) -> float:
        model = self.model
        return float(model.cost(state, FOLLOWER, action)) if model.can_apply(state, FOLLOWER, action) else 0.0

    def matrices(self, state, t: int):
        """U^A_t, U^B_t over (leader_actions(state), follower_actions())."""
        model = self.model
        task = model.task
        w = task.utility
        reward = float(model.reward(state))
        rows, cols = self.leader_actions(state), self.follower_actions()
        big_ua = np.empty((len(rows), len(cols)))
        big_ub = np.empty((len(rows), len(cols)))
        for i, a in enumerate(rows):
            after_leader = model.apply(state, LEADER, a)
            leader_cost = float(model.cost(state, LEADER, a))
            for k, b in enumerate(cols):
                follower_cost = (self.p_leader * self._follower_cost(after_leader, b)
                                 + (1 - self.p_leader) * self._follower_cost(state, b))
                ca, cb = leader_cost, follower_cost
                if not task.charge_failed_actions:
                    ca, cb = ca * self.p_leader, cb * self.p_follower
                future_a = future_b = 0.0
                for leader_ok, follower_ok in OUTCOMES:
                    p = self.outcome_probability(leader_ok, follower_ok)
                    va, vb = self.value(model.step(state, a, b, leader_ok, follower_ok), t + 1)
                    future_a += p * va
                    future_b += p * vb
                big_ua[i, k] = reward - w.leader_own * ca - w.leader_other * cb + task.discount * future_a
                big_ub[i, k] = reward - w.follower_own * cb - w.follower_other * ca + task.discount * future_b
        return rows, cols, big_ua, big_ub

    def value(self, state, t: int) -> tuple[float, float]:
        state = np.asarray(state, dtype=np.int64)
        self.reachable[t].add(state.tobytes())
        if t == self.horizon:
            r = float(self.model.reward(state))
            return r, r   # v_T^i = u_T^i = r(s)
        key = (state.tobytes(), t)
        if key not in self.memo:
            _, _, big_ua, big_ub = self.matrices(state, t)
            if self.cooperative:
                # U^A = U^B up to the order of the cost terms: the largest entry is the equilibrium.
                np.testing.assert_allclose(big_ua, big_ub, rtol=0, atol=1e-9)
                self.memo[key] = (float(big_ua.max()), float(big_ub.max()))
            else:
                self.memo[key] = reference_sse(big_ua, big_ub)
        return self.memo[key]
