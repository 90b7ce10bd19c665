"""The shared top-view camera model against OpenCV's projection, and its error messages."""
import cv2
import numpy as np
import pytest

from collab_tools.core.camera_geometry import (
    LOOKING_DOWN_XYZW, CameraGeometryError, TopViewGeometry, rotation_from_quaternion)

K = np.array([[400.0, 0.0, 319.5], [0.0, 380.0, 239.5], [0.0, 0.0, 1.0]])


def opencv_pixels(geometry: TopViewGeometry, world: np.ndarray) -> np.ndarray:
    """Project (N, 3) world points with cv2.projectPoints (world -> optical = R^T (p - c))."""
    rotation = rotation_from_quaternion(geometry.orientation_xyzw)
    rvec, _ = cv2.Rodrigues(rotation.T)
    tvec = -rotation.T @ np.asarray(geometry.position)
    pixels, _ = cv2.projectPoints(world.reshape(-1, 1, 3), rvec, tvec, geometry.intrinsics, None)
    return pixels.reshape(-1, 2)


@pytest.mark.parametrize('orientation', [
    LOOKING_DOWN_XYZW,
    (0.99, 0.1, 0.05, 0.02),     # slightly tilted and turned
    (0.95, -0.2, 0.1, 0.2),
])
def test_projection_matches_opencv_and_inverts(orientation):
    geometry = TopViewGeometry(K, (0.3, -0.2, 5.0), orientation)
    rng = np.random.default_rng(4)
    points = rng.uniform(-1.5, 1.5, size=(40, 2))
    for z in (0.0, 0.7):
        world = np.column_stack([points, np.full(len(points), z)])
        pixels = geometry.world_to_pixel(points, z)
        assert pixels == pytest.approx(opencv_pixels(geometry, world), abs=1e-9)
        assert geometry.pixel_to_world(pixels, z) == pytest.approx(points, abs=1e-9)


def test_looking_down_axes_and_pixel_size():
    geometry = TopViewGeometry.from_camera_info(K.ravel(), (1.0, 2.0, 4.0))
    assert geometry.world_to_pixel([[1.0, 2.0]])[0] == pytest.approx([319.5, 239.5])
    (u, v), = geometry.world_to_pixel([[1.5, 2.5]])
    assert u > 319.5 and v < 239.5                        # image right = +x, image up = +y
    assert geometry.metres_per_pixel() == pytest.approx(4.0 / 400.0)
    assert geometry.metres_per_pixel(z=2.0) == pytest.approx(2.0 / 400.0)


@pytest.mark.parametrize('call, message', [
    (lambda: TopViewGeometry(np.zeros((3, 3)), (0, 0, 1)), 'focal lengths'),
    (lambda: TopViewGeometry.from_camera_info([1, 0, 0], (0, 0, 1)), '9 entries'),
    (lambda: TopViewGeometry(np.eye(3), (0, 0, 1), (0, 0, 0, 0)), 'quaternion'),
    (lambda: TopViewGeometry(np.eye(3), (0, float('nan'), 1)), 'camera position'),
    (lambda: TopViewGeometry(K, (0, 0, 1)).world_to_pixel([[0.0, 0.0]], z=2.0), 'behind the camera'),
    (lambda: TopViewGeometry(K, (0, 0, 1)).pixel_to_world([[0.0, 0.0]], z=2.0), 'not in front'),
])
def test_bad_inputs_raise_clear_errors(call, message):
    with pytest.raises(CameraGeometryError, match=message):
        call()
