"""A recorder of the camera costs few renders, and a report finds the scene a bag's run simulated.

* With only a compressed subscriber (a bag recorder of ``image_raw/compressed``) the bridge renders
  a frame only when ``compressed_rate`` lets one through, and the frames it renders for get_frame
  feed that stream too.
* pybullet_bridge.report_scene reads the scenario of a recorded run (session.json -> the bridge's
  parameter files -> ``scenario``) into the layout the report's plots and videos draw.
"""
import json
from pathlib import Path

import pytest
import rclpy
from bridge_interfaces.srv import GetCameraFrame
from builtin_interfaces.msg import Time
from rclpy.context import Context
from rclpy.node import Node
from sensor_msgs.msg import CompressedImage

from collab_tools.parameters import NodeParameters
from collab_tools.qos import SENSOR_IN
from pybullet_bridge.camera_adapter import CameraPublisher
from pybullet_bridge.core.scenario import load_scenario
from pybullet_bridge.core.scene import Scene
from pybullet_bridge.report_scene import read_scene, scenario_file_of

CONFIG = Path(__file__).resolve().parents[3] / 'config'
TABLETOP = CONFIG / 'scenarios' / 'test_tabletop.yaml'     # camera at 5 Hz


@pytest.fixture
def camera():
    context = Context()
    rclpy.init(context=context)
    node = Node('recorded_camera_under_test', context=context, start_parameter_services=False)
    scene = Scene(load_scenario(TABLETOP))
    publisher = CameraPublisher(node, NodeParameters(node), 'top_camera')
    publisher.on_scene_loaded(scene, Time())
    published = []
    real_publish = publisher.image_compressed_pub.publish
    publisher.image_compressed_pub.publish = lambda msg: (published.append(msg), real_publish(msg))
    yield node, scene, publisher, published
    node.destroy_node()
    scene.close()
    context.try_shutdown()


def run_ticks(scene, publisher, seconds):
    """About ``seconds`` of simulated time in control ticks of two physics steps."""
    dt = 2 * scene.scenario.world.physics_dt
    for _ in range(round(seconds / dt)):
        scene.step(2)
        stamp_ns = round(scene.sim_time * 1e9)
        publisher.publish_due(scene, Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9))


def test_a_compressed_only_subscriber_costs_a_render_per_throttled_frame(camera):
    node, scene, publisher, published = camera
    publisher.throttle.set_rate(2.0)
    node.create_subscription(CompressedImage, 'top_camera/image_raw/compressed', lambda msg: None, SENSOR_IN)
    run_ticks(scene, publisher, 1.9)       # ten camera periods at 5 Hz, four frames at 2 Hz
    assert len(published) == 4
    assert scene.frames_rendered == 4      # not 10: no frame rendered for nobody


def test_get_frame_feeds_the_recorded_stream_within_its_rate(camera):
    node, scene, publisher, published = camera
    publisher.throttle.set_rate(0.5)
    node.create_subscription(CompressedImage, 'top_camera/image_raw/compressed', lambda msg: None, SENSOR_IN)
    response = publisher._on_get_frame(GetCameraFrame.Request(with_labels=True), GetCameraFrame.Response())
    assert response.success and len(published) == 1
    assert published[0].header.stamp == response.image.header.stamp
    run_ticks(scene, publisher, 1.5)       # the periodic frame is not due for 2 s: no render of its own
    assert (len(published), scene.frames_rendered) == (1, 1)
    run_ticks(scene, publisher, 1.0)
    assert (len(published), scene.frames_rendered) == (2, 2)


def test_the_scene_of_a_recorded_run_is_its_bridges_scenario(tmp_path):
    run = tmp_path / 'run'
    (run / 'bags' / 'demo').mkdir(parents=True)
    (run / 'params').mkdir()
    params = run / 'params' / 'pybullet_bridge.1.yaml'
    params.write_text(f'/**:\n  ros__parameters:\n    scenario: {CONFIG / "scenarios" / "demo_mobile.yaml"}\n')
    command = ['/install/pybullet_bridge/lib/pybullet_bridge/pybullet_bridge', '--ros-args',
               '--params-file', str(CONFIG / 'params' / 'pybullet_bridge.yaml'), '--params-file', str(params)]
    (run / 'session.json').write_text(json.dumps({'nodes': {'pybullet_bridge': {'command': command}}}))
    bag = run / 'bags' / 'demo'
    assert scenario_file_of(bag) == CONFIG / 'scenarios' / 'demo_mobile.yaml'
    layout = read_scene(bag)
    assert layout.bounds == (-3.0, -3.0, 3.0, 3.0) and len(layout.walls) == 4
    names = {o.name for o in layout.obstacles}
    assert {'shelf', 'crate', 'pillar'} <= names and any(n.startswith('map_') for n in names)
    assert layout.robot_color('robot_2') == (0.15, 0.35, 0.85)
    assert layout.robots['robot_3'].radius < layout.robots['robot_1'].radius     # a burger beside pioneers


def test_a_bag_outside_a_recorded_run_has_no_scene(tmp_path):
    (tmp_path / 'bag').mkdir()
    assert read_scene(tmp_path / 'bag') is None
