"""Signed distance field: values against exact distances, sign, gradient, off-grid behaviour."""
import numpy as np
import pytest

from role_engine.core.errors import RoleEngineError
from role_engine.core.sdf import SignedDistanceField, signed_distance_cells

RES = 0.1


def box_sdf(**kwargs) -> SignedDistanceField:
    """30 x 40 grid, obstacle cells ix 10..19, iy 10..19: the box [1, 2] x [1, 2] m."""
    grid = np.zeros((30, 40), dtype=bool)
    grid[10:20, 10:20] = True
    return SignedDistanceField.from_occupancy(grid, RES, (0.0, 0.0), **kwargs)


def exact_box_distance(points: np.ndarray) -> np.ndarray:
    """Signed distance to the box [1, 2] x [1, 2]."""
    excess = np.abs(points - 1.5) - 0.5
    outside = np.linalg.norm(np.maximum(excess, 0.0), axis=1)
    return outside + np.minimum(excess.max(axis=1), 0.0)


def test_attributes_follow_the_interface_contract():
    sdf = box_sdf()
    assert sdf.resolution == RES
    assert sdf.origin == (0.0, 0.0)
    assert sdf.shape == (30, 40)
    assert sdf.data.shape == (30, 40)


def test_axis_aligned_distances_are_exact_at_cell_centres():
    sdf = box_sdf()
    # Cell centres on the row through the box centre, left of it, right of it and inside.
    points = np.array([[0.25, 1.55], [0.95, 1.55], [2.05, 1.55], [3.45, 1.55], [1.05, 1.55], [1.45, 1.55]])
    distance, _ = sdf.query(points)
    assert distance == pytest.approx(exact_box_distance(points), abs=1e-9)


def test_sign_and_zero_level_on_the_obstacle_surface():
    sdf = box_sdf()
    distance, _ = sdf.query(np.array([[1.5, 1.5], [1.5, 2.5], [2.0, 1.5], [1.0, 1.3]]))
    assert distance[0] < 0 < distance[1]
    assert distance[2] == pytest.approx(0.0, abs=1e-9)
    assert distance[3] == pytest.approx(0.0, abs=1e-9)


def test_off_axis_distances_are_within_a_cell_of_exact():
    rng = np.random.default_rng(3)
    points = rng.uniform([0.1, 0.1], [3.9, 2.9], size=(300, 2))
    distance, _ = box_sdf().query(points)
    assert np.max(np.abs(distance - exact_box_distance(points))) < RES


def test_gradient_matches_finite_differences_of_the_interpolant():
    sdf = box_sdf()
    rng = np.random.default_rng(5)
    # Stay off the cell-centre lines, where the bilinear interpolant has kinks.
    cells = rng.integers(1, 28, size=(100, 2)) + rng.uniform(0.2, 0.8, size=(100, 2))
    points = (cells + 0.5) * RES
    _, gradient = sdf.query(points)
    step = 1e-6
    for axis in range(2):
        offset = np.zeros(2)
        offset[axis] = step
        numeric = (sdf.query(points + offset)[0] - sdf.query(points - offset)[0]) / (2 * step)
        assert gradient[:, axis] == pytest.approx(numeric, abs=1e-5)


def test_gradient_points_away_from_the_obstacle():
    _, gradient = box_sdf().query(np.array([[0.55, 1.55], [3.05, 1.55], [1.55, 0.35], [1.55, 2.75]]))
    assert gradient == pytest.approx(np.array([[-1, 0], [1, 0], [0, -1], [0, 1]]), abs=1e-9)


def test_points_beyond_the_grid_extend_linearly():
    sdf = box_sdf(border_is_obstacle=True)
    inside_edge, gradient = sdf.query(np.array([[0.05, 1.55]]))
    assert inside_edge[0] == pytest.approx(0.05)          # half a cell from the arena edge
    assert gradient[0] == pytest.approx([1.0, 0.0])
    outside, _ = sdf.query(np.array([[-0.3, 1.55], [-1.3, 1.55]]))
    assert outside == pytest.approx([-0.3, -1.3])         # negative and decreasing beyond the wall
    far, _ = box_sdf().query(np.array([[10.0, 1.55]]))    # open border: distance keeps growing
    assert far[0] == pytest.approx(8.0)


def test_grid_without_obstacles_has_a_finite_constant_field():
    sdf = SignedDistanceField.from_occupancy(np.zeros((5, 8), dtype=bool), 0.5, (1.0, 2.0))
    distance, gradient = sdf.query(np.array([[1.2, 2.2], [4.0, 3.0]]))
    assert np.isfinite(distance).all() and distance[0] == distance[1] > 0
    assert gradient == pytest.approx(np.zeros((2, 2)))
    assert (signed_distance_cells(np.ones((3, 3), dtype=bool)) < 0).all()


def test_single_point_and_single_cell_grids():
    sdf = SignedDistanceField.from_occupancy(np.array([[False]]), 1.0, (0.0, 0.0), border_is_obstacle=True)
    distance, gradient = sdf.query(np.array([0.5, 0.5]))
    assert distance.shape == (1,) and gradient.shape == (1, 2)
    assert distance[0] == pytest.approx(0.5)


@pytest.mark.parametrize('points, message', [
    (np.zeros((3, 3)), 'shape'),
    (np.array([[0.0, np.nan]]), 'finite'),
])
def test_bad_points_are_rejected_with_a_clear_error(points, message):
    with pytest.raises(RoleEngineError, match=message):
        box_sdf().query(points)


def test_bad_construction_is_rejected():
    with pytest.raises(RoleEngineError, match='resolution'):
        SignedDistanceField(np.zeros((2, 2)), 0.0, (0.0, 0.0))
    with pytest.raises(RoleEngineError, match='finite'):
        SignedDistanceField(np.full((2, 2), np.inf), 0.1, (0.0, 0.0))
    with pytest.raises(RoleEngineError, match='2-D'):
        signed_distance_cells(np.zeros(4, dtype=bool))
