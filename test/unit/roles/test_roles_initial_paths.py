"""Initial process roles: straight line and E-Map polyline, evenly timed states [x, y, vx, vy]."""
import math

import numpy as np
import pytest

from role_engine.core.astar import EMapPlanner
from role_engine.core.emap import build_emap
from role_engine.core.environment import RobotType, load_map_file
from role_engine.core.errors import RoleEngineError
from role_engine.core.initial_paths import (
    InfeasiblePathError, emap_trajectory, polyline_trajectory, state_times, straight_line_trajectory)

from roles_map_helpers import MAPS_DIR, cell_centre, environment, two_rooms


def test_straight_line_has_constant_velocity_and_even_spacing():
    states = straight_line_trajectory((0.0, 0.0), (3.0, 4.0), total_time=10.0, num_intervals=5)
    assert states.shape == (6, 4)
    assert states[:, :2] == pytest.approx(np.outer(np.linspace(0, 1, 6), [3.0, 4.0]))
    assert states[:, 2:] == pytest.approx(np.tile([0.3, 0.4], (6, 1)))


def test_polyline_states_are_evenly_spaced_along_the_path():
    waypoints = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    states = polyline_trajectory(waypoints, total_time=4.0, num_intervals=8)
    assert states[0, :2] == pytest.approx([0, 0]) and states[-1, :2] == pytest.approx([2, 2])
    assert states[4, :2] == pytest.approx([2.0, 0.0])          # the corner at half the length
    steps = np.hypot(*np.diff(states[:, :2], axis=0).T)
    assert steps == pytest.approx(np.full(8, 0.5))
    on_first = states[:5, 1] == pytest.approx(0.0)
    on_second = states[4:, 0] == pytest.approx(2.0)
    assert on_first and on_second


def test_velocities_are_consistent_with_the_spacing():
    waypoints = np.array([[0.0, 0.0], [1.0, 0.5], [1.5, 2.0], [-0.5, 2.5]])
    total_time, n = 6.0, 30
    states = polyline_trajectory(waypoints, total_time, n)
    dt = total_time / n
    positions = states[:, :2]
    assert states[1:-1, 2:] == pytest.approx((positions[2:] - positions[:-2]) / (2 * dt))
    assert states[0, 2:] == pytest.approx((positions[1] - positions[0]) / dt)
    assert states[-1, 2:] == pytest.approx((positions[-1] - positions[-2]) / dt)
    speed = np.hypot(*states[:, 2:].T)
    length = np.sum(np.hypot(*np.diff(waypoints, axis=0).T))
    assert np.median(speed) == pytest.approx(length / total_time)


def test_zero_length_path_stays_put():
    states = straight_line_trajectory((1.0, 2.0), (1.0, 2.0), 5.0, 4)
    assert states[:, :2] == pytest.approx(np.tile([1.0, 2.0], (5, 1)))
    assert states[:, 2:] == pytest.approx(np.zeros((5, 2)))


def test_state_times():
    assert state_times(2.0, 4) == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0])


@pytest.mark.parametrize('kwargs, message', [
    ({'total_time': 0.0}, 'total_time'),
    ({'total_time': math.inf}, 'total_time'),
    ({'num_intervals': 0}, 'num_intervals'),
    ({'num_intervals': 2.5}, 'num_intervals'),
])
def test_bad_timing_is_rejected(kwargs, message):
    arguments = {'total_time': 1.0, 'num_intervals': 4, **kwargs}
    with pytest.raises(RoleEngineError, match=message):
        straight_line_trajectory((0, 0), (1, 1), **arguments)


def test_bad_waypoints_are_rejected():
    with pytest.raises(RoleEngineError, match='waypoints'):
        polyline_trajectory(np.zeros((3, 3)), 1.0, 4)
    with pytest.raises(RoleEngineError, match='finite'):
        polyline_trajectory(np.array([[0.0, 0.0], [np.nan, 1.0]]), 1.0, 4)


def test_emap_initialisation_avoids_the_obstacles_the_straight_line_hits():
    env = load_map_file(MAPS_DIR / 'env_5.yaml')                  # two rooms and a hallway
    robot = env.for_robot(RobotType('large', 0.1))
    planner = EMapPlanner(build_emap(robot))
    start, goal = (-2.0, -1.8), (2.0, 1.8)
    states, path = emap_trajectory(planner, start, goal, total_time=10.0, num_intervals=60)
    assert states.shape == (61, 4)
    assert states[0, :2] == pytest.approx(start) and states[-1, :2] == pytest.approx(goal)
    # Every state of the E-Map path keeps the robot's disc free; the straight line does not.
    assert robot.sdf.distance(states[:, :2]).min() > 0.0
    straight = straight_line_trajectory(start, goal, 10.0, 60)
    assert robot.sdf.distance(straight[:, :2]).min() < -0.3
    assert path.length > math.dist(start, goal)


def test_unreachable_goal_raises_infeasible_path_error():
    planner = EMapPlanner(build_emap(environment(two_rooms(door_cells=2)).for_robot(RobotType('r', 0.1))))
    with pytest.raises(InfeasiblePathError, match='separate free regions'):
        emap_trajectory(planner, cell_centre(20, 10), cell_centre(20, 50), 5.0, 10)
