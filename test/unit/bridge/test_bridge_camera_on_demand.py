"""The camera renders only for a consumer: subscribers of its image topics, or a get_frame request.

Also which renderer a scene uses: pybullet's EGL plugin where it loads (``auto``), TinyRenderer
otherwise, and why. The publisher runs in-process on a private context with the real scene.
"""
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
import rclpy
from bridge_interfaces.srv import GetCameraFrame
from builtin_interfaces.msg import Time
from rclpy.context import Context
from rclpy.node import Node
from sensor_msgs.msg import Image

from collab_tools.images import image_array
from collab_tools.parameters import NodeParameters
from collab_tools.qos import SENSOR_IN
from pybullet_bridge.camera_adapter import CameraPublisher
from pybullet_bridge.core.renderer import EGL, TINY, RendererError, choose_renderer
from pybullet_bridge.core.scenario import load_scenario
from pybullet_bridge.core.scene import Scene

TABLETOP = Path(__file__).resolve().parents[3] / 'config' / 'scenarios' / 'test_tabletop.yaml'


# --- which renderer ----------------------------------------------------------------------------
def test_tiny_is_used_as_asked_without_touching_the_plugin():
    def load(path):
        raise AssertionError('the plugin must not be loaded')
    assert choose_renderer(TINY, load).name == TINY


def test_auto_takes_the_plugin_where_it_loads():
    loaded = []
    choice = choose_renderer('auto', lambda path: loaded.append(path) or 3, plugin_path='/x/eglRenderer.so')
    assert (choice.name, loaded) == (EGL, ['/x/eglRenderer.so'])
    assert 'loaded' in choice.reason


@pytest.mark.parametrize('path, load, reason', [
    (None, lambda path: 0, 'no eglRenderer plugin'),
    ('/x/eglRenderer.so', lambda path: -1, 'did not load'),
    ('/x/eglRenderer.so', lambda path: (_ for _ in ()).throw(p.error('cannot load plugin')), 'cannot load plugin'),
])
def test_auto_falls_back_to_tiny_with_the_reason_and_egl_refuses(path, load, reason):
    choice = choose_renderer('auto', load, plugin_path=path)
    assert choice.name == TINY and choice.reason.startswith('fallback') and reason in choice.reason
    with pytest.raises(RendererError, match=reason):
        choose_renderer(EGL, load, plugin_path=path)


def test_auto_on_this_machine_renders_the_same_labels_up_to_object_borders():
    """EGL (software Mesa here) vs TinyRenderer on the SGCM table: each object is seen where it is;
    only border pixels may differ (measured 0.8 % of the frame on an SGCM case)."""
    scenario = load_scenario(TABLETOP)
    with Scene(scenario, renderer=TINY) as tiny, Scene(scenario, renderer='auto') as auto:
        assert tiny.renderer.name == TINY
        assert auto.renderer.name in (EGL, TINY) and auto.renderer.reason
        a, b = tiny.render(), auto.render()
    assert set(np.unique(a.labels)) == set(np.unique(b.labels))
    differ = np.count_nonzero(a.labels != b.labels)
    assert differ <= 0.02 * a.labels.size
    if auto.renderer.name == TINY:
        assert differ == 0 and np.array_equal(a.rgb, b.rgb)


# --- rendering only for consumers ----------------------------------------------------------------
@pytest.fixture
def camera():
    context = Context()
    rclpy.init(context=context)
    node = Node('camera_under_test', context=context, start_parameter_services=False)
    scene = Scene(load_scenario(TABLETOP))
    publisher = CameraPublisher(node, NodeParameters(node), 'top_camera')
    publisher.on_scene_loaded(scene, Time())
    yield node, scene, publisher
    node.destroy_node()
    scene.close()
    context.try_shutdown()


def run_ticks(scene, publisher, seconds):
    for _ in range(round(seconds / 0.01)):
        scene.step(2)
        stamp_ns = round(scene.sim_time * 1e9)
        publisher.publish_due(scene, Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9))


def test_no_subscriber_and_no_request_renders_no_frame(camera):
    node, scene, publisher = camera
    run_ticks(scene, publisher, 2.0)          # ten camera periods at 5 Hz
    assert scene.frames_rendered == 0


def test_a_subscriber_gets_a_frame_every_period(camera):
    node, scene, publisher = camera
    node.create_subscription(Image, 'top_camera/labels', lambda msg: None, SENSOR_IN)
    assert publisher.wants_frames()
    run_ticks(scene, publisher, 1.0)
    assert scene.frames_rendered == 5


def test_get_frame_returns_the_current_state(camera):
    node, scene, publisher = camera
    run_ticks(scene, publisher, 0.5)
    cube = scene.entity('red_1')
    p.resetBasePositionAndOrientation(cube.body_ids[0], [0.05, -0.05, 0.415], [0, 0, 0, 1],
                                      physicsClientId=scene.client)
    response = publisher._on_get_frame(GetCameraFrame.Request(with_labels=True), GetCameraFrame.Response())
    assert response.success and scene.frames_rendered == 1
    stamp = response.image.header.stamp
    assert stamp.sec + stamp.nanosec * 1e-9 == pytest.approx(scene.sim_time)
    assert response.labels.header.stamp == stamp and response.camera_info.header.stamp == stamp
    assert list(response.camera_info.k) == pytest.approx(scene.camera.intrinsics().flatten())
    now = scene.render()
    assert np.array_equal(image_array(response.labels), now.labels)
    assert np.array_equal(image_array(response.image), now.rgb)
    # the moved cube is seen where it was put
    rows, cols = np.nonzero(now.labels == cube.label)
    u, v = scene.camera.world_to_pixel(0.05, -0.05, 0.43)
    assert abs(cols.mean() - u) < 2 and abs(rows.mean() - v) < 2
    # without labels, only the image
    response = publisher._on_get_frame(GetCameraFrame.Request(with_labels=False), GetCameraFrame.Response())
    assert response.success and len(response.labels.data) == 0 and len(response.image.data) > 0


def test_get_frame_is_refused_while_the_camera_is_off(camera):
    node, scene, publisher = camera
    publisher.publish_camera = False
    response = publisher._on_get_frame(GetCameraFrame.Request(with_labels=True), GetCameraFrame.Response())
    assert not response.success and 'publish_camera' in response.message
    assert scene.frames_rendered == 0
