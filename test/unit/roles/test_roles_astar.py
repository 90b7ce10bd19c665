"""Auxiliary nodes: A* with the octile heuristic, line-of-sight reduction, infeasibility."""
import math

import networkx as nx
import numpy as np
import pytest

from role_engine.core.astar import EMapPlanner, polyline_length, reduce_by_line_of_sight
from role_engine.core.emap import build_emap
from role_engine.core.environment import RobotType, load_map_file
from role_engine.core.errors import RoleEngineError
from role_engine.core.grid import line_of_sight, octile_distance

from roles_map_helpers import MAPS_DIR, cell_centre, environment, ring_corridor, two_rooms

POINT = RobotType('point', 0.0)


def planner_of(grid, robot=POINT, **kwargs):
    return EMapPlanner(build_emap(environment(grid).for_robot(robot)), **kwargs)


def assert_free_polyline(planner, points):
    frame = planner.frame
    cells = frame.world_to_continuous(points)[:, ::-1]
    for a, b in zip(cells[:-1], cells[1:]):
        assert line_of_sight(planner.robot_env.visitable, a, b), f'segment {a} -> {b} crosses an obstacle'


def test_octile_heuristic_is_admissible_on_the_emap():
    emap = build_emap(load_map_file(MAPS_DIR / 'env_3.yaml').for_robot(RobotType('r', 0.05)))
    graph = emap.graph
    nodes = list(graph)[::4]
    lengths = dict(nx.all_pairs_dijkstra_path_length(graph, weight='weight'))
    for a in nodes:
        for b in nodes:
            if b in lengths[a]:
                h = octile_distance(graph.nodes[a]['cell'], graph.nodes[b]['cell']) * emap.robot_env.frame.resolution
                assert h <= lengths[a][b] + 1e-9


def test_path_around_the_ring_takes_the_short_side_and_stays_free():
    planner = planner_of(ring_corridor())
    source, destination = cell_centre(5, 5), cell_centre(34, 20)
    path = planner.plan(source, destination)
    assert path.feasible and path.reason == ''
    assert path.waypoints[0] == pytest.approx(source) and path.waypoints[-1] == pytest.approx(destination)
    assert_free_polyline(planner, path.waypoints)
    assert_free_polyline(planner, path.graph_waypoints)
    # Around the block through the left side: about 29 cells up and 15 right, well under the long way.
    assert path.length < 0.05 * 50
    assert path.length <= polyline_length(path.graph_waypoints) + 1e-9
    assert path.length >= math.dist(source, destination)


def test_line_of_sight_reduction_leaves_only_needed_corners():
    planner = planner_of(ring_corridor())
    path = planner.plan(cell_centre(5, 5), cell_centre(34, 34))
    # Opposite corners of the loop: one turn is needed, so three points remain.
    assert len(path.waypoints) == 3
    direct = planner.plan(cell_centre(3, 3), cell_centre(3, 36))
    assert len(direct.waypoints) == 2
    assert direct.length == pytest.approx(33 * 0.05)


def test_reduce_by_line_of_sight_on_a_grid():
    free = np.ones((10, 10), dtype=bool)
    free[3:7, 5] = False
    cells = np.array([[5, 1], [5, 2], [8, 4], [8, 6], [5, 8]], dtype=float)
    kept = reduce_by_line_of_sight(cells, free)
    assert kept[0] == 0 and kept[-1] == 4
    for i, j in zip(kept[:-1], kept[1:]):
        assert line_of_sight(free, cells[i], cells[j])
    assert not line_of_sight(free, cells[0], cells[4])


def test_unreachable_destination_is_infeasible_with_a_reason():
    planner = planner_of(two_rooms(door_cells=4), RobotType('large', 0.1))
    path = planner.plan(cell_centre(20, 10), cell_centre(20, 50))
    assert not path.feasible and math.isinf(path.length) and len(path.waypoints) == 0
    assert 'separate free regions' in path.reason and "'large'" in path.reason
    small = planner_of(two_rooms(door_cells=4), RobotType('small', 0.02)).plan(cell_centre(20, 10),
                                                                                 cell_centre(20, 50))
    assert small.feasible


