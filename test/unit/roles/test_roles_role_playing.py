"""The role-playing update (Algorithm 4): other robots as moving obstacles, head-on swaps pass.

Two robots swap ends of an open area or of a hallway; like the role players they re-plan
alternately (each against the other's latest role) once per second while following their
roles exactly. The distance between the roles actually followed must never fall below the
sum of the radii.
"""
import numpy as np
import pytest

from role_engine.core.conflict import SharedRole
from role_engine.core.environment import Environment, RobotType
from role_engine.core.gp_planner import GPPlanner, GPPlannerConfig
from role_engine.core.initial_paths import straight_line_trajectory
from role_engine.core.role_playing import (REJOIN_DISTANCE, AvoidanceSettings, moving_obstacle_terms, replan_process_role,
                                         role_gaps)

TOTAL_TIME = 20.0
STATES = 41
#: The settings of config/roles/formation_demo.yaml, with a 0.4 m/s speed limit.
CONFIG = dict(qc=1.0, sigma_obs=0.1, epsilon=0.1, lambda_initial=1000.0, max_iterations=50,
              relative_error_tol=1e-4, max_speed=0.4)


def open_area():
    """A 4 x 4 m free area (walls beyond its border)."""
    return Environment(np.zeros((80, 80), dtype=bool), 0.05, (-2.0, -2.0))


def hallway():
    """A 5 m long hallway 0.9 m wide along y = 0 (x in [-2.5, 2.5])."""
    grid = np.ones((40, 100), dtype=bool)
    grid[11:29, :] = False
    return Environment(grid, 0.05, (-2.5, -1.0))


def robot_type(name, radius):
    return RobotType(name, radius, inflation_margin=0.03, max_linear_velocity=0.5)


def swap(environment, ends_a, ends_b, radii, *, rounds=8, formulation='vectorised'):
    """Both robots re-plan alternately once per second for ``rounds`` s; returns the roles followed."""
    envs = [environment.for_robot(robot_type(f'type_{i}', r)) for i, r in enumerate(radii)]
    config = GPPlannerConfig(**CONFIG, formulation=formulation)
    roles = [SharedRole(name, straight_line_trajectory(*ends, TOTAL_TIME, STATES - 1), TOTAL_TIME, radius)
             for name, ends, radius in (('a', ends_a, radii[0]), ('b', ends_b, radii[1]))]
    followed, replans = [], []
    for second in range(rounds):
        for me in (0, 1):
            own, other = roles[me], roles[1 - me]
            result = replan_process_role(config, envs[me], own, [other], float(second),
                                         own.positions([second])[0], horizon=4.0)
            replans.append(result)
            if result.trajectory is not None:
                roles[me] = SharedRole(own.name, result.trajectory, result.total_time, own.radius, result.start_time)
        times = np.linspace(second, second + 1.0, 41)
        followed.append((times, roles[0].positions(times), roles[1].positions(times)))
    times = np.linspace(rounds, TOTAL_TIME + 1.0, 800)
    followed.append((times, roles[0].positions(times), roles[1].positions(times)))
    return roles, envs, followed, replans


def min_distance(followed):
    return min(float(np.min(np.hypot(*(a - b).T))) for _, a, b in followed)


def assert_reached(role, goal):
    np.testing.assert_allclose(role.positions([TOTAL_TIME + 1.0])[0], goal, atol=1e-3)


@pytest.mark.parametrize('radii', [(0.1, 0.1), (0.105, 0.23)])
def test_head_on_swap_in_an_open_area_passes_without_touching(radii):
    roles, envs, followed, replans = swap(open_area(), ((-1.5, 0.0), (1.5, 0.0)), ((1.5, 0.0), (-1.5, 0.0)), radii)
    distance = min_distance(followed)
    print(f'open area, radii {radii}: min distance between the roles followed {distance:.3f} m '
          f'(r_a + r_b = {sum(radii):.3f}); first plan from {replans[0].initialisation!r}')
    assert distance >= sum(radii)
    assert replans[0].initialisation.startswith('detour')             # the straight line was a saddle
    # The roles as finally published keep the gap at every common time, too.
    assert role_gaps(roles[0].trajectory, roles[0].start_time, roles[0].total_time, radii[0], [roles[1]])['b'] >= 0
    assert_reached(roles[0], (1.5, 0.0))
    assert_reached(roles[1], (-1.5, 0.0))


def test_head_on_swap_in_a_hallway_for_two_stays_inside_it():
    radii = (0.1, 0.1)
    roles, envs, followed, _ = swap(hallway(), ((-2.0, 0.0), (2.0, 0.0)), ((2.0, 0.0), (-2.0, 0.0)), radii)
    distance = min_distance(followed)
    print(f'hallway 0.9 m: min distance between the roles followed {distance:.3f} m (r_a + r_b = {sum(radii):.3f})')
    assert distance >= sum(radii)
    for (_, a, b), in zip([f for f in followed]):
        for env, positions in zip(envs, (a, b)):
            # Centres stay out of the inflated walls: the robots do not touch them.
            assert env.sdf.distance(positions).min() >= 0.0
    assert_reached(roles[0], (2.0, 0.0))
    assert_reached(roles[1], (-2.0, 0.0))


