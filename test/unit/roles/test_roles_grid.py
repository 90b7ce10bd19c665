"""Grid placement, octile distance and exact segment traversal."""
import numpy as np
import pytest

from role_engine.core.errors import RoleEngineError
from role_engine.core.grid import GridFrame, image_rows_to_grid, line_of_sight, octile_distance, segment_cells


def test_world_cell_round_trip_and_bounds():
    frame = GridFrame(0.5, (-1.0, 2.0), (4, 6))
    assert frame.bounds == (-1.0, 2.0, 2.0, 4.0)
    cells = np.array([[0, 0], [3, 5], [1, 2]])
    centres = frame.cell_to_world(cells)
    assert centres[0] == pytest.approx([-0.75, 2.25])
    assert frame.world_to_cell(centres).tolist() == cells.tolist()
    assert frame.world_to_cell(np.array([[-1.01, 2.0]])).tolist() == [[0, -1]]
    assert frame.contains_cells(np.array([[0, -1], [3, 5], [4, 0]])).tolist() == [False, True, False]


def test_octile_distance():
    assert octile_distance([0, 0], [3, 4]) == pytest.approx(4 + (2 ** 0.5 - 1) * 3)
    assert octile_distance(np.array([[0, 0], [1, 1]]), np.array([[0, 5], [1, 1]])).tolist() == [5.0, 0.0]


def test_segment_cells_are_exact_and_corner_touches_do_not_count():
    assert segment_cells([0, 0], [0, 3]).tolist() == [[0, 0], [0, 1], [0, 2], [0, 3]]
    assert segment_cells([0, 0], [2, 2]).tolist() == [[0, 0], [1, 1], [2, 2]]
    # Through the corner at (0.5, 1.5): straight from cell (0, 1) into cell (1, 2).
    assert segment_cells([0, 0], [1, 3]).tolist() == [[0, 0], [0, 1], [1, 2], [1, 3]]
    # Just off that corner the segment does enter a side cell.
    assert [0, 2] in segment_cells([0, 0], [1, 3.2]).tolist()
    free = np.ones((3, 3), dtype=bool)
    free[0, 1] = free[1, 0] = False
    assert line_of_sight(free, np.array([0, 0]), np.array([1, 1]))
    assert not line_of_sight(free, np.array([0, 0]), np.array([0, 2]))
    assert not line_of_sight(free, np.array([0, 0]), np.array([0, 5]))    # leaves the grid


def test_image_rows_are_flipped_to_y_up():
    image = np.array([[1, 2], [3, 4]])
    assert image_rows_to_grid(image).tolist() == [[3, 4], [1, 2]]


@pytest.mark.parametrize('kwargs, message', [
    ({'resolution': 0.0}, 'resolution'),
    ({'origin': (0.0, float('nan'))}, 'origin'),
    ({'shape': (0, 3)}, 'shape'),
])
def test_bad_frames_are_rejected(kwargs, message):
    arguments = {'resolution': 0.1, 'origin': (0.0, 0.0), 'shape': (2, 2), **kwargs}
    with pytest.raises(RoleEngineError, match=message):
        GridFrame(**arguments)
