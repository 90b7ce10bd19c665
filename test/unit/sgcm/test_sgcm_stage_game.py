"""Stage games (Q_t^A)/(Q_t^B): hand-solved games, MILP vs fast method, big-M."""
import numpy as np
import pytest

from sgcm.core import stage_game
from sgcm.core.stage_game import big_m, solve_fast, solve_milp

from sgcm_reference import reference_sse

SOLVERS = pytest.mark.parametrize('solve', [solve_fast, solve_milp], ids=['fast', 'milp'])


def assert_solution(solution, policy, follower_action, leader_value, follower_value, atol=1e-6):
    np.testing.assert_allclose(solution.leader_policy, policy, atol=atol)
    assert solution.follower_action == follower_action
    assert solution.leader_value == pytest.approx(leader_value, abs=atol)
    assert solution.follower_value == pytest.approx(follower_value, abs=atol)


def pure_nash_equilibria(ua, ub):
    ua, ub = np.asarray(ua, float), np.asarray(ub, float)
    return {(a, b) for a in range(ua.shape[0]) for b in range(ua.shape[1])
            if ua[a, b] >= ua[:, b].max() and ub[a, b] >= ub[a, :].max()}


# --- hand-solved games ------------------------------------------------------------------

@SOLVERS
def test_classic_game_needs_a_mixed_commitment(solve):
    # U^A = [[2,4],[1,3]], U^B = [[1,0],[0,1]]; the leader commits to x = (p, 1-p).
    # Follower: column 0 pays p, column 1 pays 1-p, so column 1 is a best response iff p <= 1/2.
    #   column 1: leader gets 4p + 3(1-p) = 3 + p, best at p = 1/2 -> 3.5 (follower indifferent
    #             there; the strong equilibrium breaks the tie for the leader), follower 1 - p = 0.5;
    #   column 0 (p >= 1/2): leader gets 2p + (1-p) = 1 + p <= 2.
    # So x = (0.5, 0.5), follower column 1, values 3.5 and 0.5; any pure commitment gets at most 3.
    ua, ub = [[2, 4], [1, 3]], [[1, 0], [0, 1]]
    solution = solve(ua, ub)
    assert_solution(solution, [0.5, 0.5], 1, 3.5, 0.5)


@SOLVERS
def test_commitment_differs_from_the_nash_outcome(solve):
    # U^A = [[2,4],[1,3]]: row 0 strictly dominates row 1 for the leader, and at row 0 the follower
    # strictly prefers column 0 (1 > 0), so the simultaneous game has the single Nash equilibrium
    # (row 0, column 0) with values (2, 1).
    # Commitment: column 1 is a best response iff 0 >= p, i.e. only to pure row 1, where the
    # follower is indifferent (0 = 0) and breaks the tie for the leader: the leader gets 3 > 2.
    # (With a strict follower at the committed row, a pure Stackelberg commitment is always a
    # Nash equilibrium too, so the difference needs this indifference.)
    ua, ub = [[2, 4], [1, 3]], [[1, 0], [0, 0]]
    assert pure_nash_equilibria(ua, ub) == {(0, 0)}
    solution = solve(ua, ub)
    assert_solution(solution, [0.0, 1.0], 1, 3.0, 0.0)
    assert solution.leader_action == 1
    assert solution.leader_value > np.asarray(ua)[0, 0]


@SOLVERS
def test_cooperative_game_gives_the_largest_entry(solve):
    # U^A = U^B: committing to the row of the largest entry makes its column the follower's
    # strict best response (7 > 3, 7 > 0); no commitment can give either robot more than 7.
    u = [[1, 5, 2], [7, 3, 0], [4, 4, 6]]
    assert_solution(solve(u, u), [0, 1, 0], 0, 7.0, 7.0)


@SOLVERS
def test_one_by_one_game(solve):
    # Nothing to choose: both play their only action.
    assert_solution(solve([[3.0]], [[-2.0]]), [1.0], 0, 3.0, -2.0)


@SOLVERS
def test_indifferent_follower_picks_the_leaders_favourite(solve):
    # One leader action; the follower is indifferent among his three actions (all pay 2), and the
    # strong equilibrium picks the one the leader likes best: column 1 (5 > 3 > 1).
    assert_solution(solve([[1, 5, 3]], [[2, 2, 2]]), [1.0], 1, 5.0, 2.0)


@SOLVERS
def test_equal_leader_values_prefer_the_higher_follower_value(solve):
    # U^A = [[3,0],[0,3]], U^B = [[1,0],[0,2]], x = (p, 1-p).
    # Column 0 is a best response iff p >= 2(1-p), i.e. p >= 2/3: leader 3p, best 3 at p = 1,
    #   follower 1.
    # Column 1 iff p <= 2/3: leader 3(1-p), best 3 at p = 0, follower 2.
    # Both commitments give the leader 3; secondary rule: the one better for the follower,
    # row 1 / column 1 (listed second, so the lowest-index rule alone would pick the other).
    assert_solution(solve([[3, 0], [0, 3]], [[1, 0], [0, 2]]), [0, 1], 1, 3.0, 2.0)


