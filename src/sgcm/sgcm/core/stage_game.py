"""One stage game of the feedback Stackelberg equilibrium (Section IV-A/B).

Given the leader's and the follower's utility matrices U^A, U^B (rows: leader
actions, columns: follower actions), the leader commits to a mixed strategy x and the
follower best-responds with a pure action (a pure best response always exists,
Section IV-B).

Tie-breaking (strong Stackelberg equilibrium): a follower indifferent between several
best responses picks the one best for the leader, which is what the MILP (Q~_t^A)
encodes by optimising over pi^B. Two more rules make the equilibrium unique in value
and reproducible in the dynamic programme:
  1. among commitments with the same leader value (within ``tolerance`` times the
     payoff scale), the one with the highest follower value is chosen, because the
     follower's value feeds back into earlier stages through v^B;
  2. among those, the lowest follower action index, and a pure leader strategy when
     one attains the values.

Two exact solvers:
- :func:`solve_milp`: the paper's MILP with z = pi^A pi^B, binary pi^B and the dual
  lambda, solved with HiGHS; big-M is the follower's payoff range in this stage game
  (lambda - (U^B)^T x lies in [0, max U^B - min U^B] at any feasible point, so a smaller
  M cuts off solutions and a larger one only weakens the relaxation and the numerics).
  The secondary rule is a second MILP with the leader value fixed; rule 2 is applied to
  its answer (HiGHS may return any of several equivalent follower actions): a lower
  follower action attaining both values replaces it (checked by its pure rows, else one LP).
- :func:`solve_fast`: one LP per follower action j ("multiple LPs"), skipped when it
  cannot matter: a column whose best leader payoff is below the best value found cannot
  win, and when a pure commitment with j as a best response reaches the column's upper
  bound, that bound is the LP's value without solving it. In cooperative games
  (U^A = U^B, the default guidance set-up) no LP is needed at all.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, linprog, milp
from scipy import sparse

DEFAULT_TOLERANCE = 1e-9


class StageGameError(RuntimeError):
    """The solver failed on a stage game (should not happen for finite payoffs)."""


@dataclass(frozen=True)
class StageSolution:
    leader_policy: np.ndarray   # (m,) probabilities over the leader's actions
    follower_action: int        # column index of the follower's pure best response
    leader_value: float
    follower_value: float
    programs_solved: int        # LPs or MILPs solved (0 when the pure bound settled it)

    @property
    def leader_action(self) -> int:
        """Most probable leader action (the executed one when the policy is pure)."""
        return int(np.argmax(self.leader_policy))


def _check(ua: np.ndarray, ub: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ua = np.asarray(ua, dtype=float)
    ub = np.asarray(ub, dtype=float)
    if ua.ndim != 2 or ua.shape != ub.shape or ua.size == 0:
        raise ValueError(f'utility matrices must be non-empty and of equal 2-D shape '
                         f'(got {ua.shape} and {ub.shape})')
    if not (np.isfinite(ua).all() and np.isfinite(ub).all()):
        raise ValueError('utility matrices must be finite')
    return ua, ub


def _scale(ua: np.ndarray, ub: np.ndarray) -> float:
    return max(1.0, float(np.abs(ua).max()), float(np.abs(ub).max()))


def _pure(x_row: int, m: int) -> np.ndarray:
    policy = np.zeros(m)
    policy[x_row] = 1.0
    return policy


# --- fast exact method ----------------------------------------------------------------

def _best_response_mask(ub: np.ndarray, tol: float) -> np.ndarray:
    """(m, n) True where column j is a follower best response to pure leader row a."""
    return ub >= ub.max(axis=1, keepdims=True) - tol


def _lp_column(ua: np.ndarray, ub: np.ndarray, j: int, objective: np.ndarray,
               floor: tuple[np.ndarray, float] | None = None) -> tuple[float, np.ndarray] | None:
    """max objective.x  s.t. j is a follower best response to x (and an optional floor row)."""
    m, n = ua.shape
    a_ub = (ub - ub[:, [j]]).T            # (U^B_k - U^B_j).x <= 0 for every k
    b_ub = np.zeros(n)
    if floor is not None:
        row, value = floor
        a_ub = np.vstack([a_ub, -row])
        b_ub = np.append(b_ub, -value)
    result = linprog(-objective, A_ub=a_ub, b_ub=b_ub, A_eq=np.ones((1, m)), b_eq=[1.0],
                     bounds=(0.0, None), method='highs')
    if result.status == 2:  # infeasible: j is never a best response
        return None
    if result.status != 0:
        raise StageGameError(f'LP for follower action {j} failed: {result.message}')
    x = np.clip(result.x, 0.0, None)
    return float(objective @ x), x / x.sum()


def solve_fast(ua: np.ndarray, ub: np.ndarray, tolerance: float = DEFAULT_TOLERANCE) -> StageSolution:
    """Strong Stackelberg equilibrium by bounded multiple LPs (see the module docstring)."""
    ua, ub = _check(ua, ub)
    m, n = ua.shape
    tol = tolerance * _scale(ua, ub)
    br = _best_response_mask(ub, tol)
    column_bound = ua.max(axis=0)
    programs = 0
    # Best pure commitment per column: rows where j is a best response, best for the
    # leader, then for the follower, then the lowest row.
    masked_a = np.where(br, ua, -np.inf)
    best = []  # (V_j, W_j, j, policy)
    order = np.argsort(-column_bound, kind='stable')
    best_value = -np.inf
    for j in order:
        if column_bound[j] < best_value - tol:
            break  # columns are sorted by bound: none of the rest can reach the best value
        pure_value = masked_a[:, j].max()
        if pure_value >= column_bound[j] - tol:
            value = float(column_bound[j])
            policy = None
        else:
            solved = _lp_column(ua, ub, j, ua[:, j])
            programs += 1
            if solved is None:
                continue
            value, policy = solved
            if np.isfinite(pure_value) and pure_value >= value - tol:
                value, policy = float(pure_value), None
        if value < best_value - tol:
            continue
        best_value = max(best_value, value)
        best.append((value, j, policy))
    ties = [(v, j, pol) for v, j, pol in best if v >= best_value - tol]
    # Secondary rule: highest follower value among commitments reaching the leader value.
    chosen = None
    for value, j, policy in sorted(ties, key=lambda item: item[1]):
        rows = ua[:, j] >= value - tol
        candidates = rows & br[:, j]
        pure_w = ub[candidates, j].max() if candidates.any() else -np.inf
        # When the leader value is the column's best payoff, only rows reaching it can
        # carry weight, so their best follower payoff bounds the follower value.
        at_bound = value >= column_bound[j] - tol
        if at_bound and pure_w >= ub[rows, j].max() - tol:
            row = int(np.flatnonzero(candidates & (ub[:, j] >= pure_w - tol))[0])
            w, pol = float(ub[row, j]), _pure(row, m)
            v = float(ua[row, j])
        else:
            solved = _lp_column(ua, ub, j, ub[:, j], floor=(ua[:, j], value - tol))
            programs += 1
            if solved is None:  # numerically at the edge; keep the primary solution
                pol = policy if policy is not None else _pure(int(np.argmax(masked_a[:, j])), m)
            else:
                pol = solved[1]
            v, w = float(ua[:, j] @ pol), float(ub[:, j] @ pol)
        if chosen is None or w > chosen[1] + tol:
            chosen = (v, w, j, pol)
    if chosen is None:
        raise StageGameError('no follower action is a best response to any commitment')
    v, w, j, pol = chosen
    return StageSolution(pol, int(j), v, w, programs)


# --- the paper's MILP --------------------------------------------------------------------

def big_m(ub: np.ndarray) -> float:
    """Big-M of (Q~_t^A): the follower's payoff range in this stage game (plus slack)."""
    spread = float(ub.max() - ub.min())
    return spread + max(1e-6, 1e-6 * spread)


