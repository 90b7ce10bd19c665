"""Qualification Q = lambda F_gp + F_conf (Eq. 13-15) and the central role plan (Algorithms 1-3)."""
import math

import numpy as np
import pytest

from role_engine.core.central import plan_roles
from role_engine.core.environment import Environment, RobotType, load_map_file
from role_engine.core.errors import RoleEngineError
from role_engine.core.initial_paths import straight_line_trajectory
from role_engine.core.negotiation import Agent, Role, negotiate_roles
from role_engine.core.qualification import (
    ProcessRoleEvaluation, conflict_cost, hinge_cost, path_length_evaluator, qualification_matrix)
from role_engine.core.sdf import SignedDistanceField

from roles_map_helpers import MAPS_DIR

SMALL = RobotType('small', 0.02)
LARGE = RobotType('large', 0.1)


def wall_sdf() -> SignedDistanceField:
    """A 4 x 2 m open field (0.05 m cells) with a wall x in [1.9, 2.1] m across it."""
    grid = np.zeros((40, 80), dtype=bool)
    grid[:, 38:42] = True
    return SignedDistanceField.from_occupancy(grid, 0.05, (0.0, 0.0))


def test_hinge_cost_eq21():
    assert hinge_cost(np.array([-0.1, 0.0, 0.05, 0.2, 0.3]), 0.2) == pytest.approx([0.3, 0.2, 0.15, 0.0, 0.0])


def test_conflict_cost_is_zero_in_the_clear_and_grows_through_the_wall():
    sdf = wall_sdf()
    clear = straight_line_trajectory((0.2, 1.0), (1.4, 1.0), 5.0, 10)
    through = straight_line_trajectory((0.2, 1.0), (3.8, 1.0), 5.0, 10)
    assert conflict_cost(clear, 5.0, sdf, epsilon=0.2) == 0.0
    cost = conflict_cost(through, 5.0, sdf, epsilon=0.2)
    # Arc-length integral of the hinge across the wall: c rises linearly to 0.3 at its middle
    # from 0 at 0.2 m before it, over 0.3 m each side -> 2 * 0.3 * 0.3 / 2 = 0.09.
    assert cost == pytest.approx(0.09, rel=0.05)
    # Twice as fast along the same path: the same arc-length integral.
    assert conflict_cost(through, 5.0, sdf, 0.2) == pytest.approx(
        conflict_cost(straight_line_trajectory((0.2, 1.0), (3.8, 1.0), 2.5, 10), 2.5, sdf, 0.2))
    assert conflict_cost(through, 5.0, sdf, 0.2, body_radius=0.1) > cost


def test_conflict_cost_checks_its_arguments():
    states = straight_line_trajectory((0, 0), (1, 1), 1.0, 2)
    with pytest.raises(RoleEngineError, match='epsilon'):
        conflict_cost(states, 1.0, wall_sdf(), -0.1)
    with pytest.raises(RoleEngineError, match='trajectory'):
        conflict_cost(states[:, :3], 1.0, wall_sdf(), 0.1)


def test_negotiation_builds_one_view_per_type_and_finds_unreachable_pairs():
    env = load_map_file(MAPS_DIR / 'env_6.yaml')
    agents = [Agent('s1', SMALL, (-2.2, -2.2)), Agent('l1', LARGE, (2.2, -2.2)), Agent('s2', SMALL, (2.2, 2.2))]
    roles = [Role('a', (0.0, -0.8)), Role('b', (-2.0, 0.5)), Role('pocket', (-2.3, 2.3))]
    result = negotiate_roles(agents, roles, env, total_time=8.0, num_intervals=20)
    assert set(result.robot_envs) == {'small', 'large'} and set(result.emaps) == {'small', 'large'}
    assert not result.feasible and len(result.reasons) == 1 and "role 'pocket'" in result.reasons[0]
    reachable = result.reachable()
    assert reachable[:, :2].all() and not reachable[:, 2].any()
    for (i, j), states in result.initial_trajectories.items():
        assert states.shape == (21, 4)
        assert states[0, :2] == pytest.approx(agents[i].position)
        assert states[-1, :2] == pytest.approx(roles[j].destination)


def test_qualification_matrix_combines_prior_and_conflict_eq13():
    env = load_map_file(MAPS_DIR / 'env_1.yaml')
    agents = [Agent('s1', SMALL, (-2.2, -2.2)), Agent('l1', LARGE, (2.2, 2.2))]
    roles = [Role('a', (-2.2, 2.2)), Role('b', (2.2, -2.2))]
    negotiation = negotiate_roles(agents, roles, env, total_time=10.0, num_intervals=30)
    calls = []

    def evaluate(agent, role, trajectory, robot_env):
        calls.append((agent.name, role.name, robot_env.robot_type.name))
        return ProcessRoleEvaluation(trajectory, 2.0)

    result = qualification_matrix(negotiation, evaluate=evaluate, lam=3.0, epsilon=0.05)
    assert sorted(calls) == [('l1', 'a', 'large'), ('l1', 'b', 'large'), ('s1', 'a', 'small'), ('s1', 'b', 'small')]
    assert result.prior == pytest.approx(np.full((2, 2), 2.0))
    assert result.q == pytest.approx(3.0 * result.prior + result.conflict)
    assert (result.conflict >= 0).all()
    # The default stand-in F_gp is the path length.
    lengths = qualification_matrix(negotiation, lam=1.0, epsilon=0.0)
    assert lengths.q[0, 0] == pytest.approx(negotiation.paths[(0, 0)].length)


