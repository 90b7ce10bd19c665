"""Group Role Assignment (Hungarian) on known matrices, infeasibility reports, nearest neighbour."""
import itertools
import math

import numpy as np
import pytest

from role_engine.core.assignment import group_role_assignment, nearest_neighbour_assignment
from role_engine.core.errors import RoleEngineError

INF = math.inf


def brute_force(q: np.ndarray) -> float:
    """Minimum total cost over every way of giving each role a distinct agent."""
    m, n = q.shape
    best = INF
    for agents in itertools.permutations(range(m), n):
        best = min(best, sum(q[a, r] for r, a in enumerate(agents)))
    return best


def test_known_three_by_three():
    q = np.array([[4.0, 1.0, 3.0], [2.0, 0.0, 5.0], [3.0, 2.0, 2.0]])
    result = group_role_assignment(q)
    assert result.feasible and result.total_cost == 5.0
    assert result.pairs == [(0, 1), (1, 0), (2, 2)]
    assert result.assignment.tolist() == [[0, 1, 0], [1, 0, 0], [0, 0, 1]]
    assert result.role_of_agent.tolist() == [1, 0, 2]


def test_paper_table_two_shape():
    # Costs built so the optimum is Table II: a1->r3, a2->r1, a3->r2, a4->r4.
    q = np.full((4, 4), 5.0)
    for agent, role in [(0, 2), (1, 0), (2, 1), (3, 3)]:
        q[agent, role] = 1.0
    q[0, 0] = 0.5                  # a greedy pick for a1 that would block a2
    result = group_role_assignment(q)
    assert result.assignment.tolist() == [[0, 0, 1, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]]


@pytest.mark.parametrize('m, n', [(4, 4), (6, 6), (6, 4), (7, 3)])
def test_matches_brute_force_on_random_matrices(m, n):
    rng = np.random.default_rng(m * 10 + n)
    for _ in range(5):
        q = rng.uniform(0.0, 10.0, size=(m, n))
        q[rng.uniform(size=(m, n)) < 0.2] = INF
        expected = brute_force(q)
        result = group_role_assignment(q)
        if math.isinf(expected):
            assert not result.feasible and result.reason
        else:
            assert result.feasible and result.total_cost == pytest.approx(expected)
            assert result.assignment.sum(axis=0).tolist() == [1] * n
            assert result.assignment.sum(axis=1).max() <= 1


def test_more_agents_than_roles_leaves_the_costliest_idle():
    q = np.array([[1.0, 9.0], [9.0, 1.0], [5.0, 5.0]])
    result = group_role_assignment(q, agent_names=['a', 'b', 'c'])
    assert result.feasible and result.total_cost == 2.0
    assert result.unassigned_agents == [2]


def test_infinite_entries_force_the_assignment():
    q = np.array([[1.0, INF], [0.0, 10.0]])
    result = group_role_assignment(q)
    assert result.feasible and result.pairs == [(0, 0), (1, 1)] and result.total_cost == 11.0


def test_role_nobody_can_play_is_reported_by_name():
    q = np.array([[1.0, INF], [2.0, INF]])
    result = group_role_assignment(q, role_names=['north', 'pocket'])
    assert not result.feasible and math.isinf(result.total_cost)
    assert 'pocket' in result.reason and 'north' not in result.reason
    assert result.assignment.sum() == 0 and result.role_of_agent.tolist() == [-1, -1]


def test_roles_sharing_one_qualified_agent_are_reported():
    q = np.array([[1.0, 2.0, 3.0], [INF, INF, 4.0], [INF, INF, 5.0]])
    result = group_role_assignment(q, agent_names=['big', 's1', 's2'], role_names=['r1', 'r2', 'r3'])
    assert not result.feasible
    assert 'r1, r2' in result.reason and 'only big (1)' in result.reason


def test_more_roles_than_agents_is_not_workable():
    result = group_role_assignment(np.ones((2, 3)))
    assert not result.feasible and '3 role positions need more agents than the 2 available' in result.reason


def test_role_requirements_repeat_roles():
    q = np.array([[1.0, 5.0], [2.0, 5.0], [3.0, 1.0], [9.0, 9.0]])
    result = group_role_assignment(q, role_requirements=np.array([2, 1]))
    assert result.feasible and result.total_cost == 4.0
    assert result.assignment.sum(axis=0).tolist() == [2, 1]
    assert group_role_assignment(q, role_requirements=np.array([0, 0])).pairs == []
    with pytest.raises(RoleEngineError, match='L: must be 2 integers'):
        group_role_assignment(q, role_requirements=np.array([1.5, 1.0]))


@pytest.mark.parametrize('q, message', [
    (np.array([[1.0, np.nan]]), r'Q\[0, 1\]: must be a finite cost or \+inf'),
    (np.array([[1.0], [-INF]]), r'Q\[1, 0\]'),
    (np.zeros((0, 3)), 'at least one agent'),
    (np.zeros(3), '2-D'),
])
def test_malformed_matrices_raise(q, message):
    with pytest.raises(RoleEngineError, match=message):
        group_role_assignment(q)


def test_names_must_match_the_matrix():
    with pytest.raises(RoleEngineError, match='expected 2 names'):
        group_role_assignment(np.ones((2, 2)), agent_names=['a'])


def test_nearest_neighbour_is_greedy_and_can_be_worse_than_gra():
    sources = np.array([[0.0, 0.0], [2.0, 0.0]])
    destinations = np.array([[1.0, 0.0], [-2.5, 0.0]])
    nn = nearest_neighbour_assignment(sources, destinations)
    # The closest pair (either robot, 1 m) goes first; robot 0 wins the tie (stable order).
    assert nn.pairs == [(0, 0), (1, 1)] and nn.total_cost == pytest.approx(5.5)
    distance = np.linalg.norm(sources[:, None] - destinations[None], axis=2)
    gra = group_role_assignment(distance)
    assert gra.pairs == [(0, 1), (1, 0)] and gra.total_cost == pytest.approx(3.5)


def test_nearest_neighbour_reads_costs_from_q_and_reports_infeasible_pairs():
    sources = np.array([[0.0, 0.0], [5.0, 0.0]])
    destinations = np.array([[0.5, 0.0], [5.5, 0.0]])
    q = np.array([[INF, 3.0], [2.0, 7.0]])
    nn = nearest_neighbour_assignment(sources, destinations, q)
    assert not nn.feasible and 'agent0 with role0' in nn.reason
    ok = nearest_neighbour_assignment(sources, destinations, np.array([[1.0, 3.0], [2.0, 7.0]]))
    assert ok.feasible and ok.total_cost == 8.0
    more = nearest_neighbour_assignment(sources[:1], destinations)
    assert not more.feasible and 'more robots' in more.reason
    with pytest.raises(RoleEngineError, match='sources'):
        nearest_neighbour_assignment(np.zeros((2, 3)), destinations)
    with pytest.raises(RoleEngineError, match=r'Q: must have shape \(2, 2\)'):
        nearest_neighbour_assignment(sources, destinations, np.ones((2, 3)))