def _milp_model(ua: np.ndarray, ub: np.ndarray):
    """Variables [z (m*n, row-major), pi^B (n), lambda]; constraints of (Q~_t^A)."""
    m, n = ua.shape
    nz = m * n
    nv = nz + n + 1
    M = big_m(ub)
    rows, cols, vals, lower, upper = [], [], [], [], []

    def add(entries, lo, hi):
        r = len(lower)
        for c, v in entries:
            rows.append(r)
            cols.append(c)
            vals.append(v)
        lower.append(lo)
        upper.append(hi)

    z = lambda a, j: a * n + j  # noqa: E731
    q = lambda j: nz + j        # noqa: E731
    lam = nz + n
    add([(k, 1.0) for k in range(nz)], 1.0, 1.0)                       # sum z = 1
    for a in range(m):                                                 # z 1 <= 1
        add([(z(a, j), 1.0) for j in range(n)], -np.inf, 1.0)
    for j in range(n):                                                 # pi^B <= z^T 1 <= 1
        add([(z(a, j), 1.0) for a in range(m)] + [(q(j), -1.0)], 0.0, np.inf)
        add([(z(a, j), 1.0) for a in range(m)], -np.inf, 1.0)
    add([(q(j), 1.0) for j in range(n)], 1.0, 1.0)                     # sum pi^B = 1
    for k in range(n):
        # 0 <= lambda - U^B[:, k].x  and  lambda - U^B[:, k].x <= M (1 - pi^B_k), x = z 1
        coeff = [(z(a, j), -ub[a, k]) for a in range(m) for j in range(n) if ub[a, k] != 0.0]
        add(coeff + [(lam, 1.0)], 0.0, np.inf)
        add(coeff + [(lam, 1.0), (q(k), M)], -np.inf, M)
    matrix = sparse.csr_array((vals, (rows, cols)), shape=(len(lower), nv))
    integrality = np.zeros(nv)
    integrality[nz:nz + n] = 1
    lo = np.zeros(nv)
    hi = np.ones(nv)
    lo[lam], hi[lam] = -np.inf, np.inf
    return matrix, np.array(lower), np.array(upper), integrality, Bounds(lo, hi)


