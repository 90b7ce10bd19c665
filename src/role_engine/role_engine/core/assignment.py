"""Group Role Assignment (GRA) by the Hungarian method, and the nearest-neighbour baseline.

GRA (Zhu et al. 2012, ref. [14]; Algorithm 3 line 23): given the qualification matrix
``Q`` (m agents x n roles, here a cost: lower is better, ``inf`` = the agent cannot
play the role) and the role requirement vector ``L`` (agents needed per role, default
one each), find the 0/1 assignment matrix ``T`` with column sums ``L`` and row sums
<= 1 that minimises the total cost. Each role is repeated ``L[j]`` times and the
rectangular problem is solved with ``scipy.optimize.linear_sum_assignment``.

The group is *workable* when every role position can be filled by a distinct agent
with a finite entry; otherwise the result says why not (too few agents, a role nobody
qualifies for, or a set of roles sharing too few qualified agents) and ``T`` is empty.
More agents than role positions is workable: the extra agents stay unassigned.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching

from .errors import RoleEngineError


@dataclass
class AssignmentResult:
    """Outcome of an assignment.

    ``assignment`` is T (m x n, 0/1); ``role_of_agent[i]`` is the role index of agent i
    or -1 when unassigned; ``pairs`` lists (agent, role) indices; ``total_cost`` sums Q
    over the pairs (inf when infeasible).
    """

    feasible: bool
    assignment: np.ndarray
    role_of_agent: np.ndarray
    total_cost: float
    reason: str = ''
    pairs: list[tuple[int, int]] = field(default_factory=list)

    @property
    def unassigned_agents(self) -> list[int]:
        return [int(i) for i in np.flatnonzero(self.role_of_agent < 0)]


def _names(names, count: int, prefix: str) -> list[str]:
    if names is None:
        return [f'{prefix}{i}' for i in range(count)]
    names = [str(n) for n in names]
    if len(names) != count:
        raise RoleEngineError(f'{prefix} names: expected {count} names (got {len(names)})')
    return names


def check_qualification(q: np.ndarray) -> np.ndarray:
    """Return Q as a float (m, n) array; NaN or -inf entries are errors naming the entry."""
    q = np.array(q, dtype=float)
    if q.ndim != 2 or q.shape[0] < 1 or q.shape[1] < 1:
        raise RoleEngineError(f'Q: must be a 2-D matrix with at least one agent and one role (got shape {q.shape})')
    bad = np.argwhere(np.isnan(q) | (q == -np.inf))
    if bad.size:
        i, j = bad[0]
        raise RoleEngineError(f'Q[{i}, {j}]: must be a finite cost or +inf (got {q[i, j]})')
    return q


def _result_from_pairs(q: np.ndarray, pairs: list[tuple[int, int]], reason: str = '') -> AssignmentResult:
    m, n = q.shape
    assignment = np.zeros((m, n), dtype=int)
    role_of_agent = np.full(m, -1, dtype=int)
    for agent, role in pairs:
        assignment[agent, role] = 1
        role_of_agent[agent] = role
    total = float(sum(q[a, r] for a, r in pairs)) if pairs else 0.0
    feasible = not reason and math.isfinite(total)
    return AssignmentResult(feasible, assignment, role_of_agent, total if feasible else math.inf,
                            reason, sorted(pairs))


def _infeasible(q: np.ndarray, reason: str) -> AssignmentResult:
    m, n = q.shape
    return AssignmentResult(False, np.zeros((m, n), dtype=int), np.full(m, -1, dtype=int), math.inf, reason)


def group_role_assignment(q, role_requirements=None, *, agent_names=None, role_names=None) -> AssignmentResult:
    """Minimum-cost assignment of agents to roles (Hungarian method), or why none exists."""
    q = check_qualification(q)
    m, n = q.shape
    agents = _names(agent_names, m, 'agent')
    roles = _names(role_names, n, 'role')
    if role_requirements is None:
        needs = np.ones(n, dtype=int)
    else:
        needs = np.asarray(role_requirements)
        if needs.shape != (n,) or not np.issubdtype(needs.dtype, np.integer) or (needs < 0).any():
            raise RoleEngineError(f'L: must be {n} integers >= 0, one per role (got {np.asarray(role_requirements).tolist()})')
    role_of_position = np.repeat(np.arange(n), needs)
    positions = len(role_of_position)
    if positions == 0:
        return _result_from_pairs(q, [])
    if positions > m:
        return _infeasible(q, f'not workable: {positions} role positions need more agents than the {m} available')
    expanded = q[:, role_of_position]                      # m x positions
    qualified = np.isfinite(expanded)
    empty_roles = [roles[j] for j in range(n) if needs[j] > 0 and not np.isfinite(q[:, j]).any()]
    if empty_roles:
        return _infeasible(q, f"not workable: no agent can play role(s) {', '.join(empty_roles)} "
                              '(every qualification is inf)')
    matching = maximum_bipartite_matching(csr_matrix(qualified.T.astype(np.int8)), perm_type='column')
    if (matching < 0).any():
        return _infeasible(q, _hall_violation(qualified, matching, role_of_position, agents, roles))
    rows, cols = linear_sum_assignment(expanded)
    return _result_from_pairs(q, [(int(a), int(role_of_position[p])) for a, p in zip(rows, cols)])


def _hall_violation(qualified: np.ndarray, matching: np.ndarray, role_of_position: np.ndarray,
                    agents: list[str], roles: list[str]) -> str:
    """Name a set of roles whose qualified agents are too few (alternating-path search)."""
    agent_position = {int(a): p for p, a in enumerate(matching) if a >= 0}
    seen_positions = set(int(p) for p in np.flatnonzero(matching < 0))
    seen_agents: set[int] = set()
    queue = deque(seen_positions)
    while queue:
        position = queue.popleft()
        for agent in np.flatnonzero(qualified[:, position]):
            if int(agent) not in seen_agents:
                seen_agents.add(int(agent))
                nxt = agent_position.get(int(agent))
                if nxt is not None and nxt not in seen_positions:
                    seen_positions.add(nxt)
                    queue.append(nxt)
    role_set = sorted({int(role_of_position[p]) for p in seen_positions})
    return (f"not workable: roles {', '.join(roles[r] for r in role_set)} need {len(seen_positions)} agents "
            f"but only {', '.join(agents[a] for a in sorted(seen_agents)) or 'none'} "
            f'({len(seen_agents)}) can play them')


def nearest_neighbour_assignment(sources, destinations, q=None) -> AssignmentResult:
    """Baseline of Table IV: pair robots and destinations by straight-line distance.

    Pairs are taken greedily, closest (robot, destination) pair first, until every
    destination has a robot. The pairing ignores ``Q``; when ``Q`` is given the result's
    cost is read from it, and a pair with ``Q = inf`` makes the result infeasible.
    """
    sources = np.asarray(sources, dtype=float)
    destinations = np.asarray(destinations, dtype=float)
    for name, array in (('sources', sources), ('destinations', destinations)):
        if array.ndim != 2 or array.shape[1] != 2 or len(array) == 0 or not np.isfinite(array).all():
            raise RoleEngineError(f'{name}: must be a non-empty (K, 2) array of finite points (got shape {array.shape})')
    m, n = len(sources), len(destinations)
    distance = np.linalg.norm(sources[:, None, :] - destinations[None, :, :], axis=2)
    cost = distance if q is None else check_qualification(q)
    if cost.shape != (m, n):
        raise RoleEngineError(f'Q: must have shape ({m}, {n}) (got {cost.shape})')
    if n > m:
        return _infeasible(cost, f'not workable: {n} destinations need more robots than the {m} available')
    order = np.argsort(distance, axis=None, kind='stable')
    used_agents, used_roles, pairs = set(), set(), []
    for flat in order:
        agent, role = divmod(int(flat), n)
        if agent not in used_agents and role not in used_roles:
            pairs.append((agent, role))
            used_agents.add(agent)
            used_roles.add(role)
            if len(pairs) == n:
                break
    result = _result_from_pairs(cost, pairs)
    if not result.feasible:
        bad = [(a, r) for a, r in pairs if not np.isfinite(cost[a, r])]
        result.reason = 'nearest neighbour pairs ' + ', '.join(
            f'agent{a} with role{r}' for a, r in bad) + ' although it cannot play it (Q = inf)'
    return result
