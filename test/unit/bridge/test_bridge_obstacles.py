"""Occupancy-image decomposition and the obstacles section."""
from pathlib import Path

import cv2
import numpy as np
import pytest

from bridge_core_helpers import SCENARIO_DIR, scenario_dict
from pybullet_bridge.core.obstacles import BoxObstacle, WallSet, occupancy_to_rectangles
from pybullet_bridge.core.scenario import parse_scenario
from pybullet_bridge.core.scene import Scene


def paint(shape, rectangles) -> np.ndarray:
    """Count how many rectangles cover each cell."""
    cover = np.zeros(shape, dtype=int)
    for row0, col0, row1, col1 in rectangles:
        assert 0 <= row0 < row1 <= shape[0] and 0 <= col0 < col1 <= shape[1]
        cover[row0:row1, col0:col1] += 1
    return cover


@pytest.mark.parametrize('seed', range(20))
def test_rectangles_cover_random_grids_exactly_without_overlap(seed):
    rng = np.random.default_rng(seed)
    shape = tuple(rng.integers(1, 40, size=2))
    # Mix sparse noise and blocky grids so merging across rows is exercised.
    occupied = rng.random(shape) < rng.uniform(0.1, 0.9)
    if seed % 2:
        occupied = np.kron(occupied[: shape[0] // 4 + 1, : shape[1] // 4 + 1], np.ones((4, 4), bool))
    cover = paint(occupied.shape, occupancy_to_rectangles(occupied))
    assert np.array_equal(cover, occupied.astype(int))


def test_rectangles_merge_rows_then_columns():
    occupied = np.zeros((6, 8), bool)
    occupied[1:4, 2:6] = True   # one block
    occupied[4, 2:4] = True     # narrower row below it starts a new rectangle
    occupied[0:6, 7] = True     # full-height column
    assert occupancy_to_rectangles(occupied) == [(0, 7, 6, 8), (1, 2, 4, 6), (4, 2, 5, 4)]


def test_empty_and_full_grids():
    assert occupancy_to_rectangles(np.zeros((3, 4), bool)) == []
    assert occupancy_to_rectangles(np.ones((3, 4), bool)) == [(0, 0, 3, 4)]
    with pytest.raises(ValueError):
        occupancy_to_rectangles(np.zeros(5, bool))


def test_map_image_becomes_boxes_with_top_row_at_max_y(tmp_path):
    image = np.full((10, 20), 255, np.uint8)
    image[0:2, 0:4] = 0      # top-left corner of the image
    image[8:10, 16:20] = 100  # bottom-right, grey but below the threshold
    image[5, 10] = 200        # light grey: free
    cv2.imwrite(str(tmp_path / 'm.png'), image)
    data = scenario_dict(world={'bounds': [-5, -5, 5, 5]}, obstacles={
        'map': {'image': 'm.png', 'resolution': 0.1, 'origin': [1.0, 2.0], 'occupied_below': 128, 'height': 0.2}})
    boxes = parse_scenario(data, tmp_path).sections['obstacles']
    by_center = {tuple(np.round(box.center, 6)): box for box in boxes}
    # Image 2 m wide, 1 m tall; its top-left block spans x 1.0..1.4, y 2.8..3.0.
    assert set(by_center) == {(1.2, 2.9), (2.8, 2.1)}
    assert by_center[(1.2, 2.9)].size == pytest.approx((0.4, 0.2))
    assert all(box.height == 0.2 and box.name.startswith('map_') for box in boxes)


def test_demo_map_matches_its_generator():
    import importlib.util
    spec = importlib.util.spec_from_file_location('make_demo_map', SCENARIO_DIR / '../maps/make_demo_map.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    stored = cv2.imread(str(SCENARIO_DIR / '../maps/demo_map.png'), cv2.IMREAD_GRAYSCALE)
    assert np.array_equal(stored, module.make_map())


def test_boxes_and_walls_spawn_as_static_bodies():
    data = scenario_dict(mobile_robots=[], obstacles={'boxes': [
        {'center': [1.0, 0.5], 'size': [0.4, 0.2], 'height': 0.5, 'yaw': 0.3},
        {'name': 'crate', 'center': [-1.0, -1.0], 'size': [0.3, 0.3]}]})
    with Scene(parse_scenario(data, Path('.'))) as scene:
        assert [e.name for e in scene.entities] == ['walls', 'obstacle_0', 'crate']
        walls = scene.entities_of(WallSet)[0]
        assert len(walls.body_ids) == 4
        box = scene.entity('obstacle_0')
        assert isinstance(box, BoxObstacle)
        scene.step(100)
        state = {s.name: s for s in scene.body_states()}['obstacle_0']
        assert state.position == pytest.approx((1.0, 0.5, 0.25))
        assert state.linear_velocity == pytest.approx((0.0, 0.0, 0.0))
