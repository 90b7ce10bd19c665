"""Where to set an object down: the pixel test on the top-view label image.

SGCM paper, Sec. V: "all pixels in the destination cells are iteratively tested until a
pixel is found such that the object can be placed at this pixel as the center and has
no collisions with other objects". Here a candidate centre pixel is free when the
object's footprint (a (2*half_u+1) x (2*half_v+1) pixel box, clearance included) lies
wholly inside the region and covers no pixel whose label is an obstacle. All candidates
are tested at once with an integral image (a box-sum per pixel), and the first free one
in **row-major order from the region's top-left pixel** (image row 0 = largest world y,
then increasing column = increasing x) is returned. Row-major packing from a corner
leaves the most room for further objects in the same cell (a cell centre would split
it), which matters because SGCM lets several objects share a cell.

Which labels are obstacles is the caller's choice: other objects and, when the object
must rest on one table, everything that is not that table (ground, other tables), so a
footprint never hangs over an edge. The carried object itself and the arms are not
obstacles (the arm is at home when the image is taken; the object leaves its spot).
"""
from __future__ import annotations

import math
from typing import Iterable, Protocol

import numpy as np


class PixelCamera(Protocol):
    """The camera model the pixel test needs (:class:`.camera.TopViewCamera` is one)."""

    width: int
    height: int
    focal: float
    altitude: float

    def world_to_pixel(self, x: float, y: float, z: float = 0.0) -> tuple[float, float]: ...

    def pixel_to_world(self, u: float, v: float, z: float = 0.0) -> tuple[float, float]: ...

PixelRect = tuple[int, int, int, int]  # u_min v_min u_max v_max, inclusive


def find_free_pixel(labels: np.ndarray, obstacle_labels: Iterable[int], region: PixelRect,
                    half_size: int | tuple[int, int]) -> tuple[int, int] | None:
    """First pixel (u, v) in row-major order whose footprint box is inside ``region`` and obstacle-free.

    ``labels`` is an (H, W) integer label image; ``region`` is the inclusive pixel rectangle
    (u_min, v_min, u_max, v_max), clipped to the image; ``half_size`` is the footprint's
    half width in pixels (one int for a square, or (half_u, half_v)). Returns None when no
    centre fits.
    """
    labels = np.asarray(labels)
    if labels.ndim != 2:
        raise ValueError(f'labels must be a 2-D image (got shape {labels.shape})')
    half_u, half_v = (half_size, half_size) if np.isscalar(half_size) else half_size  # type: ignore[misc]
    half_u, half_v = int(half_u), int(half_v)
    if half_u < 0 or half_v < 0:
        raise ValueError(f'half_size must be >= 0 (got {half_size})')
    height, width = labels.shape
    u_min, v_min, u_max, v_max = (int(v) for v in region)
    u_min, v_min = max(u_min, 0), max(v_min, 0)
    u_max, v_max = min(u_max, width - 1), min(v_max, height - 1)
    # Centres whose whole footprint stays inside the region.
    cu0, cu1 = u_min + half_u, u_max - half_u
    cv0, cv1 = v_min + half_v, v_max - half_v
    if cu0 > cu1 or cv0 > cv1:
        return None
    blocked = np.isin(labels[v_min:v_max + 1, u_min:u_max + 1],
                      np.fromiter(obstacle_labels, dtype=np.int64, count=-1))
    # integral[i, j] = number of blocked pixels in rows < i, columns < j of the region.
    integral = np.zeros((blocked.shape[0] + 1, blocked.shape[1] + 1), dtype=np.int64)
    integral[1:, 1:] = blocked.cumsum(axis=0).cumsum(axis=1)
    size_u, size_v = 2 * half_u + 1, 2 * half_v + 1
    # Box sums for every footprint's top-left corner (r, c) in region coordinates.
    counts = (integral[size_v:, size_u:] - integral[:-size_v, size_u:]
              - integral[size_v:, :-size_u] + integral[:-size_v, :-size_u])
    free_rows, free_cols = np.nonzero(counts == 0)  # row-major order
    if free_rows.size == 0:
        return None
    return int(u_min + free_cols[0] + half_u), int(v_min + free_rows[0] + half_v)


def region_to_pixels(camera: PixelCamera, region: tuple[float, float, float, float],
                     z: float) -> PixelRect | None:
    """Inclusive rectangle of the pixels lying wholly inside the world rectangle ``region``
    (on the plane at height ``z``), clipped to the image; None if no pixel is.

    Pixel (u, v) covers [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5], so a footprint made of
    these pixels never pokes out of the region.
    """
    xmin, ymin, xmax, ymax = region
    u0, v0 = camera.world_to_pixel(xmin, ymax, z)  # top-left corner in the image
    u1, v1 = camera.world_to_pixel(xmax, ymin, z)
    tol = 1e-6  # a region edge exactly on a pixel border keeps that pixel
    pixel = (math.ceil(u0 + 0.5 - tol), math.ceil(v0 + 0.5 - tol),
             math.floor(u1 - 0.5 + tol), math.floor(v1 - 0.5 + tol))
    u_min, v_min = max(pixel[0], 0), max(pixel[1], 0)
    u_max, v_max = min(pixel[2], camera.width - 1), min(pixel[3], camera.height - 1)
    if u_min > u_max or v_min > v_max:
        return None
    return u_min, v_min, u_max, v_max


def meters_to_pixels(camera: PixelCamera, length: float, z: float) -> float:
    """Length in pixels of ``length`` metres lying on the plane at height ``z``."""
    return length * camera.focal / (camera.altitude - z)


def find_place_position(camera: PixelCamera, labels: np.ndarray, obstacle_labels: Iterable[int],
                        region: tuple[float, float, float, float], half_extent: float,
                        z: float) -> tuple[float, float] | None:
    """World (x, y) on the plane at height ``z`` where a square footprint of half side ``half_extent``
    (m, clearance included) fits inside ``region`` clear of obstacles, or None.

    The footprint is rounded up to whole pixels (a box of 2h + 1 pixels with
    h + 0.5 >= half_extent in pixels) so a free pixel box always covers it.
    """
    pixels = region_to_pixels(camera, region, z)
    if pixels is None:
        return None
    half = max(0, math.ceil(meters_to_pixels(camera, half_extent, z) - 0.5 - 1e-9))
    found = find_free_pixel(labels, obstacle_labels, pixels, half)
    if found is None:
        return None
    return camera.pixel_to_world(found[0], found[1], z)
