"""Compiled kernels of the feedback Stackelberg equilibrium (Section IV-A, Algorithm 1 lines 3-18).

The same computation as :class:`.fse.FSEPlanner` (the reference), over integer state arrays
(:mod:`.game_tables`): numba-compiled loops instead of numpy calls on small per-state arrays.

- :func:`expand_level`: forward prediction S_t -> S_{t+1} (Algorithm 1 lines 3-10): every outcome of
  every candidate action pair of every state, merged by key in an open-addressing hash table. Per
  state the outcomes (0, 0), (a^A, 0), (0, a^B) are hashed once (1 + m + n keys) and only the
  outcome (a^A, a^B) per pair.
- :func:`solve_level_pure`: one whole stage t of the dynamic programme (lines 11-18): per state the
  stage utilities u^i(s, a^A, a^B) and the transitions (successor values looked up by key in
  S_{t+1}'s table, or r(s') from per-action deltas at t = T-1), U^i = u^i + gamma E[v^i_{t+1}], and
  the stage game's equilibrium read off the matrices by :func:`_solve_pure` (the cooperative case).
  A follower move that finds no object whether her move succeeds or not (a "relay" candidate she
  does not serve) has exactly his empty action's numbers: that cell is copied, not recomputed.
- :func:`level_games`: the matrices U^A, U^B of a slice of a stage, for the stage-game solvers of
  :mod:`.stage_game` (general-sum games, and any state :func:`_solve_pure` cannot settle).

Every number is computed with the reference's formula in the reference's order of operations
(utilities, clutter multipliers, expected costs); the expectation over the four outcomes is summed
as (p_both v_both + p_follower v_follower) + (p_leader v_leader + p_none v_none), the order numpy's
BLAS matmul uses for these shapes, so values agree with the reference to the last bits (a few ulps
where BLAS sums differently).

Tie rule of :func:`_solve_pure` (= the reference :func:`.stage_game.solve_fast` whenever no LP is
needed, which in cooperative games U^A = U^B is always; tolerance tol = 1e-9 x the payoff scale):
with B the largest entry of U^A, the follower actions (columns) whose best entry reaches B - tol
are the candidates; each is settled by a pure commitment (else the state is handed to the LP
solver); the lowest-index candidate is kept unless a later one gives the follower more than tol
more; within a column the leader action is the lowest-index row reaching the column's best entry
within tol, to which the column is a best response, and with the follower's best payoff within
tol. In a cooperative game this is: the maximal entry, lowest follower action first, then lowest
leader action (indices in the stage's candidate order = action-table order).
"""
from __future__ import annotations

import numpy as np
from numba import njit

# Rows of a robot's int64 action table (game_tables.GameTables; kept here, as numba's cache only
# notices changes to this file).
TAKE, PUT, SOURCE, TARGET, MISPLACED = range(5)
# Rows of a robot's float64 action table.
BASE_COST, REWARD_DELTA = range(2)
# Entries of the float parameter vector.
P_BOTH, P_LEADER, P_FOLLOWER, P_NONE, P_A, Q_A, P_B, LEADER_OWN, LEADER_OTHER, FOLLOWER_OWN, \
    FOLLOWER_OTHER, GAMMA, GOAL_BONUS, TOLERANCE = range(14)
# Entries of the int parameter vector.
CAPACITY, CHARGE_FAILED, COLOURS = range(3)

NO_ROW = -1
_MIX = np.uint64(0x9E3779B97F4A7C15)
_SHIFT = np.uint64(32)


# --- a level's hash table: state key -> row in the level ---------------------------------------
# Open addressing with linear probing in one (slots, 2) uint64 array: [key, row + 1], 0 = empty slot
# (key and row share a cache line), at most half full.

@njit(cache=True)
def _slot(key, mask):
    return np.int64((key * _MIX) >> _SHIFT) & mask


@njit(cache=True)
def _empty_table(entries):
    size = 16
    while size < 2 * entries:
        size *= 2
    return np.zeros((size, 2), np.uint64)


@njit(cache=True)
def _probe(table, key):
    """The slot holding ``key``, or the empty slot where it would go (linear probing)."""
    mask = len(table) - 1
    i = _slot(key, mask)
    while table[i, 1] != 0 and table[i, 0] != key:
        i = (i + 1) & mask
    return i


