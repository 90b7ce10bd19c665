#!/usr/bin/env python3
"""Regenerate demo_map.png: a 6 x 6 m occupancy image (0.05 m/px) for demo_mobile.yaml.

White is free, black is occupied. Row 0 is the top (largest y) of the map; the
scenario puts the bottom-left corner at world (-3, -3).
Run: python3 config/maps/make_demo_map.py
"""
from pathlib import Path

import cv2
import numpy as np

RESOLUTION = 0.05              # m per pixel, as in demo_mobile.yaml
ORIGIN = (-3.0, -3.0)          # world x, y of the bottom-left corner
SIZE_PX = 120                  # 6 m / 0.05 m
# Obstacles as world rectangles (xmin, ymin, xmax, ymax), clear of the robots' start poses.
OBSTACLES = [
    (-0.6, 0.4, 0.6, 0.6),     # low wall across the middle
    (2.0, 1.4, 2.6, 2.4),      # cabinet in the north-east
    (-2.6, -0.6, -2.2, 0.6),   # bench along the west wall
]


def world_to_pixel(x: float, y: float) -> tuple[int, int]:
    """(column, row) of the pixel corner at world (x, y)."""
    return round((x - ORIGIN[0]) / RESOLUTION), round(SIZE_PX - (y - ORIGIN[1]) / RESOLUTION)


def make_map() -> np.ndarray:
    image = np.full((SIZE_PX, SIZE_PX), 255, dtype=np.uint8)
    for xmin, ymin, xmax, ymax in OBSTACLES:
        col0, row1 = world_to_pixel(xmin, ymin)
        col1, row0 = world_to_pixel(xmax, ymax)
        # cv2.rectangle includes both corners, hence the -1 on the exclusive ends.
        cv2.rectangle(image, (col0, row0), (col1 - 1, row1 - 1), color=0, thickness=-1)
    return image


if __name__ == '__main__':
    output = Path(__file__).resolve().with_name('demo_map.png')
    cv2.imwrite(str(output), make_map())
    print(f'wrote {output}')