def test_plan_roles_assigns_by_gra():
    env = load_map_file(MAPS_DIR / 'env_1.yaml')
    agents = [Agent('s1', SMALL, (-2.2, -2.2)), Agent('l1', LARGE, (2.2, 2.2)), Agent('l2', LARGE, (2.2, -2.2))]
    roles = [Role('sw', (-2.0, -2.0)), Role('ne', (2.0, 2.0))]
    plan = plan_roles(agents, roles, env, total_time=10.0, num_intervals=20)
    assert plan.feasible and plan.reason == ''
    assert {name: role for name, (role, _) in plan.process_roles.items()} == {'s1': 'sw', 'l1': 'ne'}
    states = plan.process_roles['l1'][1]
    assert states[0, :2] == pytest.approx((2.2, 2.2)) and states[-1, :2] == pytest.approx((2.0, 2.0))
    assert plan.assignment.unassigned_agents == [2]


def test_plan_roles_reports_infeasibility_instead_of_failing():
    env = load_map_file(MAPS_DIR / 'env_2.yaml')     # the 0.15 m door passes small robots only
    agents = [Agent('l1', LARGE, (-1.0, 2.2)), Agent('s1', SMALL, (-1.0, -2.0))]
    roles = [Role('east_1', (1.0, 2.2)), Role('east_2', (1.0, 0.4))]
    # Block the wide door for everyone: then only small robots cross.
    blocked = env.occupied.copy()
    rows, cols = np.nonzero(~blocked)
    x = env.origin[0] + (cols + 0.5) * env.resolution
    y = env.origin[1] + (rows + 0.5) * env.resolution
    blocked[rows[(np.abs(x) < 0.1) & (y < -0.5)], cols[(np.abs(x) < 0.1) & (y < -0.5)]] = True
    closed = Environment(blocked, env.resolution, env.origin)
    plan = plan_roles(agents, roles, closed, total_time=10.0, num_intervals=20)
    assert not plan.feasible and plan.process_roles == {}
    assert 'not workable' in plan.reason and 'only s1' in plan.reason
    too_many_roles = plan_roles(agents[:1], roles, env, total_time=10.0, num_intervals=20)
    assert not too_many_roles.feasible and 'more agents than the 1 available' in too_many_roles.reason


def test_straight_line_negotiation_skips_the_emap():
    env = load_map_file(MAPS_DIR / 'env_5.yaml')
    agents = [Agent('l1', LARGE, (-2.0, -1.8))]
    roles = [Role('r', (2.0, 1.8))]
    result = negotiate_roles(agents, roles, env, total_time=5.0, num_intervals=10, use_emap=False)
    assert result.feasible and result.emaps == {}
    assert result.paths[(0, 0)].length == pytest.approx(math.dist((-2.0, -1.8), (2.0, 1.8)))
    straight = qualification_matrix(result, epsilon=0.05)
    assert straight.conflict[0, 0] > 0.1        # the straight line runs through the walls


@pytest.mark.parametrize('agents, roles, message', [
    ([], [Role('r', (0, 0))], 'at least one agent'),
    ([Agent('a', SMALL, (0, 0))], [], 'at least one role'),
    ([Agent('a', SMALL, (0, 0)), Agent('a', SMALL, (1, 0))], [Role('r', (0, 0))], 'repeated: a'),
    ([Agent('a', SMALL, (0, 0)), Agent('b', RobotType('small', 0.05), (1, 0))], [Role('r', (0, 0))],
     "two different definitions of type 'small'"),
    ([Agent('a', SMALL, (0, math.nan))], [Role('r', (0, 0))], r'agents\[0\].position'),
    ([Agent('a', SMALL, (0, 0))], [Role('r', (0, 0, 1))], r'roles\[0\].destination'),
])
def test_bad_negotiation_inputs_raise(agents, roles, message):
    env = load_map_file(MAPS_DIR / 'env_1.yaml')
    with pytest.raises(RoleEngineError, match=message):
        negotiate_roles(agents, roles, env, total_time=5.0, num_intervals=10)


def test_path_length_evaluator():
    states = straight_line_trajectory((0, 0), (3, 4), 1.0, 5)
    evaluation = path_length_evaluator(None, None, states, None)
    assert evaluation.prior_cost == pytest.approx(5.0) and evaluation.trajectory is not None