def solve_milp(ua: np.ndarray, ub: np.ndarray, tolerance: float = DEFAULT_TOLERANCE) -> StageSolution:
    """Strong Stackelberg equilibrium from the paper's MILP (Q~_t^A) with HiGHS."""
    ua, ub = _check(ua, ub)
    m, n = ua.shape
    tol = tolerance * _scale(ua, ub)
    matrix, lower, upper, integrality, bounds = _milp_model(ua, ub)
    options = {'mip_rel_gap': 0.0, 'presolve': True}
    objective = np.zeros(matrix.shape[1])
    objective[:m * n] = -ua.reshape(-1)
    first = milp(objective, constraints=LinearConstraint(matrix, lower, upper),
                 integrality=integrality, bounds=bounds, options=options)
    if first.status != 0:
        raise StageGameError(f'stage MILP failed: {first.message}')
    value = -first.fun
    # Secondary rule: maximise the follower's value with the leader's value held.
    floor = np.zeros((1, matrix.shape[1]))
    floor[0, :m * n] = ua.reshape(-1)
    constraints = [LinearConstraint(matrix, lower, upper), LinearConstraint(floor, value - tol, np.inf)]
    objective2 = np.zeros(matrix.shape[1])
    objective2[:m * n] = -ub.reshape(-1)
    second = milp(objective2, constraints=constraints, integrality=integrality, bounds=bounds,
                  options=options)
    solution = second if second.status == 0 else first
    zmat = np.clip(solution.x[:m * n].reshape(m, n), 0.0, None)
    j = int(np.argmax(solution.x[m * n:m * n + n]))
    policy = zmat.sum(axis=1)
    policy = policy / policy.sum()
    leader_value, follower_value = float(ua[:, j] @ policy), float(ub[:, j] @ policy)
    programs = 2 if second.status == 0 else 1
    # Rule 2: HiGHS may return any of several follower actions attaining both values; report
    # the lowest one, as solve_fast does (columns whose best entries fall short are skipped).
    br_all = _best_response_mask(ub, tol)
    for k in range(j):
        if ua[:, k].max() < leader_value - tol or ub[:, k].max() < follower_value - tol:
            continue
        if (br_all[:, k] & (ua[:, k] >= leader_value - tol) & (ub[:, k] >= follower_value - tol)).any():
            j = k  # a pure row attains the values; the canonical form below picks it
            break
        solved = _lp_column(ua, ub, k, ub[:, k], floor=(ua[:, k], leader_value - tol))
        programs += 1
        if solved is not None and solved[0] >= follower_value - tol:
            j, policy = k, solved[1]
            break
    # Canonical form: a pure row reaching the same values is reported as pure.
    br = br_all[:, j]
    pure_rows = np.flatnonzero(br & (ua[:, j] >= leader_value - tol) & (ub[:, j] >= follower_value - tol))
    if len(pure_rows):
        policy = _pure(int(pure_rows[0]), m)
    leader_value, follower_value = float(ua[:, j] @ policy), float(ub[:, j] @ policy)
    return StageSolution(policy, j, leader_value, follower_value, programs)


SOLVERS = {'fast': solve_fast, 'milp': solve_milp}