@njit(cache=True)
def table_find(table, key):
    """The row of ``key`` in the level, NO_ROW if absent."""
    i = _probe(table, key)
    return np.int64(table[i, 1]) - 1 if table[i, 1] != 0 else NO_ROW


@njit(cache=True)
def _table_insert(table, key, row):
    """Insert ``key`` -> ``row`` unless present; returns the row already there or NO_ROW."""
    i = _probe(table, key)
    if table[i, 1] != 0:
        return np.int64(table[i, 1]) - 1
    table[i, 0] = key
    table[i, 1] = np.uint64(row + 1)
    return NO_ROW


@njit(cache=True)
def build_table(keys):
    """The hash table of a level's keys (distinct)."""
    table = _empty_table(len(keys))
    for row in range(len(keys)):
        _table_insert(table, keys[row], row)
    return table


# --- one state's candidate actions, blocked follower moves and costs (RearrangementModel.stage) ---

# Rows of the per-row (leader action) arrays and per-column (follower action) arrays of ``work``.
R_ACT, R_TAKE, R_PUT, R_SOURCE, R_TARGET, R_MISPLACED = range(6)
R_COST, R_REWARD, R_VALUE_A, R_VALUE_B, R_UTILITY_A, R_COST_B, R_BEST_B, R_TAIL_A, R_TAIL_B = range(9)
C_ACT, C_TAKE, C_SOURCE, C_TARGET, C_HELD, C_SOURCE_TOTAL, C_TARGET_TOTAL, C_MISPLACED, C_BLOCKED = range(9)
C_BASE, C_COST_ALONE, C_REWARD, C_VALUE_A, C_VALUE_B, C_BEST_A = range(6)


