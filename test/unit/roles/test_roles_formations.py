"""Unlabeled destinations from formations."""
import math

import numpy as np
import pytest

from role_engine.core.formations import (
    circle_formation, diamond_formation, line_formation, parse_formation, square_formation)


def test_circle_points_lie_on_the_circle_evenly():
    points = circle_formation((1.0, -1.0), 2.0, 6)
    assert np.hypot(*(points - [1.0, -1.0]).T) == pytest.approx(np.full(6, 2.0))
    assert points[0] == pytest.approx([3.0, -1.0])
    gaps = np.hypot(*np.diff(np.vstack([points, points[:1]]), axis=0).T)
    assert gaps == pytest.approx(np.full(6, 2.0))         # hexagon side = radius


def test_square_four_points_are_the_corners_and_eight_add_midpoints():
    corners = square_formation((0.0, 0.0), 2.0, 4)
    assert sorted(map(tuple, np.round(corners, 9))) == [(-1, -1), (-1, 1), (1, -1), (1, 1)]
    eight = square_formation((0.0, 0.0), 2.0, 8)
    assert {tuple(p) for p in np.round(eight, 9)} >= {(0, 1), (-1, 0), (0, -1), (1, 0)}


def test_diamond_vertices_and_rotation():
    diamond = diamond_formation((0.5, 0.5), 1.0, 4)
    assert diamond == pytest.approx(np.array([[1.0, 0.5], [0.5, 1.0], [0.0, 0.5], [0.5, 0.0]]))
    turned = square_formation((0.0, 0.0), math.sqrt(2.0), 4, rotation=math.pi / 4)
    assert turned[0] == pytest.approx([0.0, 1.0])


def test_line_spacing_and_single_point():
    line = line_formation((0.0, 1.0), 2.0, 3, rotation=math.pi / 2)
    assert line == pytest.approx(np.array([[0.0, 0.0], [0.0, 1.0], [0.0, 2.0]]))
    assert line_formation((0.3, 0.4), 2.0, 1) == pytest.approx(np.array([[0.3, 0.4]]))


def test_parse_every_type():
    assert parse_formation({'type': 'circle', 'center': [0, 0], 'radius': 1, 'count': 4}).shape == (4, 2)
    assert parse_formation({'type': 'points', 'points': [[1, 2], [3, 4]]}) == pytest.approx(
        np.array([[1.0, 2.0], [3.0, 4.0]]))
    assert parse_formation({'type': 'diamond', 'center': [0, 0], 'size': 1, 'count': 4,
                            'rotation': 0.1}).shape == (4, 2)


@pytest.mark.parametrize('data, message', [
    ({'type': 'star', 'center': [0, 0]}, r"formation.type: unknown formation 'star'"),
    ({'type': 'circle', 'center': [0, 0], 'count': 3}, r'formation.radius: missing required field'),
    ({'type': 'circle', 'center': [0, 0], 'radius': -1, 'count': 3}, r'formation.radius: must be > 0'),
    ({'type': 'line', 'center': [0, 0], 'length': 1, 'count': 0}, r'formation.count: must be >= 1'),
    ({'type': 'square', 'center': [0], 'side': 1, 'count': 2}, r'formation.center: must be a list of 2'),
    ({'type': 'square', 'center': [0, 0], 'radius': 1, 'count': 2}, r'formation.radius: unknown field'),
    ({'type': 'points', 'points': []}, r'formation.points: must list at least one point'),
    ({'type': 'points', 'points': [[0, 0], ['a', 1]]}, r'formation.points\[1\]\[0\]: must be a number'),
    ({'type': 'points', 'points': [[0, 0], [0, 0]]}, r'destinations 0 and 1 coincide'),
    ({'type': 'circle', 'center': [0, 0], 'radius': 1e-12, 'count': 2}, 'coincide'),
    ('circle', r'formation: must be a mapping'),
])
def test_bad_formations_name_the_field(data, message):
    with pytest.raises(ValueError, match=message):
        parse_formation(data)
