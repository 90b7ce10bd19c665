"""E-Map on small hand-made maps: skeleton, de-stairing, feature nodes and the weighted graph."""
import networkx as nx
import numpy as np
import pytest
from scipy import ndimage

from role_engine.core.emap import build_emap, neighbour_count, remove_stairs, skeleton_of
from role_engine.core.environment import RobotType
from role_engine.core.errors import RoleEngineError
from role_engine.core.grid import line_of_sight

from roles_map_helpers import RESOLUTION, empty_grid, environment, l_corridor, ring_corridor, two_rooms

POINT = RobotType('point', 0.0)
EIGHT = np.ones((3, 3), dtype=bool)


def emap_of(grid, robot=POINT, **kwargs):
    return build_emap(environment(grid).for_robot(robot), **kwargs)


def components(mask):
    return ndimage.label(mask, structure=EIGHT)[1]


def test_remove_stairs_drops_redundant_corners_only():
    stairs = np.zeros((8, 9), dtype=bool)
    # A 4-connected staircase from (1, 1) to (6, 6) plus a tail: every inner corner is redundant.
    for k in range(1, 6):
        stairs[k, k] = stairs[k, k + 1] = True
    stairs[6, 6] = stairs[6, 7] = True
    thinned = remove_stairs(stairs)
    assert thinned.sum() == stairs.sum() - 5
    assert components(thinned) == components(stairs) == 1
    assert not (thinned & ~stairs).any()
    # The extreme pixels stay and become the line's only two ends.
    assert np.argwhere(neighbour_count(thinned) == 1).tolist() == [[1, 1], [6, 7]]
    # What is left is a thin 8-connected line: no pixel has more than two neighbours.
    assert neighbour_count(thinned).max() == 2
    assert np.array_equal(remove_stairs(thinned), thinned)


def test_remove_stairs_keeps_a_clean_line_and_a_junction():
    grid = np.zeros((7, 7), dtype=bool)
    grid[3, :] = True
    grid[:3, 3] = True      # T junction: the centre has three orthogonal neighbours
    assert np.array_equal(remove_stairs(grid), grid)


def test_skeleton_lies_in_free_space_and_covers_every_region():
    grid = two_rooms(door_cells=0)                          # two closed rooms
    grid[5:8, 5:8] = False
    env = environment(grid).for_robot(POINT)
    skeleton = skeleton_of(env.visitable)
    assert not (skeleton & ~env.visitable).any()
    assert set(np.unique(env.components[skeleton])) == set(range(1, env.components.max() + 1))


def test_ring_corridor_gives_a_cycle_of_free_straight_edges():
    emap = emap_of(ring_corridor())
    graph = emap.graph
    assert nx.is_connected(graph)
    assert nx.cycle_basis(graph), 'the corridor loop must stay a loop'
    free = emap.robot_env.visitable
    for a, b, data in graph.edges(data=True):
        ca, cb = np.array(graph.nodes[a]['cell']), np.array(graph.nodes[b]['cell'])
        assert free[tuple(ca)] and free[tuple(cb)]
        assert line_of_sight(free, ca, cb), f'edge {a}-{b} cuts an obstacle'
        # The chain along the skeleton is never shorter than the straight segment.
        assert data['weight'] >= np.hypot(*(ca - cb)) * RESOLUTION - 1e-9
        assert tuple(data['cells'][0]) == tuple(graph.nodes[min(a, b)]['cell'])
    # The four corners of the square loop are feature nodes (one of them anchors the loop).
    cells = np.array([graph.nodes[n]['cell'] for n in graph])
    for corner in ([4.5, 4.5], [4.5, 34.5], [34.5, 4.5], [34.5, 34.5]):
        assert np.min(np.hypot(*(cells - corner).T)) <= 2.0
    assert sorted(graph.nodes[n]['kind'] for n in graph) == ['corner', 'corner', 'corner', 'loop']


def test_t_junction_becomes_one_node_of_degree_three():
    grid = np.ones((40, 40), dtype=bool)
    grid[17:23, 2:38] = False          # horizontal corridor
    grid[2:20, 17:23] = False          # vertical corridor joining it from below
    graph = emap_of(grid).graph
    junctions = [n for n in graph if graph.nodes[n]['kind'] == 'junction']
    assert len(junctions) == 1 and graph.degree[junctions[0]] == 3
    assert sum(1 for n in graph if graph.nodes[n]['kind'] == 'end') == 3


def test_l_corridor_has_a_corner_node_at_the_bend():
    graph = emap_of(l_corridor()).graph
    cells = np.array([graph.nodes[n]['cell'] for n in graph])
    bend = np.array([35, 5])
    assert np.min(np.hypot(*(cells - bend).T)) <= 3
    assert nx.is_connected(graph)


def test_narrow_door_separates_large_robots_only():
    grid = two_rooms(door_cells=4)                         # 0.2 m door
    small = emap_of(grid, RobotType('small', 0.02)).graph
    large = emap_of(grid, RobotType('large', 0.1)).graph
    assert nx.number_connected_components(small) == 1
    assert nx.number_connected_components(large) == 2


def test_isolated_pocket_gets_its_own_node():
    grid = ring_corridor()
    grid[18:22, 18:22] = False                              # a hole inside the block
    emap = emap_of(grid)
    assert nx.number_connected_components(emap.graph) == 2
    cells = [emap.graph.nodes[n]['cell'] for n in emap.graph]
    assert any(18 <= y < 22 and 18 <= x < 22 for y, x in cells)


def test_open_room_and_full_map():
    room = emap_of(empty_grid())
    assert room.graph.number_of_nodes() >= 1 and nx.is_connected(room.graph)
    blocked = emap_of(np.ones((10, 10), dtype=bool))
    assert blocked.graph.number_of_nodes() == 0


def test_bad_tolerance_is_rejected():
    with pytest.raises(RoleEngineError, match='corner_tolerance'):
        emap_of(empty_grid(), corner_tolerance=0.0)