def test_without_a_conflict_the_role_is_essentially_unchanged():
    env = open_area().for_robot(robot_type('small', 0.1))
    config = GPPlannerConfig(**CONFIG)
    initial = straight_line_trajectory((-1.5, -1.0), (1.5, -1.0), TOTAL_TIME, STATES - 1)
    initial[[0, -1], 2:] = 0.0                                    # an already optimised role, at rest at both ends
    planned = GPPlanner(config, env.sdf).plan(initial, TOTAL_TIME).trajectory
    own = SharedRole('me', planned, TOTAL_TIME, 0.1)
    far = SharedRole('far', straight_line_trajectory((1.5, 1.5), (-1.5, 1.5), TOTAL_TIME, STATES - 1), TOTAL_TIME,
                     0.1)
    now = 5.0
    position = own.positions([now])[0]
    alone = replan_process_role(config, env, own, [], now, position, horizon=4.0)
    beside = replan_process_role(config, env, own, [far], now, position, horizon=4.0)
    assert beside.conflicting == [] and beside.initialisation == 'warm start' and beside.candidates == 1
    np.testing.assert_allclose(beside.trajectory, alone.trajectory, atol=1e-12)
    times = now + np.linspace(0.0, TOTAL_TIME - now, 200)
    moved = np.hypot(*(SharedRole('me', beside.trajectory, beside.total_time, 0.1, now).positions(times)
                       - own.positions(times)).T)
    print(f'no conflict: the re-planned role moved at most {moved.max() * 1000:.2f} mm')
    assert moved.max() < 5e-3
    assert beside.term_costs['robots'] == 0.0 and beside.term_costs['robots_interpolated'] == 0.0


def test_both_formulations_reach_the_same_cost_with_moving_obstacles():
    env = open_area().for_robot(robot_type('small', 0.1))
    own = SharedRole('a', straight_line_trajectory((-1.5, 0.0), (1.5, 0.0), TOTAL_TIME, 20), TOTAL_TIME, 0.1)
    other = SharedRole('b', straight_line_trajectory((1.5, 0.0), (-1.5, 0.0), TOTAL_TIME, 20), TOTAL_TIME, 0.1)
    results = {formulation: replan_process_role(GPPlannerConfig(**CONFIG, formulation=formulation), env, own,
                                                [other], 2.0, own.positions([2.0])[0], horizon=4.0,
                                                avoidance=AvoidanceSettings(detour_scales=(1.0,)))
               for formulation in ('vectorised', 'gtsam')}
    vectorised, graph = results['vectorised'], results['gtsam']
    assert vectorised.candidates == graph.candidates == 3
    assert vectorised.initialisation == graph.initialisation
    assert vectorised.cost == pytest.approx(graph.cost, rel=1e-6)
    np.testing.assert_allclose(vectorised.trajectory, graph.trajectory, atol=1e-5)
    assert vectorised.min_gap >= 0.0


def test_moving_obstacle_terms_compare_at_the_same_absolute_times():
    other = SharedRole('b', straight_line_trajectory((0.0, 0.0), (2.0, 0.0), 4.0, 4), 4.0, 0.2, start_time=10.0)
    support = 11.0 + np.array([0.0, 1.0, 2.0])                     # the other's role started 1 s earlier
    robots, between = moving_obstacle_terms(0.1, [other], support, AvoidanceSettings(interpolation=1))
    np.testing.assert_allclose(robots.positions, [[0.5, 0.0], [1.0, 0.0], [1.5, 0.0]], atol=1e-9)
    np.testing.assert_allclose(between.positions, [[0.75, 0.0], [1.25, 0.0]], atol=1e-9)
    assert robots.combined_radius == pytest.approx(0.3) and robots.epsilon == pytest.approx(0.1)


@pytest.mark.parametrize('data, message', [
    ({'clearance': -0.1}, 'settings.clearance'),
    ({'sigma': 0}, 'settings.sigma'),
    ({'interpolation': 1.5}, 'settings.interpolation'),
    ({'detour_scales': [1.0, -2.0]}, r'settings.detour_scales\[1\]'),
    ({'detour_scales': 2.0}, 'settings.detour_scales'),
    ({'speed': 1.0}, 'settings.speed'),
])
def test_avoidance_settings_name_the_bad_field(data, message):
    with pytest.raises(ValueError, match=message):
        AvoidanceSettings.from_mapping(data, 'settings')