@SOLVERS
def test_equal_leader_values_across_rows_prefer_the_higher_follower_value(solve):
    # Single follower action; both rows give the leader 2, row 1 gives the follower 1 > 0.
    assert_solution(solve([[2], [2]], [[0], [1]]), [0, 1], 0, 2.0, 1.0)


@SOLVERS
def test_complete_tie_picks_the_lowest_follower_action_and_a_pure_row(solve):
    # Every commitment and response gives (2, 1): rule 2 picks column 0 and pure row 0.
    assert_solution(solve([[2, 2]], [[1, 1]]), [1], 0, 2.0, 1.0)
    assert_solution(solve([[2, 2, 2]], [[1, 1, 1]]), [1], 0, 2.0, 1.0)
    assert_solution(solve([[2, 2], [2, 2]], [[1, 1], [1, 1]]), [1, 0], 0, 2.0, 1.0)
    # A cooperative game with two equal maxima at (0,0) and (1,1): column 0 with pure row 0.
    assert_solution(solve([[7, 1], [0, 7]], [[7, 1], [0, 7]]), [1, 0], 0, 7.0, 7.0)


@SOLVERS
def test_invalid_matrices_are_rejected(solve):
    with pytest.raises(ValueError, match='equal 2-D shape'):
        solve([[1, 2]], [[1], [2]])
    with pytest.raises(ValueError, match='non-empty'):
        solve(np.zeros((0, 2)), np.zeros((0, 2)))
    with pytest.raises(ValueError, match='finite'):
        solve([[1.0, np.nan]], [[0.0, 0.0]])


# --- MILP vs fast method on random games -------------------------------------------------

def random_games(count: int, seed: int = 20240):
    """Games of sizes 1..7 x 1..7 of several kinds; the small integer ranges make many ties."""
    rng = np.random.default_rng(seed)
    for index in range(count):
        m, n = (int(v) for v in rng.integers(1, 8, size=2))
        kind = index % 6
        if kind == 0:      # small integer payoffs
            ua, ub = rng.integers(-3, 4, size=(2, m, n)).astype(float)
        elif kind == 1:    # very few distinct values: ties everywhere
            ua, ub = rng.integers(0, 2, size=(2, m, n)).astype(float)
        elif kind == 2:    # cooperative
            ua = rng.integers(-5, 6, size=(m, n)).astype(float)
            ub = ua.copy()
        elif kind == 3:    # continuous payoffs
            ua, ub = rng.normal(scale=10.0, size=(2, m, n))
        elif kind == 4:    # a duplicated row and a duplicated column
            ua, ub = rng.integers(-2, 3, size=(2, m, n)).astype(float)
            ua, ub = (np.concatenate([u, u[[int(rng.integers(m))]]], axis=0) for u in (ua, ub))
            col = int(rng.integers(n))
            ua, ub = (np.concatenate([u, u[:, [col]]], axis=1) for u in (ua, ub))
            ua, ub = ua[:7, :7], ub[:7, :7]
        else:              # utilities shaped like the rearrangement game: team reward minus costs
            reward = rng.integers(0, 4, size=(m, n)).astype(float)
            ca = rng.integers(0, 2, size=(m, 1)).astype(float)
            cb = rng.integers(0, 2, size=(m, n)).astype(float)
            ua, ub = reward - ca - 0.5 * cb, reward - cb - 0.25 * ca
        yield ua, ub


def check_equilibrium_properties(ua, ub, solution):
    m, n = ua.shape
    x, j = solution.leader_policy, solution.follower_action
    assert x.shape == (m,) and 0 <= j < n
    assert (x >= -1e-9).all() and x.sum() == pytest.approx(1.0, abs=1e-9)
    assert solution.leader_value == pytest.approx(float(ua[:, j] @ x), abs=1e-6)
    assert solution.follower_value == pytest.approx(float(ub[:, j] @ x), abs=1e-6)
    # j is a follower best response to x
    assert float(ub[:, j] @ x) >= float((ub.T @ x).max()) - 1e-6
    # The leader can do at least as well as her best pure commitment (ties broken for her)
    # and never better than her best entry.
    pure = max(ua[a, ub[a] >= ub[a].max()].max() for a in range(m))
    assert pure - 1e-6 <= solution.leader_value <= ua.max() + 1e-6


def test_milp_and_fast_method_agree_on_random_games():
    games = list(random_games(240))
    ties = sum(1 for ua, ub in games if len(np.unique(ub)) < ub.size)
    assert ties >= 150  # most of the games have repeated follower payoffs
    for ua, ub in games:
        fast, exact = solve_fast(ua, ub), solve_milp(ua, ub)
        assert fast.leader_value == pytest.approx(exact.leader_value, abs=1e-6), (ua, ub)
        assert fast.follower_value == pytest.approx(exact.follower_value, abs=1e-6), (ua, ub)
        # Rule 2 (lowest follower action) makes the recommended action solver-independent.
        assert fast.follower_action == exact.follower_action, (ua, ub)
        check_equilibrium_properties(ua, ub, fast)
        check_equilibrium_properties(ua, ub, exact)
        if np.array_equal(ua, ub):
            assert fast.leader_value == pytest.approx(ua.max(), abs=1e-9)


