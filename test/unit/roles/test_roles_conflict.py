"""Conflict field among time-indexed process roles (Fig. 5)."""
import numpy as np
import pytest

from role_engine.core.conflict import SharedRole, make_conflict_field
from role_engine.core.environment import RobotType
from role_engine.core.errors import RoleEngineError
from role_engine.core.initial_paths import straight_line_trajectory

from roles_map_helpers import empty_grid, environment

ROBOT = RobotType('r', 0.1)


def hallway_roles():
    """Two robots swapping ends of a 2 m long corridor along y = 1 in 10 s (40 x 40 grid, 0.05 m)."""
    east = straight_line_trajectory((0.2, 1.0), (1.8, 1.0), 10.0, 20)
    west = straight_line_trajectory((1.8, 1.0), (0.2, 1.0), 10.0, 20)
    return SharedRole('east', east, 10.0, 0.1), SharedRole('west', west, 10.0, 0.1)


def test_conflict_area_is_where_the_other_will_be_when_roles_meet():
    robot_env = environment(empty_grid()).for_robot(ROBOT)
    east, west = hallway_roles()
    # At t = 4 s they meet around t = 5 s at x = 1.0: the other robot's discs around there.
    field = make_conflict_field(robot_env, [west], 4.0, own=east, horizon=2.0, samples=20)
    assert field.conflicting == ['west']
    cells = np.argwhere(field.area)
    xs = robot_env.frame.cell_to_world(cells)[:, 0]
    assert 0.75 < xs.min() and xs.max() < 1.35
    # Robot east's SDF now says the meeting point is blocked, its own start is not.
    assert field.sdf.distance(np.array([[1.0, 1.0]]))[0] < 0
    assert field.sdf.distance(np.array([[0.3, 1.0]]))[0] == pytest.approx(
        robot_env.sdf.distance(np.array([[0.3, 1.0]]))[0])


def test_no_conflict_when_roles_stay_apart():
    robot_env = environment(empty_grid()).for_robot(ROBOT)
    east, west = hallway_roles()
    # Early on they are 1.6 m apart: nothing within 2 s conflicts.
    field = make_conflict_field(robot_env, [west], 0.0, own=east, horizon=2.0)
    assert field.conflicting == [] and not field.area.any()
    assert field.sdf.data == pytest.approx(robot_env.sdf.data)


def test_without_own_role_every_position_in_the_horizon_counts():
    robot_env = environment(empty_grid()).for_robot(ROBOT)
    _, west = hallway_roles()
    field = make_conflict_field(robot_env, [west], 0.0, horizon=10.0)
    xs = robot_env.frame.cell_to_world(np.argwhere(field.area))[:, 0]
    assert xs.min() < 0.2 and xs.max() > 1.8


def test_bad_arguments():
    robot_env = environment(empty_grid()).for_robot(ROBOT)
    east, _ = hallway_roles()
    with pytest.raises(RoleEngineError, match='horizon'):
        make_conflict_field(robot_env, [east], 0.0, horizon=-1.0)
    with pytest.raises(RoleEngineError, match="'bad'.radius"):
        make_conflict_field(robot_env, [SharedRole('bad', east.trajectory, 10.0, -0.1)], 0.0)