def corner_corridor():
    """A corridor 0.6 m wide along y = 0 (x from -0.5) turning left at x = 1.0 into one along x = 1.0 (up)."""
    resolution, origin = 0.025, (-0.6, -0.6)
    iy, ix = np.mgrid[0:96, 0:96]
    x, y = origin[0] + (ix + 0.5) * resolution, origin[1] + (iy + 0.5) * resolution
    free = ((x > -0.5) & (x < 1.3) & (np.abs(y) < 0.3)) | ((np.abs(x - 1.0) < 0.3) & (y > -0.3) & (y < 1.75))
    return Environment(~free, resolution, origin)


def corner_role(speed=0.2, states=STATES):
    """The corridor's centre line round the bend (a quarter circle of 0.3 m about the inner corner)."""
    arc = np.pi * 0.3 / 2.0
    length = 2.0 + arc
    rows = []
    for k, s in enumerate(np.linspace(0.0, length, states)):
        if s <= 1.0:
            p, d = (-0.3 + s, 0.0), (1.0, 0.0)
        elif s <= 1.0 + arc:
            phi = (s - 1.0) / 0.3
            p, d = (0.7 + 0.3 * np.sin(phi), 0.3 - 0.3 * np.cos(phi)), (np.cos(phi), np.sin(phi))
        else:
            p, d = (1.0, 0.3 + s - 1.0 - arc), (0.0, 1.0)
        v = np.array(d) * speed if 0 < k < states - 1 else np.zeros(2)
        rows.append([*p, *v])
    return np.array(rows), length / speed


def test_a_lagging_robot_replans_from_where_it_is_along_its_role():
    """The role's clock is round the bend, the robot 0.3 m short of it: the re-planned role starts along
    the corridor the robot is in (not towards the clock's point across the inner corner), keeps the
    planned timing from there, and its body stays clear of the corner."""
    env = corner_corridor().for_robot(RobotType('r', 0.2, inflation_margin=0.03, max_linear_velocity=0.5))
    states, total = corner_role()
    own = SharedRole('a', states, total, 0.2)
    clock = 6.0                                    # s: the clock's point is 1.2 m along, on the bend
    position = own.positions([clock - 1.5])[0]     # the robot: 0.9 m along, still in the straight part
    assert position[1] == pytest.approx(0.0, abs=1e-3) and position[0] == pytest.approx(0.6, abs=1e-3)
    result = replan_process_role(GPPlannerConfig(**CONFIG), env, own, [], clock, position, horizon=4.0)
    assert result.trajectory is not None
    assert result.total_time == pytest.approx(total - (clock - 1.5), abs=0.05)
    start_velocity = result.trajectory[0, 2:]
    assert start_velocity[0] == pytest.approx(0.2, abs=0.02) and abs(start_velocity[1]) < 0.02
    times = np.linspace(0.0, result.total_time, 400)
    path = SharedRole('a', result.trajectory, result.total_time, 0.2).positions(times)
    assert env.sdf.distance(path).min() > 0.0      # the body (radius + margin) never touches the corner


def test_a_robot_near_its_role_replans_the_role_not_its_tracking_error():
    """Within REJOIN_DISTANCE of its role the re-planned rest starts on the role (the controller closes
    the gap), so re-plans do not bend the role towards every tracking error; farther off it starts
    from the robot."""
    env = corner_corridor().for_robot(RobotType('r', 0.2, inflation_margin=0.03, max_linear_velocity=0.5))
    states, total = corner_role()
    own = SharedRole('a', states, total, 0.2)
    on_role = own.positions([2.0])[0]
    near = on_role + np.array([0.0, 0.06])          # 6 cm off the centre line, inside the corridor
    result = replan_process_role(GPPlannerConfig(**CONFIG), env, own, [], 2.0, near, horizon=4.0)
    assert np.allclose(result.trajectory[0, :2], on_role, atol=0.01)
    assert REJOIN_DISTANCE < 0.2
    far = on_role + np.array([0.0, REJOIN_DISTANCE + 0.02])
    result = replan_process_role(GPPlannerConfig(**CONFIG), env, own, [], 2.0, far, horizon=4.0)
    assert np.allclose(result.trajectory[0, :2], far, atol=1e-6)



def test_with_another_robot_in_conflict_the_replan_starts_where_the_robot_is():
    """The role is what the others plan around: with a conflicting robot it starts at the robot's
    true position even when the robot is only a few cm off its role."""
    env = corner_corridor().for_robot(RobotType('r', 0.2, inflation_margin=0.03, max_linear_velocity=0.5))
    states, total = corner_role()
    own = SharedRole('a', states, total, 0.2)
    near = own.positions([2.0])[0] + np.array([0.0, 0.06])
    oncoming = SharedRole('b', np.array([[1.0, 0.0, -0.2, 0.0], [-0.3, 0.0, -0.2, 0.0]]), 6.5, 0.1, 1.0)
    result = replan_process_role(GPPlannerConfig(**CONFIG), env, own, [oncoming], 2.0, near, horizon=4.0)
    assert result.conflicting == ['b']
    assert np.allclose(result.trajectory[0, :2], near, atol=1e-6)