@pytest.mark.parametrize('source, destination, word', [
    (cell_centre(15, 15), cell_centre(5, 5), 'source'),       # inside the block
    (cell_centre(5, 5), (-1.0, 0.5), 'destination'),          # off the map
    (cell_centre(5, 5), cell_centre(9, 9), 'destination'),    # within the inflation of the block
])
def test_points_in_obstacles_or_off_the_map_are_infeasible(source, destination, word):
    path = planner_of(ring_corridor(), RobotType('r', 0.05)).plan(source, destination)
    assert not path.feasible and path.reason.startswith(word) and 'not visitable' in path.reason


def test_malformed_points_raise():
    planner = planner_of(ring_corridor())
    with pytest.raises(RoleEngineError, match='source'):
        planner.plan((np.nan, 0.0), (1.0, 1.0))
    with pytest.raises(RoleEngineError, match='destination'):
        planner.plan((0.2, 0.2), (1.0, 1.0, 2.0))


def test_point_that_sees_no_candidate_node_joins_by_grid_search():
    grid = np.ones((24, 40), dtype=bool)
    grid[2:6, 2:38] = False            # corridor A
    grid[7:11, 2:38] = False           # corridor B, behind the wall on row 6
    grid[7:20, 18:26] = False          # B opens into a room right behind the wall
    grid[2:11, 34:38] = False          # A and B meet at the right end
    planner = planner_of(grid, attach_count=1, attach_candidates=1)
    source = cell_centre(5, 21)        # in A; the nearest node is B's junction behind the wall
    node_cells = planner.emap.node_cells
    nearest = node_cells[np.argmin(np.hypot(*(node_cells - [5, 21]).T))]
    assert not line_of_sight(planner.robot_env.visitable, np.array([5, 21]), nearest)
    path = planner.plan(source, cell_centre(16, 22))
    assert path.feasible
    assert_free_polyline(planner, path.graph_waypoints)
    assert path.waypoints[0] == pytest.approx(source)
    # The join goes around through A to the right end, not through the wall.
    first_node = planner.frame.world_to_cell(path.graph_waypoints[1])[0]
    assert tuple(first_node) != tuple(nearest) and first_node[1] > 30


def test_same_point_gives_a_zero_length_path():
    path = planner_of(ring_corridor()).plan(cell_centre(5, 5), cell_centre(5, 5))
    assert path.feasible and path.length == 0.0


def test_planner_arguments_are_checked():
    emap = build_emap(environment(ring_corridor()).for_robot(POINT))
    with pytest.raises(RoleEngineError, match='attach_count'):
        EMapPlanner(emap, attach_count=0)


@pytest.mark.parametrize('seed', range(4))
def test_random_maps_keep_every_edge_and_path_collision_free(seed):
    """Noisy maps stress junction clusters and diagonal gaps; the guarantees must hold anyway."""
    rng = np.random.default_rng(seed)
    for _ in range(6):
        n = int(rng.integers(10, 50))
        grid = rng.uniform(size=(n, n)) < rng.uniform(0.05, 0.5)
        robot = environment(grid).for_robot(RobotType('r', float(rng.choice([0.0, 0.05]))))
        emap = build_emap(robot)
        graph = emap.graph
        for a, b, data in graph.edges(data=True):
            ca, cb = np.array(graph.nodes[a]['cell']), np.array(graph.nodes[b]['cell'])
            assert line_of_sight(robot.visitable, ca, cb)
            assert data['weight'] >= octile_distance(ca, cb) * robot.frame.resolution - 1e-9
            assert np.abs(np.diff(data['cells'], axis=0)).max() <= 1     # a true 8-connected chain
        planner = EMapPlanner(emap)
        free = np.argwhere(robot.visitable)
        for source_cell, goal_cell in free[rng.integers(0, len(free), size=(5, 2))]:
            source, goal = robot.frame.cell_to_world(np.array([source_cell, goal_cell]))
            path = planner.plan(source, goal)
            assert path.feasible == (robot.components[tuple(source_cell)] == robot.components[tuple(goal_cell)])
            if path.feasible:
                assert_free_polyline(planner, path.waypoints)
