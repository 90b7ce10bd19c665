"""Occupancy-map images: read one as grey values, read a Nav2 map YAML, cover occupied cells with rectangles.

The ``obstacles.map`` field of a scenario turns an image into static boxes (:mod:`.obstacles`);
the role engine reads the same images and the same Nav2 map YAMLs (:func:`read_nav2_map`), so the
simulated walls and the planner's map come from one file. OpenCV only reads the file.

Nav2 map YAML (nav2_map_server's format, read as map_server reads it)::

    image: map.png            # required; relative to the YAML file's directory (or absolute)
    resolution: 0.05          # required, m per pixel, > 0
    origin: [-2.5, -2.5, 0.0] # required, [x, y, yaw]: world pose of the image's bottom-left corner
                              # (yaw rad, counter-clockwise; the image is rotated about that corner)
    negate: 0                 # required, 0/1 (or false/true): 1 = white is occupied
    occupied_thresh: 0.65     # required, in [0, 1]: a pixel is occupied when p > occupied_thresh
    free_thresh: 0.25         # required, in [0, 1], <= occupied_thresh: free when p < free_thresh
    mode: trinary             # optional, only trinary (the default): other pixels are unknown

with p = (255 - shade) / 255 (shade / 255 when negated), shade the mean of the colour channels
(alpha ignored, 16-bit images scaled to 8 bits). Cells are 100 (occupied), 0 (free), -1 (unknown)
in image rows (row 0 = the top of the image = the largest map y).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import cv2
import numpy as np
from collab_tools.core.errors import ConfigurationError
from collab_tools.core.fields import Fields, fail, read_yaml_file
from collab_tools.core.input_files import read_image_bytes, shown_path
from collab_tools.core.settings import echo

from .errors import ScenarioError

NAV2_FIELDS = ('image', 'resolution', 'origin', 'negate', 'occupied_thresh', 'free_thresh', 'mode')
NAV2_MODES = ('trinary',)
OCCUPIED, FREE, UNKNOWN = 100, 0, -1


#: Most boxes a map may turn into. Measured (pybullet DIRECT, touching 1 cm boxes, load 3.3): 5,000
#: static boxes take 3.9 ms per physics step, all of the 4.2 ms a 240 Hz step has in real time;
#: 10,000 take 25 ms, 20,000 take 95 ms (and 4.6 s to build); a random 1000 x 1000 image makes
#: 230,000. The bridge also bounds the whole scene by this (core.scenario).
MAX_MAP_BOXES = 4000


def occupancy_to_rectangles(occupied: np.ndarray, limit: int | None = None) -> list[tuple[int, int, int, int]]:
    """Cover a boolean grid with non-overlapping rectangles (row0, col0, row1, col1), ends exclusive.

    Each row is split into maximal runs of occupied cells; a run continues the
    rectangle above it when it spans exactly the same columns. The union of the
    rectangles equals ``occupied`` exactly. With ``limit``, stops (unsorted, incomplete) as soon as
    more than ``limit`` rectangles are found: the caller refuses the map by their count.
    """
    grid = np.asarray(occupied)
    if grid.ndim != 2:
        raise ValueError(f'occupancy grid must be 2-D (got shape {grid.shape})')
    grid = grid.astype(bool)
    rectangles: list[tuple[int, int, int, int]] = []
    open_since: dict[tuple[int, int], int] = {}  # (col0, col1) -> first row of the open rectangle
    for row in range(grid.shape[0] + 1):
        runs: set[tuple[int, int]] = set()
        if row < grid.shape[0]:
            # Run boundaries are where the padded row changes value.
            padded = np.concatenate(([False], grid[row], [False])).astype(np.int8)
            edges = np.flatnonzero(np.diff(padded))
            runs = {(int(start), int(stop)) for start, stop in zip(edges[::2], edges[1::2])}
        for span in sorted(set(open_since) - runs):
            rectangles.append((open_since.pop(span), span[0], row, span[1]))
        if limit is not None and len(rectangles) + len(runs) > limit:
            return rectangles + [(row, a, row + 1, b) for a, b in runs]
        for span in runs - set(open_since):
            open_since[span] = row
    return sorted(rectangles)


def _decode_image(image_path: Path, field_path: str, flags: int, error) -> np.ndarray:
    """The image file ``image_path`` decoded with ``flags``, its size checked from its header before
    decoding (collab_tools.core.input_files: regular file, size and pixel bounds, truncation)."""
    where = f'{field_path}: image file'
    data, width, height = read_image_bytes(image_path, where, error)
    image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), flags)
    if image is None or image.shape[:2] != (height, width):
        raise error(f"{where} '{shown_path(image_path)}': cannot be decoded (a damaged or truncated image)")
    return image


def read_grey_image(image_path: Path, field_path: str, error=ScenarioError) -> np.ndarray:
    """The occupancy image a map field names, as 8-bit grey; errors start with ``field_path``."""
    return _decode_image(Path(image_path), field_path, cv2.IMREAD_GRAYSCALE, error)


def read_shade_image(image_path: Path, field_path: str, error=ScenarioError) -> np.ndarray:
    """The image as map_server sees it: mean of the colour channels (alpha ignored), 0..255 floats."""
    image = _decode_image(Path(image_path), field_path, cv2.IMREAD_UNCHANGED, error)
    scale = 257.0 if image.dtype == np.uint16 else 1.0
    if image.ndim == 3:    # the mean straight from the integers: no float copy of every channel
        image = image[:, :, :3].mean(axis=2, dtype=float) if image.shape[2] >= 3 else image[:, :, 0]
    return image.astype(float) / scale


@dataclass(frozen=True)
class Nav2Map:
    """A Nav2 map YAML and its image, read (module docstring). ``cells`` is (rows, cols) int8 in image
    rows: 100 occupied, 0 free, -1 unknown. ``extra`` holds the caller's additional keys."""

    source: Path
    image: Path
    resolution: float
    origin: tuple[float, float, float]
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str
    cells: np.ndarray
    extra: dict

    @property
    def shape(self) -> tuple[int, int]:
        return self.cells.shape

    def occupied(self, unknown_is_occupied: bool = True) -> np.ndarray:
        """Boolean (rows, cols) in image rows: occupied cells (and unknown ones, by default)."""
        return (self.cells == OCCUPIED) | ((self.cells == UNKNOWN) if unknown_is_occupied else False)

    def map_to_world(self, points: np.ndarray) -> np.ndarray:
        """(K, 2) points in the map frame (bottom-left corner of the image, x along a row) to world."""
        x0, y0, yaw = self.origin
        c, s = math.cos(yaw), math.sin(yaw)
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        return np.column_stack([x0 + c * p[:, 0] - s * p[:, 1], y0 + s * p[:, 0] + c * p[:, 1]])

    def boxes(self, unknown_is_occupied: bool = True,
              limit: int | None = None) -> list[tuple[tuple[float, float], tuple[float, float], float]]:
        """(world centre, size, yaw) of rectangles that cover the occupied cells exactly (with ``limit``:
        more than ``limit`` of them, incomplete, when the map needs more)."""
        rows = self.shape[0]
        r = self.resolution
        out = []
        for row0, col0, row1, col1 in occupancy_to_rectangles(self.occupied(unknown_is_occupied), limit):
            centre = np.array([[(col0 + col1) / 2.0 * r, (rows - (row0 + row1) / 2.0) * r]])
            world = self.map_to_world(centre)[0]
            out.append(((float(world[0]), float(world[1])), ((col1 - col0) * r, (row1 - row0) * r),
                        float(self.origin[2])))
        return out

    def axis_aligned(self, unknown_is_occupied: bool = True) -> tuple[np.ndarray, tuple[float, float]]:
        """Occupancy on an unrotated grid of the same resolution: (occupied[iy, ix] y-up, world origin x, y).

        With yaw 0 the image itself (flipped to y-up). Otherwise the grid covers the rotated image's
        bounding box; each cell takes the image pixel under its centre (nearest), and cells outside
        the image are unknown (occupied when ``unknown_is_occupied``).
        """
        occupied = self.occupied(unknown_is_occupied)
        x0, y0, yaw = self.origin
        if abs(math.remainder(yaw, 2.0 * math.pi)) < 1e-12:
            return np.flipud(occupied).copy(), (x0, y0)
        rows, cols = occupied.shape
        r = self.resolution
        corners = self.map_to_world(np.array([[0, 0], [cols * r, 0], [0, rows * r], [cols * r, rows * r]]))
        low, high = corners.min(axis=0), corners.max(axis=0)
        nx, ny = (int(math.ceil((high[i] - low[i]) / r - 1e-9)) for i in (0, 1))
        iy, ix = np.mgrid[0:ny, 0:nx]
        centres = np.column_stack([low[0] + (ix.ravel() + 0.5) * r, low[1] + (iy.ravel() + 0.5) * r])
        c, s = math.cos(yaw), math.sin(yaw)
        d = centres - np.array([x0, y0])
        mx, my = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]      # world -> map frame
        col, row_up = np.floor(mx / r).astype(int), np.floor(my / r).astype(int)
        inside = (col >= 0) & (col < cols) & (row_up >= 0) & (row_up < rows)
        grid = np.full(len(centres), unknown_is_occupied, dtype=bool)
        grid[inside] = occupied[rows - 1 - row_up[inside], col[inside]]
        return grid.reshape(ny, nx), (float(low[0]), float(low[1]))


