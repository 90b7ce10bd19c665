"""The placement pixel test (SGCM paper Sec. V) on hand-made label images."""
import math

import numpy as np
import pytest

from pybullet_bridge.core.camera import TopViewCamera
from pybullet_bridge.core.placement import (
    find_free_pixel, find_place_position, meters_to_pixels, region_to_pixels,
)
from pybullet_bridge.core.scenario import CameraConfig

TABLE, CUBE_A, CUBE_B, CARRIED, ARM = 1, 2, 3, 4, 5


def brute_force(labels, obstacles, region, half_u, half_v):
    """Reference: test every pixel of the region in row-major order, one by one."""
    u_min, v_min, u_max, v_max = region
    blocked = np.isin(labels, list(obstacles))
    for v in range(v_min, v_max + 1):
        for u in range(u_min, u_max + 1):
            if u - half_u < u_min or u + half_u > u_max or v - half_v < v_min or v + half_v > v_max:
                continue
            if not blocked[v - half_v:v + half_v + 1, u - half_u:u + half_u + 1].any():
                return u, v
    return None


def test_first_free_pixel_is_the_top_left_most_in_row_major_order():
    labels = np.full((20, 30), TABLE, np.uint16)
    assert find_free_pixel(labels, {CUBE_A}, (5, 3, 25, 15), 2) == (7, 5)
    # An object in the top-left corner pushes the first spot right along the same rows.
    labels[3:8, 5:10] = CUBE_A
    assert find_free_pixel(labels, {CUBE_A}, (5, 3, 25, 15), 2) == (12, 5)


def test_footprint_stays_inside_the_region():
    labels = np.full((20, 20), TABLE, np.uint16)
    u, v = find_free_pixel(labels, {CUBE_A}, (4, 6, 12, 16), (3, 2))
    assert (u - 3, v - 2) == (4, 6)
    # The region is exactly one footprint wide: a single candidate, its centre.
    assert find_free_pixel(labels, {CUBE_A}, (4, 6, 10, 10), (3, 2)) == (7, 8)
    # One pixel narrower: nothing fits, although no pixel is an obstacle.
    assert find_free_pixel(labels, {CUBE_A}, (4, 6, 9, 10), (3, 2)) is None


def test_full_region_returns_none():
    labels = np.full((16, 16), TABLE, np.uint16)
    labels[::4, ::4] = CUBE_A  # a lattice of obstacle pixels 4 apart: no 5x5 box is clear
    assert find_free_pixel(labels, {CUBE_A}, (0, 0, 15, 15), 2) is None
    assert find_free_pixel(labels, {CUBE_A}, (0, 0, 15, 15), 1) == (2, 1)  # 3x3 between lattice points


def test_carried_object_and_arm_are_not_obstacles():
    labels = np.full((20, 20), TABLE, np.uint16)
    labels[2:9, 2:9] = CARRIED  # the object to move sits in the region itself
    labels[10:12, 0:20] = ARM   # an arm link across the image
    obstacles = {CUBE_A, CUBE_B}
    assert find_free_pixel(labels, obstacles, (2, 2, 18, 18), 3) == (5, 5)
    # Counting the carried object would push the spot past it.
    assert find_free_pixel(labels, obstacles | {CARRIED}, (2, 2, 18, 18), 3) == (12, 5)


def test_region_is_clipped_to_the_image_and_edges_count_as_outside():
    labels = np.full((10, 10), TABLE, np.uint16)
    assert find_free_pixel(labels, {CUBE_A}, (-5, -5, 4, 4), 1) == (1, 1)
    assert find_free_pixel(labels, {CUBE_A}, (12, 0, 20, 9), 1) is None
    with pytest.raises(ValueError, match='2-D'):
        find_free_pixel(np.zeros(5), {CUBE_A}, (0, 0, 4, 0), 0)


@pytest.mark.parametrize('seed', range(25))
def test_matches_pixel_by_pixel_search_on_random_images(seed):
    rng = np.random.default_rng(seed)
    height, width = rng.integers(8, 40, size=2)
    labels = rng.choice([TABLE, CUBE_A, CUBE_B, CARRIED], size=(height, width),
                        p=[0.93, 0.03, 0.02, 0.02]).astype(np.uint16)
    u0, u1 = sorted(rng.integers(0, width, size=2))
    v0, v1 = sorted(rng.integers(0, height, size=2))
    half_u, half_v = (int(h) for h in rng.integers(0, 4, size=2))
    obstacles = {CUBE_A, CUBE_B}
    expected = brute_force(labels, obstacles, (u0, v0, u1, v1), half_u, half_v)
    assert find_free_pixel(labels, obstacles, (u0, v0, u1, v1), (half_u, half_v)) == expected


@pytest.fixture
def camera():
    return TopViewCamera(CameraConfig(frame_id='top', rate=10.0, width=200, height=200, center=(0.0, 0.0),
                                      altitude=2.0, fov_deg=10.0))


def test_region_pixels_lie_wholly_inside_the_world_region(camera):
    z = 0.4
    region = (-0.1, 0.0, 0.05, 0.12)
    u_min, v_min, u_max, v_max = region_to_pixels(camera, region, z)
    # Every selected pixel's outer edges map back inside the region...
    x0, y1 = camera.pixel_to_world(u_min - 0.5, v_min - 0.5, z)
    x1, y0 = camera.pixel_to_world(u_max + 0.5, v_max + 0.5, z)
    assert region[0] <= x0 and x1 <= region[2] and region[1] <= y0 and y1 <= region[3]
    # ...and one more pixel on any side would not.
    assert camera.pixel_to_world(u_min - 1.5, 0, z)[0] < region[0]
    assert camera.pixel_to_world(u_max + 1.5, 0, z)[0] > region[2]
    assert region_to_pixels(camera, (5.0, 5.0, 6.0, 6.0), z) is None


def test_place_position_round_trip_in_world_coordinates(camera):
    z = 0.4
    labels = np.full((camera.height, camera.width), TABLE, np.uint16)
    region = (-0.05, -0.05, 0.05, 0.05)
    half = 0.02
    x, y = find_place_position(camera, labels, {CUBE_A}, region, half, z)
    # First spot: the top-left corner of the region (largest y, smallest x), footprint inside.
    pixel = 1.0 / meters_to_pixels(camera, 1.0, z)
    assert region[0] + half <= x <= region[0] + half + 1.5 * pixel
    assert region[3] - half - 1.5 * pixel <= y <= region[3] - half
    # Block that spot with another cube: the next spot leaves room for both footprints.
    u, v = camera.world_to_pixel(x, y, z)
    r = math.ceil(meters_to_pixels(camera, 0.015, z))
    labels[round(v) - r:round(v) + r + 1, round(u) - r:round(u) + r + 1] = CUBE_A
    x2, y2 = find_place_position(camera, labels, {CUBE_A}, region, half, z)
    assert y2 == pytest.approx(y, abs=pixel) and x2 - x >= half + 0.015 - pixel
    # Blocking the whole region leaves no spot.
    labels[:, :] = CUBE_A
    assert find_place_position(camera, labels, {CUBE_A}, region, half, z) is None