@njit(cache=True)
def buffers(game, dim):
    """Work arrays for one state at a time: totals, may_hold, row ints/floats, column ints/floats, U^A, U^B."""
    size_a, size_b = game[6].shape[1], game[9].shape[1]
    return (np.zeros(dim // game[1][COLOURS], np.int64), np.zeros(dim, np.bool_),
            np.zeros((6, size_a), np.int64), np.zeros((9, size_a)),
            np.zeros((9, size_b), np.int64), np.zeros((6, size_b)),
            np.zeros((size_a, size_b)), np.zeros((size_a, size_b)))


@njit(cache=True)
def _stage(state, game, work):
    """Candidate actions (EMPTY first) and what each pair needs, per row and column; returns (m, n)."""
    fl, ints, mult, lint, lflt, fint, fflt = game[0], game[1], game[5], game[6], game[7], game[9], game[10]
    totals, may_hold, rows, rows_f, cols, cols_f = work[:6]
    cap, k = ints[CAPACITY], ints[COLOURS]
    for c in range(len(totals)):
        total = 0
        for j in range(k):
            total += state[c * k + j]
        totals[c] = total
    m = 0
    for i in range(lint.shape[1]):
        if i == 0 or (state[lint[TAKE, i]] > 0 and totals[lint[TARGET, i]] < cap):
            rows[R_ACT, m] = i
            m += 1
    for d in range(len(state)):
        may_hold[d] = state[d] > 0
    for r in range(1, m):   # "relay": he may carry on an object she just put down
        may_hold[lint[PUT, rows[R_ACT, r]]] = True
    n = 0
    for i in range(fint.shape[1]):
        if i == 0 or may_hold[fint[TAKE, i]]:
            cols[C_ACT, n] = i
            n += 1
    charge = ints[CHARGE_FAILED] != 0
    for r in range(m):
        a = rows[R_ACT, r]
        rows[R_TAKE, r], rows[R_PUT, r] = lint[TAKE, a], lint[PUT, a]
        rows[R_SOURCE, r], rows[R_TARGET, r] = lint[SOURCE, a], lint[TARGET, a]
        rows[R_MISPLACED, r] = lint[MISPLACED, a]
        cost = lflt[BASE_COST, a] * mult[totals[lint[SOURCE, a]]]
        rows_f[R_COST, r] = cost if charge else cost * fl[P_A]
        rows_f[R_REWARD, r] = lflt[REWARD_DELTA, a]
    for col in range(n):
        b = cols[C_ACT, col]
        tb, sb, db = fint[TAKE, b], fint[SOURCE, b], fint[TARGET, b]
        cols[C_TAKE, col], cols[C_SOURCE, col], cols[C_TARGET, col] = tb, sb, db
        cols[C_HELD, col], cols[C_SOURCE_TOTAL, col], cols[C_TARGET_TOTAL, col] = state[tb], totals[sb], totals[db]
        cols[C_MISPLACED, col] = fint[MISPLACED, b]
        alone = col > 0 and (state[tb] <= 0 or totals[db] >= cap)
        cols[C_BLOCKED, col] = alone
        cols_f[C_BASE, col] = fflt[BASE_COST, b]
        cols_f[C_COST_ALONE, col] = 0.0 if alone else fflt[BASE_COST, b] * mult[totals[sb]]
        cols_f[C_REWARD, col] = fflt[REWARD_DELTA, b]
    return m, n


@njit(cache=True)
def _find(next_table, key):
    row = table_find(next_table, key)
    if row == NO_ROW:
        raise RuntimeError('successor state missing from the next level (internal error)')
    return row


@njit(cache=True)
def _state_game(state, key, game, terminal, next_table, next_va, next_vb, work):
    """U^A, U^B (work[6], work[7]) of the stage game at ``state``, the row maxima of U^B and column
    maxima of U^A; returns (m, n, payoff scale)."""
    fl, obj_value, in_goal, mult, lkey, fkey = game[0], game[2], game[3], game[5], game[8], game[11]
    rows, rows_f, cols, cols_f, ua, ub = work[2:8]
    m, n = _stage(state, game, work)
    cap = game[1][CAPACITY]
    linear = 0.0
    misplaced = 0
    for d in range(len(state)):
        linear += state[d] * obj_value[d]
        if in_goal[d] == 0:
            misplaced += state[d]
    bonus = fl[GOAL_BONUS]
    reward = linear + (bonus if misplaced == 0 else 0.0)
    p0, p1, p2, p3 = fl[P_BOTH], fl[P_LEADER], fl[P_FOLLOWER], fl[P_NONE]
    pa, qa, pb, gamma = fl[P_A], fl[Q_A], fl[P_B], fl[GAMMA]
    charge = game[1][CHARGE_FAILED] != 0
    w_lo, w_lother, w_fo, w_fother = fl[LEADER_OWN], fl[LEADER_OTHER], fl[FOLLOWER_OWN], fl[FOLLOWER_OTHER]
    # Outcomes (0, a^B), (a^A, 0), (0, 0): per column, per row, once.
    if terminal:   # v_T = r(s'), from per-action deltas (RearrangementModel.outcome_rewards)
        none_a = none_b = linear + (bonus if misplaced == 0 else 0.0)
        for col in range(n):
            blocked = cols[C_BLOCKED, col] != 0
            value = linear + (0.0 if blocked else cols_f[C_REWARD, col])
            value += bonus if misplaced + (0 if blocked else cols[C_MISPLACED, col]) == 0 else 0.0
            cols_f[C_VALUE_A, col] = cols_f[C_VALUE_B, col] = value * p2
        for r in range(m):
            value = linear + rows_f[R_REWARD, r] + (bonus if misplaced + rows[R_MISPLACED, r] == 0 else 0.0)
            rows_f[R_VALUE_A, r] = rows_f[R_VALUE_B, r] = value
    else:
        row = _find(next_table, key)
        none_a, none_b = next_va[row], next_vb[row]
        for col in range(n):
            successor = key + (np.uint64(0) if cols[C_BLOCKED, col] != 0 else fkey[cols[C_ACT, col]])
            row = _find(next_table, successor)
            cols_f[C_VALUE_A, col], cols_f[C_VALUE_B, col] = next_va[row] * p2, next_vb[row] * p2
        for r in range(m):
            row = _find(next_table, key + lkey[rows[R_ACT, r]])
            rows_f[R_VALUE_A, r], rows_f[R_VALUE_B, r] = next_va[row], next_vb[row]
    for r in range(m):
        rows_f[R_TAIL_A, r] = rows_f[R_VALUE_A, r] * p1 + none_a * p3
        rows_f[R_TAIL_B, r] = rows_f[R_VALUE_B, r] * p1 + none_b * p3
        rows_f[R_UTILITY_A, r] = reward - w_lo * rows_f[R_COST, r]
        rows_f[R_COST_B, r] = w_fother * rows_f[R_COST, r]
        rows_f[R_BEST_B, r] = -np.inf
    for col in range(n):
        cols_f[C_BEST_A, col] = -np.inf
        cols_f[C_COST_ALONE, col] = qa * cols_f[C_COST_ALONE, col]   # (1 - p_a) c^B after her failure
    scale = 1.0
    # Column views (contiguous) and row scalars, hoisted out of the pair loop.
    c_act, c_take, c_source, c_target = cols[C_ACT], cols[C_TAKE], cols[C_SOURCE], cols[C_TARGET]
    c_held, c_src_total, c_dst_total, c_misplaced = cols[C_HELD], cols[C_SOURCE_TOTAL], cols[C_TARGET_TOTAL], \
        cols[C_MISPLACED]
    c_base, c_alone, c_reward = cols_f[C_BASE], cols_f[C_COST_ALONE], cols_f[C_REWARD]
    c_value_a, c_value_b, c_best_a = cols_f[C_VALUE_A], cols_f[C_VALUE_B], cols_f[C_BEST_A]
    for r in range(m):
        a, take, put, source, target = rows[R_ACT, r], rows[R_TAKE, r], rows[R_PUT, r], rows[R_SOURCE, r], \
            rows[R_TARGET, r]
        lin_a, mis_a = linear + rows_f[R_REWARD, r], misplaced + rows[R_MISPLACED, r]
        value_a, value_b, tail_a, tail_b = rows_f[R_VALUE_A, r], rows_f[R_VALUE_B, r], rows_f[R_TAIL_A, r], \
            rows_f[R_TAIL_B, r]
        utility_a, cost_b_row = rows_f[R_UTILITY_A, r], rows_f[R_COST_B, r]
        key_a = key + lkey[a]
        best_b = -np.inf
        for col in range(n):
            if col > 0 and c_held[col] <= 0 and (r == 0 or put != c_take[col]):
                # His move finds no object after her success or failure: his empty action's cell, to the bit.
                u_a, u_b = ua[r, 0], ub[r, 0]
                ua[r, col], ub[r, col] = u_a, u_b
                if u_a > c_best_a[col]:
                    c_best_a[col] = u_a
                continue
            src = c_src_total[col]
            blocked = False
            if col > 0:   # his move after hers (the EMPTY row changes nothing)
                held, dst = c_held[col], c_dst_total[col]
                if r > 0:
                    tb, sb, db = c_take[col], c_source[col], c_target[col]
                    held += (1 if put == tb else 0) - (1 if take == tb else 0)
                    src += (1 if target == sb else 0) - (1 if source == sb else 0)
                    dst += (1 if target == db else 0) - (1 if source == db else 0)
                blocked = held <= 0 or dst >= cap
            fc = 0.0 if blocked else c_base[col] * mult[src]
            cb = pa * fc + c_alone[col]
            if not charge:
                cb = cb * pb
            # Outcome (a^A, a^B).
            if terminal:
                both_a = lin_a + (0.0 if blocked else c_reward[col])
                both_a += bonus if mis_a + (0 if blocked else c_misplaced[col]) == 0 else 0.0
                both_b = both_a
            elif blocked:
                both_a, both_b = value_a, value_b
            else:
                row = _find(next_table, key_a + fkey[c_act[col]])
                both_a, both_b = next_va[row], next_vb[row]
            u_a = (utility_a - w_lother * cb) + gamma * ((both_a * p0 + c_value_a[col]) + tail_a)
            u_b = ((reward - w_fo * cb) - cost_b_row) + gamma * ((both_b * p0 + c_value_b[col]) + tail_b)
            ua[r, col], ub[r, col] = u_a, u_b
            if abs(u_a) > scale:
                scale = abs(u_a)
            if abs(u_b) > scale:
                scale = abs(u_b)
            if u_b > best_b:
                best_b = u_b
            if u_a > c_best_a[col]:
                c_best_a[col] = u_a
        rows_f[R_BEST_B, r] = best_b
    return m, n, scale


# --- the stage game when a pure commitment settles it (the cooperative case) ---------------------

@njit(cache=True)
def _solve_pure(ua, ub, m, n, tol, best_b, bound):
    """(row, column, settled) by the module docstring's tie rule; settled False: an LP is needed.

    best_b: each row's largest U^B (j is a best response to row r where U^B[r, j] >= best_b[r] - tol);
    bound: each column's largest U^A.
    """
    best = -np.inf
    for c in range(n):
        best = max(best, bound[c])
    for c in range(n):   # every column that can reach the best value: a pure commitment reaches its bound
        if bound[c] < best - tol:
            continue
        pure = -np.inf
        for r in range(m):
            if ub[r, c] >= best_b[r] - tol:
                pure = max(pure, ua[r, c])
        if not pure >= bound[c] - tol:
            return NO_ROW, NO_ROW, False
    chosen_row, chosen_col, chosen_w = NO_ROW, NO_ROW, -np.inf
    for c in range(n):   # lowest column first; a later one only if better for the follower
        if bound[c] < best - tol:
            continue
        rows_best_b = -np.inf
        pure_w = -np.inf
        for r in range(m):
            if ua[r, c] >= bound[c] - tol:
                rows_best_b = max(rows_best_b, ub[r, c])
                if ub[r, c] >= best_b[r] - tol:
                    pure_w = max(pure_w, ub[r, c])
        if not pure_w >= rows_best_b - tol:
            return NO_ROW, NO_ROW, False
        row = 0
        while not (ua[row, c] >= bound[c] - tol and ub[row, c] >= best_b[row] - tol and ub[row, c] >= pure_w - tol):
            row += 1
        if chosen_col == NO_ROW or ub[row, c] > chosen_w + tol:
            chosen_row, chosen_col, chosen_w = row, c, ub[row, c]
    return chosen_row, chosen_col, True


@njit(cache=True)
def solve_level_pure(states, keys, game, terminal, next_table, next_va, next_vb):
    """One stage of the DP with :func:`_solve_pure`: v^A, v^B, the chosen action-table indices
    (leader, follower) per state, and whether each state was settled (else: hand it to a solver)."""
    count = len(states)
    values_a, values_b = np.empty(count), np.empty(count)
    leader, follower = np.full(count, NO_ROW, np.int64), np.full(count, NO_ROW, np.int64)
    settled = np.zeros(count, np.bool_)
    work = buffers(game, states.shape[1])
    rows, rows_f, cols, cols_f, ua, ub = work[2:8]
    tolerance = game[0][TOLERANCE]
    for i in range(count):
        m, n, scale = _state_game(states[i], keys[i], game, terminal, next_table, next_va, next_vb,
                                  work)
        row, col, ok = _solve_pure(ua, ub, m, n, tolerance * scale, rows_f[R_BEST_B], cols_f[C_BEST_A])
        settled[i] = ok
        if ok:
            values_a[i], values_b[i] = ua[row, col], ub[row, col]
            leader[i], follower[i] = rows[R_ACT, row], cols[C_ACT, col]
        else:
            values_a[i] = values_b[i] = np.nan
    return values_a, values_b, leader, follower, settled


@njit(cache=True)
def level_games(states, keys, game, terminal, next_table, next_va, next_vb):
    """U^A, U^B of every state of a slice, flat (row-major per state), for the stage-game solvers:
    (m, n, matrix offsets, U^A, U^B, leader offsets, leader actions, follower offsets, follower actions)."""
    count = len(states)
    work = buffers(game, states.shape[1])
    ms, ns = np.empty(count, np.int64), np.empty(count, np.int64)
    for i in range(count):
        ms[i], ns[i] = _stage(states[i], game, work)
    offsets = np.zeros(count + 1, np.int64)
    offsets_a = np.zeros(count + 1, np.int64)
    offsets_b = np.zeros(count + 1, np.int64)
    for i in range(count):
        offsets[i + 1] = offsets[i] + ms[i] * ns[i]
        offsets_a[i + 1] = offsets_a[i] + ms[i]
        offsets_b[i + 1] = offsets_b[i] + ns[i]
    flat_a, flat_b = np.empty(offsets[count]), np.empty(offsets[count])
    acts_a, acts_b = np.empty(offsets_a[count], np.int64), np.empty(offsets_b[count], np.int64)
    rows, cols, ua, ub = work[2], work[4], work[6], work[7]
    for i in range(count):
        m, n, _ = _state_game(states[i], keys[i], game, terminal, next_table, next_va, next_vb, work)
        for r in range(m):
            acts_a[offsets_a[i] + r] = rows[R_ACT, r]
            for c in range(n):
                flat_a[offsets[i] + r * n + c] = ua[r, c]
                flat_b[offsets[i] + r * n + c] = ub[r, c]
        for c in range(n):
            acts_b[offsets_b[i] + c] = cols[C_ACT, c]
    return ms, ns, offsets, flat_a, flat_b, offsets_a, acts_a, offsets_b, acts_b


# --- forward prediction --------------------------------------------------------------------------

@njit(cache=True)
def expand_level(states, keys, game, materialise):
    """S_{t+1} from S_t: (states, keys, hash table); without ``materialise``
    only the keys (to count |S_T|; the states array is then empty)."""
    count, dim = states.shape
    lint, lkey, fint, fkey = game[6], game[8], game[9], game[11]
    capacity = max(64, 8 * count)
    new_states = np.empty((capacity if materialise else 0, dim), np.int64)
    new_keys = np.empty(capacity, np.uint64)
    table = _empty_table(capacity)
    size = 0
    work = buffers(game, dim)
    rows, cols = work[2], work[4]
    cap = game[1][CAPACITY]
    for i in range(count):
        state, key = states[i], keys[i]
        m, n = _stage(state, game, work)
        if size + 1 + m + n + m * n > capacity:   # grow the level and its table
            while size + 1 + m + n + m * n > capacity:
                capacity *= 2
            grown_keys = np.empty(capacity, np.uint64)
            grown_keys[:size] = new_keys[:size]
            new_keys = grown_keys
            if materialise:
                grown = np.empty((capacity, dim), np.int64)
                grown[:size] = new_states[:size]
                new_states = grown
            table = _empty_table(capacity)
            for row in range(size):
                _table_insert(table, new_keys[row], row)
        # Outcomes: (0, 0) once (row and column -1), (a^A, 0) per row, (0, a^B) per column, (a^A, a^B)
        # per pair; a blocked follower move is his empty action, so its pair is skipped (the state of
        # (a^A, 0)), as are the empty actions' row 0 and column 0 (the states of row and column -1).
        c_act, c_take, c_held = cols[C_ACT], cols[C_TAKE], cols[C_HELD]
        c_target, c_dst_total, c_blocked = cols[C_TARGET], cols[C_TARGET_TOTAL], cols[C_BLOCKED]
        for r in range(-1, m):
            if r == 0:
                continue
            a, take, put, source, target = 0, -1, -1, -1, -1
            if r > 0:
                a, take, put, source, target = rows[R_ACT, r], rows[R_TAKE, r], rows[R_PUT, r], \
                    rows[R_SOURCE, r], rows[R_TARGET, r]
            for col in range(-1, n):
                b = 0
                if col == 0:
                    continue
                if col > 0:
                    if r < 0:
                        if c_blocked[col] != 0:
                            continue
                    else:   # his move after hers: the object must be there and his target not full
                        tb, db = c_take[col], c_target[col]
                        if c_held[col] + (1 if put == tb else 0) - (1 if take == tb else 0) <= 0:
                            continue
                        if c_dst_total[col] + (1 if target == db else 0) - (1 if source == db else 0) >= cap:
                            continue
                    b = c_act[col]
                successor = key + lkey[a] + fkey[b]
                if _table_insert(table, successor, size) != NO_ROW:
                    continue
                new_keys[size] = successor
                if materialise:
                    for d in range(dim):
                        new_states[size, d] = state[d]
                    if a != 0:
                        new_states[size, lint[TAKE, a]] -= 1
                        new_states[size, lint[PUT, a]] += 1
                    if b != 0:
                        new_states[size, fint[TAKE, b]] -= 1
                        new_states[size, fint[PUT, b]] += 1
                size += 1
    return new_states[:size].copy() if materialise else new_states, new_keys[:size].copy(), table