def _negate_flag(value, path: str, error) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    raise fail(path, f'must be 0 or 1 (or false / true) (got {echo(value)})', error=error)


def nav2_map_from_data(data, source: Path, where: str, *, error=ScenarioError,
                       extra_fields: Iterable[str] = ()) -> Nav2Map:
    """A Nav2 map from an already-parsed YAML mapping whose relative image path is relative to
    ``source``'s directory; errors of type ``error`` start with ``where`` and the field."""
    extra_fields = tuple(extra_fields)
    fields = Fields(data, where, allowed=NAV2_FIELDS + extra_fields, error=error)
    image_field = fields.string('image')
    resolution = fields.number('resolution', gt=0.0)
    origin_value = fields.raw('origin')
    if not isinstance(origin_value, (list, tuple)) or len(origin_value) != 3:
        raise fail(fields.path_of('origin'), f'must be a list of 3 numbers [x, y, yaw] (got {echo(origin_value)})',
                   error=error)
    origin = fields.vector('origin', 3)
    negate = _negate_flag(fields.raw('negate'), fields.path_of('negate'), error)
    occupied_thresh = fields.number('occupied_thresh', ge=0.0, le=1.0)
    free_thresh = fields.number('free_thresh', ge=0.0, le=1.0)
    if free_thresh > occupied_thresh:
        raise fail(fields.path_of('free_thresh'), f'must be <= occupied_thresh {occupied_thresh:g} '
                   f'(got {free_thresh:g})', error=error)
    mode = fields.string('mode', 'trinary')
    if mode not in NAV2_MODES:
        raise fail(fields.path_of('mode'), f"must be {' or '.join(NAV2_MODES)} (got {echo(mode)}; scale and raw "
                   'maps carry costs, not occupancy)', error=error)
    image_path = Path(image_field)
    if not image_path.is_absolute():
        image_path = (Path(source).parent / image_path).resolve()
    shade = read_shade_image(image_path, fields.path_of('image'), error)
    occupancy = shade / 255.0 if negate else (255.0 - shade) / 255.0
    cells = np.full(shade.shape, UNKNOWN, dtype=np.int8)
    cells[occupancy > occupied_thresh] = OCCUPIED
    cells[occupancy < free_thresh] = FREE
    cells.setflags(write=False)
    extra = {key: data[key] for key in extra_fields if key in data}
    return Nav2Map(Path(source), image_path, resolution, origin, negate, occupied_thresh, free_thresh, mode,
                   cells, extra)


def read_nav2_map(path: str | Path, *, error=ScenarioError, extra_fields: Iterable[str] = ()) -> Nav2Map:
    """Read a Nav2 map YAML and its image (module docstring); ``error`` (a ConfigurationError) names
    the field; ``extra_fields``: keys the caller allows besides Nav2's (returned in ``extra``)."""
    if not (isinstance(error, type) and issubclass(error, ConfigurationError)):
        raise TypeError('error must be a ConfigurationError subclass')
    path = Path(path)
    data = read_yaml_file(path, 'map file', error)
    return nav2_map_from_data(data, path, str(path), error=error, extra_fields=extra_fields)
