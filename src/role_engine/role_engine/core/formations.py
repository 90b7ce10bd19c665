"""Unlabeled destinations (roles) from formations: circle, square, line, diamond or explicit points.

The paper's roles are destination points "organized in formations such as circles,
squares or lines" (Sec. III) and a diamond (Sec. V-B); which robot takes which point is
left to Group Role Assignment. A formation is described in YAML as::

    formation: {type: circle, center: [0.0, 0.0], radius: 1.0, count: 4, rotation: 0.0}
    formation: {type: square, center: [0.0, 0.0], side: 1.5, count: 8}
    formation: {type: line, center: [0.0, 1.0], length: 2.0, count: 3, rotation: 1.5708}
    formation: {type: diamond, center: [0.0, 0.0], size: 1.2, count: 4}
    formation: {type: points, points: [[1.0, 0.0], [0.0, 1.0]]}

``rotation`` (rad, default 0) turns the shape about its centre. Circle points start on
the +x side of the centre; square points start at the corner (+side/2, +side/2);
diamond points start at the vertex (+size/2, 0) (``size`` is the vertex-to-vertex width);
polygon points are evenly spaced along the perimeter, so 4 points are the vertices and 8
add the edge midpoints. Line points are evenly spaced along ``length`` (one point: the centre).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from collab_tools.core.fields import Fields, check_vector, fail, join_path, require_list

from .errors import RoleEngineError

FORMATION_TYPES = ('circle', 'square', 'line', 'diamond', 'points')
_SIZE_FIELD = {'circle': 'radius', 'square': 'side', 'line': 'length', 'diamond': 'size'}


def _rotate(points: np.ndarray, center, rotation: float) -> np.ndarray:
    c, s = math.cos(rotation), math.sin(rotation)
    return points @ np.array([[c, s], [-s, c]]) + np.asarray(center, dtype=float)


def points_along_polygon(vertices: np.ndarray, count: int) -> np.ndarray:
    """``count`` points evenly spaced along a closed polygon's perimeter, from vertex 0."""
    closed = np.vstack([vertices, vertices[:1]])
    cumulative = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(closed, axis=0).T))])
    samples = np.arange(count) * cumulative[-1] / count
    return np.stack([np.interp(samples, cumulative, closed[:, k]) for k in range(2)], axis=1)


def circle_formation(center, radius: float, count: int, rotation: float = 0.0) -> np.ndarray:
    angles = rotation + 2.0 * math.pi * np.arange(count) / count
    return np.asarray(center, dtype=float) + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)


def square_formation(center, side: float, count: int, rotation: float = 0.0) -> np.ndarray:
    half = side / 2.0
    corners = np.array([[half, half], [-half, half], [-half, -half], [half, -half]])
    return _rotate(points_along_polygon(corners, count), center, rotation)


def diamond_formation(center, size: float, count: int, rotation: float = 0.0) -> np.ndarray:
    half = size / 2.0
    vertices = np.array([[half, 0.0], [0.0, half], [-half, 0.0], [0.0, -half]])
    return _rotate(points_along_polygon(vertices, count), center, rotation)


def line_formation(center, length: float, count: int, rotation: float = 0.0) -> np.ndarray:
    offsets = np.zeros(1) if count == 1 else np.linspace(-length / 2.0, length / 2.0, count)
    return _rotate(np.stack([offsets, np.zeros_like(offsets)], axis=1), center, rotation)


_ALL_FIELDS = ('type', 'center', 'count', 'rotation', 'points', *_SIZE_FIELD.values())
_BUILDERS = {'circle': circle_formation, 'square': square_formation,
             'line': line_formation, 'diamond': diamond_formation}


def parse_formation(data: Any, path: str = 'formation') -> np.ndarray:
    """(count, 2) destination points of a formation mapping (format in the module docstring)."""
    kind = Fields(data, path, allowed=_ALL_FIELDS, error=RoleEngineError).string('type')
    if kind not in FORMATION_TYPES:
        raise fail(join_path(path, 'type'), f"unknown formation '{kind}' (allowed: {', '.join(FORMATION_TYPES)})",
                   RoleEngineError)
    if kind == 'points':
        fields = Fields(data, path, allowed=('type', 'points'), error=RoleEngineError)
        items = require_list(fields.raw('points'), fields.path_of('points'), RoleEngineError)
        if not items:
            raise fail(fields.path_of('points'), 'must list at least one point [x, y]', RoleEngineError)
        points = np.array([check_vector(item, join_path(fields.path_of('points'), i), 2, error=RoleEngineError)
                           for i, item in enumerate(items)])
    else:
        size_field = _SIZE_FIELD[kind]
        fields = Fields(data, path, allowed=('type', 'center', size_field, 'count', 'rotation'),
                        error=RoleEngineError)
        points = _BUILDERS[kind](fields.vector('center', 2), fields.number(size_field, gt=0.0),
                                 fields.integer('count', ge=1, le=10000), fields.number('rotation', 0.0))
    _check_distinct(points, path)
    return points


def _check_distinct(points: np.ndarray, path: str) -> None:
    """Two roles at the same place cannot both be played; reject them early."""
    for i in range(len(points)):
        for j in range(i + 1, len(points)):
            if np.allclose(points[i], points[j], atol=1e-9):
                raise fail(path, f'destinations {i} and {j} coincide at '
                                 f'({points[i][0]:.3f}, {points[i][1]:.3f})', RoleEngineError)
