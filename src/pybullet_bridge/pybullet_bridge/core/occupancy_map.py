"""Occupancy-map images: read one as grey values and cover its occupied cells with rectangles.

The ``obstacles.map`` field of a scenario turns an image into static boxes (:mod:`.obstacles`);
the role engine reads the same images. OpenCV only reads the file.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from collab_tools.core.fields import fail

from .errors import ScenarioError


def occupancy_to_rectangles(occupied: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Cover a boolean grid with non-overlapping rectangles (row0, col0, row1, col1), ends exclusive.

    Each row is split into maximal runs of occupied cells; a run continues the
    rectangle above it when it spans exactly the same columns. The union of the
    rectangles equals ``occupied`` exactly.
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
        for span in runs - set(open_since):
            open_since[span] = row
    return sorted(rectangles)


def read_grey_image(image_path: Path, field_path: str) -> np.ndarray:
    """The occupancy image a map field names, as 8-bit grey; errors start with ``field_path``."""
    if not image_path.is_file():
        raise fail(field_path, f"image file '{image_path}' does not exist", error=ScenarioError)
    grey = cv2.imread(str(image_path), cv2.IMREAD_GRAYSCALE)
    if grey is None:
        raise fail(field_path, f"cannot read '{image_path}' as an image", error=ScenarioError)
    return grey
