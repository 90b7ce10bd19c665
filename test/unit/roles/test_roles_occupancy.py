"""The round's map as a nav_msgs/OccupancyGrid (Nav2 conventions) and the team as role_interfaces/Team."""
import math

import numpy as np
import pytest
from role_interfaces.msg import Team

from pybullet_bridge.core.scenario import load_scenario
from role_engine.core.environment import Environment
from role_engine.core.errors import RoleEngineError
from role_engine.core.formation_task import load_formation_task, team_from_scenario
from role_engine.core.occupancy import OccupancyCells, environment_from_cells, occupancy_cells
from role_engine.role_messages import environment_of, occupancy_grid_msg, planar_pose, pose_msg, team_msg, team_of


def asymmetric_environment() -> Environment:
    grid = np.zeros((6, 9), dtype=bool)          # (ny, nx): not square, so a transposition shows
    grid[1, 7] = True                            # one cell low right
    grid[4:6, 0:2] = True                        # a block top left
    return Environment(grid, 0.1, (-0.4, 1.25), name='asym')


def test_cells_follow_nav2_row_major_from_the_origin_cell():
    env = asymmetric_environment()
    cells = occupancy_cells(env)
    assert (cells.width, cells.height, cells.resolution, cells.origin) == (9, 6, 0.1, (-0.4, 1.25))
    assert cells.data.dtype == np.int8 and set(np.unique(cells.data)) == {0, 100}
    # data[iy * width + ix]: cell (iy=1, ix=7) is the one at x = -0.4 + 7.5 * 0.1, y = 1.25 + 1.5 * 0.1.
    assert cells.data[1 * 9 + 7] == 100 and cells.data[7 * 1 + 1] == 0
    # Row 0 of the data is the bottom of the map: the image (row 0 at the top) is its flip.
    assert np.array_equal(np.flipud(cells.data.reshape(6, 9) == 100), env.image() == 0)


def test_round_trip_keeps_cells_frame_and_obstacle_distances():
    env = asymmetric_environment()
    again = environment_from_cells(occupancy_cells(env), name='again')
    assert np.array_equal(again.occupied, env.occupied)
    assert again.frame == env.frame and again.border_is_obstacle
    point = np.array([[-0.4 + 0.75, 1.25 + 0.15]])          # the centre of the lone cell
    assert again.sdf.distance(point)[0] < 0.0
    assert np.allclose(again.sdf.data, env.sdf.data)


def test_round_trip_through_the_message():
    env = asymmetric_environment()
    stamp = Team().header.stamp
    stamp.sec, stamp.nanosec = 12, 500
    msg = occupancy_grid_msg(env, 'world', stamp)
    assert msg.header.frame_id == 'world' and msg.header.stamp == stamp and msg.info.map_load_time == stamp
    assert (msg.info.width, msg.info.height) == (9, 6) and msg.info.resolution == pytest.approx(0.1)
    assert (msg.info.origin.position.x, msg.info.origin.position.y) == (-0.4, 1.25)
    assert msg.info.origin.orientation.w == 1.0
    again = environment_of(msg)
    assert np.array_equal(again.occupied, env.occupied)
    assert again.origin == env.origin and again.resolution == pytest.approx(env.resolution)


def test_unknown_and_partly_occupied_cells_are_read_as_nav2_does():
    data = np.array([-1, 0, 50, 64, 65, 100], dtype=np.int8)
    env = environment_from_cells(OccupancyCells(3, 2, 0.5, (0.0, 0.0), data))
    assert env.occupied.ravel().tolist() == [True, False, False, False, True, True]


@pytest.mark.parametrize('change, yaw, message', [
    ({'data': np.zeros(5, dtype=np.int8)}, 0.0, r'map.data: must have width x height = 6 cells \(got 5\)'),
    ({'resolution': 0.0}, 0.0, 'map.info.resolution: must be a finite number > 0'),
    ({'width': 0, 'data': np.zeros(0, dtype=np.int8)}, 0.0, 'width and height must be >= 1'),
    ({'origin': (math.nan, 0.0)}, 0.0, 'map.info.origin.position: must be finite'),
    ({'data': np.array([0, 0, 0, 0, 0, -5], dtype=np.int8)}, 0.0, r'cells must be -1 \(unknown\) or 0..100'),
    ({}, 0.3, 'map.info.origin.orientation: the map must not be rotated'),
])
def test_bad_maps_name_the_field(change, yaw, message):
    fields = {'width': 3, 'height': 2, 'resolution': 0.5, 'origin': (0.0, 0.0), 'data': np.zeros(6, dtype=np.int8)}
    with pytest.raises(RoleEngineError, match=message):
        environment_from_cells(OccupancyCells(**{**fields, **change}), origin_yaw=yaw)


def test_a_full_turn_is_not_a_rotation():
    cells = OccupancyCells(3, 2, 0.5, (0.0, 0.0), np.zeros(6, dtype=np.int8))
    assert environment_from_cells(cells, origin_yaw=2.0 * math.pi).shape == (2, 3)


# --------------------------------------------------------------------------------------- team
def demo_team(config_dir):
    task = load_formation_task(config_dir / 'roles' / 'formation_demo.yaml')
    return task, team_from_scenario(load_scenario(task.scenario), task.inflation_margin)


def test_team_round_trip_gives_the_players_what_the_scenario_gave(config_dir):
    task, team = demo_team(config_dir)
    msg = team_msg(team, 'world')
    assert msg.header.frame_id == 'world' and [m.name for m in msg.members] == [m.name for m in team]
    again = team_of(msg, task.inflation_margin)
    for before, after in zip(team, again):
        assert after.name == before.name and after.height == pytest.approx(before.height)
        assert after.color == pytest.approx(before.color)
        assert after.robot_type == before.robot_type            # type, radius, margin, both limits


@pytest.mark.parametrize('edit, message', [
    (lambda m: setattr(m.members[1], 'name', m.members[0].name), r'team.members\[1\].name: must be a non-empty name'),
    (lambda m: setattr(m.members[0], 'radius', 0.0), r'team.members\[0\].radius: must be > 0'),
    (lambda m: setattr(m.members[2], 'color', [0.0, 0.0, 0.0]), r'team.members\[2\].color'),
    (lambda m: setattr(m.members[0], 'max_linear_velocity', -1.0), r'team.members\[0\] \(pioneer_1\).*max_linear'),
    (lambda m: m.members.clear(), 'the team has no robot'),
])
def test_bad_team_messages_name_the_field(config_dir, edit, message):
    task, team = demo_team(config_dir)
    msg = team_msg(team, 'world')
    edit(msg)
    with pytest.raises(ValueError, match=message):
        team_of(msg, task.inflation_margin)


def test_pose_message_round_trip_and_bad_poses():
    stamp = Team().header.stamp
    msg = pose_msg(1.5, -0.25, 2.5, 'world', stamp)
    assert msg.header.frame_id == 'world'
    assert planar_pose(msg) == pytest.approx((1.5, -0.25, 2.5))
    msg.pose.orientation.w = msg.pose.orientation.z = 0.0
    with pytest.raises(ValueError, match='tracked pose'):
        planar_pose(msg)
