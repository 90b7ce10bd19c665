"""State estimation from the top-view camera (Section V: "the perception is vision-based").

The bridge publishes a per-pixel label image (ground-truth segmentation, as the paper
assumes) with a legend naming each label's entity and kind. For every cube label seen:
its pixel centroid is projected onto the plane of the cubes' top faces, giving the
cell; its colour class is the task colour nearest to the segment's mean RGB in
chromaticity (r, g, b divided by their sum, so shading does not matter). Ground-truth
poses are never used.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from collab_tools.core.camera_geometry import TopViewGeometry

from .task_config import TaskConfig


@dataclass(frozen=True)
class SeenObject:
    name: str
    label: int
    cell: int | None      # None when outside the grid
    colour: int
    x: float
    y: float
    pixels: int


@dataclass(frozen=True)
class StateEstimate:
    counts: np.ndarray              # (cells, colours)
    objects: list[SeenObject]

    def objects_in(self, cell: int, colour: int) -> list[SeenObject]:
        return [o for o in self.objects if o.cell == cell and o.colour == colour]

    @property
    def off_grid(self) -> list[SeenObject]:
        return [o for o in self.objects if o.cell is None]


def classify_colour(mean_rgb: np.ndarray, palette: np.ndarray) -> int:
    """Index of the palette colour nearest in chromaticity."""
    def chroma(rgb):
        rgb = np.asarray(rgb, dtype=float)
        return rgb / np.maximum(rgb.sum(axis=-1, keepdims=True), 1e-9)
    return int(np.argmin(np.linalg.norm(chroma(palette) - chroma(mean_rgb), axis=1)))


def estimate_state(labels: np.ndarray, rgb: np.ndarray, cube_labels: dict[int, str], view: TopViewGeometry,
                   task: TaskConfig, top_height: float, min_pixels: int = 4) -> StateEstimate:
    """Counts per cell and colour of the cubes seen in one labelled frame."""
    labels = np.asarray(labels)
    rgb = np.asarray(rgb)
    if labels.ndim != 2 or rgb.shape[:2] != labels.shape or rgb.ndim != 3 or rgb.shape[2] < 3:
        raise ValueError(f'label image {labels.shape} and rgb image {rgb.shape} must be HxW and HxWx3')
    size = int(labels.max()) + 1 if labels.size else 1
    flat = labels.reshape(-1).astype(np.int64)
    pixels = np.bincount(flat, minlength=size)
    rows, cols = np.indices(labels.shape)
    sum_u = np.bincount(flat, weights=cols.reshape(-1), minlength=size)
    sum_v = np.bincount(flat, weights=rows.reshape(-1), minlength=size)
    colour_sums = [np.bincount(flat, weights=rgb[:, :, c].reshape(-1).astype(float), minlength=size)
                   for c in range(3)]
    palette = np.array(task.colour_rgb) * 255.0
    counts = np.zeros((task.cells, len(task.colours)), dtype=np.int64)
    objects = []
    for label, name in sorted(cube_labels.items()):
        if label >= size or pixels[label] < min_pixels:
            continue  # not visible (or only a sliver): not counted
        n = pixels[label]
        u, v = sum_u[label] / n, sum_v[label] / n
        x, y = view.pixel_to_world(np.array([[u, v]]), top_height)[0]
        colour = classify_colour(np.array([s[label] / n for s in colour_sums]), palette)
        cell = task.workspace.cell_of_point(task.rows, task.cols, float(x), float(y))
        if cell is not None:
            counts[cell, colour] += 1
        objects.append(SeenObject(name, int(label), cell, colour, float(x), float(y), int(n)))
    return StateEstimate(counts, objects)