def test_both_solvers_match_an_lp_enumeration_reference():
    for ua, ub in list(random_games(40, seed=77)):
        leader, follower = reference_sse(ua, ub)
        for solution in (solve_fast(ua, ub), solve_milp(ua, ub)):
            assert solution.leader_value == pytest.approx(leader, abs=1e-6), (ua, ub)
            assert solution.follower_value == pytest.approx(follower, abs=1e-6), (ua, ub)


def test_cooperative_games_need_no_linear_program():
    rng = np.random.default_rng(5)
    for _ in range(20):
        u = rng.integers(-4, 5, size=(6, 7)).astype(float)
        assert solve_fast(u, u).programs_solved == 0


# --- big-M --------------------------------------------------------------------------------

def test_big_m_is_the_follower_payoff_range_plus_slack():
    assert big_m(np.array([[1.0, -2.0], [4.0, 0.5]])) == pytest.approx(6.0 + 6e-6, rel=1e-12)
    assert big_m(np.array([[3.0, 3.0]])) == pytest.approx(1e-6, rel=1e-12)   # no spread: slack only
    assert big_m(np.array([[0.0], [0.25]])) == pytest.approx(0.25 + 1e-6, rel=1e-12)
    assert big_m(np.array([[-1e4, 1e4]])) == pytest.approx(2e4 * (1 + 1e-6), rel=1e-12)


def test_big_m_reaches_every_feasible_gap():
    # lambda - U^B[:, k].x at the follower's best response is at most the payoff range.
    rng = np.random.default_rng(11)
    for _ in range(50):
        ub = rng.normal(size=(4, 5)) * 3
        x = rng.dirichlet(np.ones(4))
        payoffs = ub.T @ x
        assert (payoffs.max() - payoffs).max() <= big_m(ub)


def test_too_small_big_m_gives_a_wrong_equilibrium(monkeypatch):
    # The classic game plus a third follower action that is never a best response:
    #   U^A = [[2,4,0],[1,3,0]], U^B = [[1,0,-10],[0,1,0.5]], x = (p, 1-p).
    # Correct: as in the classic game, x = (1/2, 1/2), column 1, values 3.5 and 0.5 (column 2 pays
    # the follower 0.5 - 10.5p < max(p, 1-p)).
    # The MILP needs lambda - U^B[:,k].x <= M for the unchosen columns k. With column 1 chosen,
    # lambda = 1 - p and the gap to column 2 is 0.5 + 9.5p: M = 2 allows only p <= 3/19, where the
    # leader gets 3 + p = 3 + 3/19; column 0 (p >= 1/2, gap 11p - 0.5) is cut off entirely.
    # No pure row reaches that value with column 1 as a best response, so it stays wrong.
    ua = np.array([[2.0, 4.0, 0.0], [1.0, 3.0, 0.0]])
    ub = np.array([[1.0, 0.0, -10.0], [0.0, 1.0, 0.5]])
    assert big_m(ub) == pytest.approx(11.0, abs=1e-4)
    assert_solution(solve_milp(ua, ub), [0.5, 0.5], 1, 3.5, 0.5)
    assert_solution(solve_fast(ua, ub), [0.5, 0.5], 1, 3.5, 0.5)
    monkeypatch.setattr(stage_game, 'big_m', lambda payoffs: 2.0)
    assert_solution(solve_milp(ua, ub), [3 / 19, 16 / 19], 1, 3 + 3 / 19, 16 / 19)
    # The exact range (without the slack) is still large enough.
    monkeypatch.setattr(stage_game, 'big_m', lambda payoffs: float(payoffs.max() - payoffs.min()))
    assert_solution(solve_milp(ua, ub), [0.5, 0.5], 1, 3.5, 0.5)


def test_milp_model_uses_big_m_in_the_complementarity_rows():
    ua, ub = np.array([[5.0, 0.0], [1.0, 1.0]]), np.array([[10.0, 0.0], [1.0, 1.0]])
    matrix, lower, upper, integrality, bounds = stage_game._milp_model(ua, ub)
    m, n = ua.shape
    assert matrix.shape[1] == m * n + n + 1
    np.testing.assert_array_equal(integrality, [0] * (m * n) + [1] * n + [0])
    dense = matrix.toarray()
    pi_b = dense[:, m * n:m * n + n]
    # Rows  lambda - U^B[:,k].x + M pi^B_k <= M  carry M on pi^B_k and as their upper bound.
    rows = np.flatnonzero((np.abs(pi_b) > 0).any(axis=1) & np.isfinite(upper) & (upper > 1.0))
    assert len(rows) == n
    np.testing.assert_allclose(upper[rows], big_m(ub))
    np.testing.assert_allclose(np.abs(pi_b[rows]).sum(axis=1), big_m(ub))
