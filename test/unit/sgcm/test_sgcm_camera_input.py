"""The SGCM arms' camera input on demand: one get_frame per look, the current state, stream fallback.

In-process on a private context: the bridge's real camera publisher over a scene of case_1 (the
service and the latched pose and legend), and a node with the arms' CameraInput.
"""
from pathlib import Path

import numpy as np
import pytest
import rclpy
from builtin_interfaces.msg import Time as TimeMsg
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from collab_tools.parameters import NodeParameters
from collab_tools.top_camera import TopCamera
from pybullet_bridge.camera_adapter import CameraPublisher
from pybullet_bridge.core.scenario import parse_scenario
from pybullet_bridge.core.scene import Scene
from sgcm.camera_input import CameraInput
from sgcm.core.scenario_builder import build_scenario
from sgcm.core.task_config import load_cases, load_task, task_of

CONFIG = Path(__file__).resolve().parents[3] / 'config' / 'sgcm'


@pytest.fixture
def rig():
    task = load_task(CONFIG / 'task.yaml')
    case = load_cases(CONFIG / 'cases.yaml', task)[0]
    task = task_of(case, task)
    context = Context()
    rclpy.init(context=context)
    bridge = Node('bridge_under_test', context=context, start_parameter_services=False)
    arm = Node('arm_under_test', context=context, start_parameter_services=False,
               parameter_overrides=[Parameter('use_sim_time', value=True)])   # as the arms run
    scene = Scene(parse_scenario(build_scenario(task, case), Path('.')))
    scene.step(240)
    publisher = CameraPublisher(bridge, NodeParameters(bridge), 'top_camera')
    publisher.on_scene_loaded(scene, TimeMsg())
    camera = CameraInput(arm, task, '/top_camera', params=NodeParameters(arm))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(bridge)
    executor.add_node(arm)
    clock = bridge.create_publisher(Clock, '/clock', 10)

    def spin_until(condition, timeout=10.0):
        for _ in range(int(timeout / 0.05)):
            if condition():
                return True
            executor.spin_once(timeout_sec=0.05)
        return condition()

    def run(steps):
        """Step the simulation and tell the arm the time."""
        scene.step(steps)
        nanoseconds = round(scene.sim_time * 1e9)
        clock.publish(Clock(clock=TimeMsg(sec=nanoseconds // 10**9, nanosec=nanoseconds % 10**9)))
        spin_until(lambda: arm.get_clock().now().nanoseconds == nanoseconds)

    run(1)
    yield task, case, scene, publisher, camera, run, spin_until
    executor.shutdown()
    arm.destroy_node()
    bridge.destroy_node()
    scene.close()
    context.try_shutdown()


def test_one_request_per_look_and_the_estimate_is_the_current_state(rig):
    task, case, scene, publisher, camera, run, spin_until = rig
    assert camera.on_demand and scene.frames_rendered == 0
    assert spin_until(lambda: camera.frame_time() is not None)
    assert scene.frames_rendered == 1 and camera.frames.requests == 1
    stamp = camera.frame_time()
    assert stamp.nanoseconds == pytest.approx(scene.sim_time * 1e9)
    assert np.array_equal(camera.estimate().counts, case.counts)
    # The frame is recent enough: no new request, however often the node looks.
    for _ in range(20):
        assert camera.frame_time(not_before=stamp) == stamp
        spin_until(lambda: False, timeout=0.05)
    assert scene.frames_rendered == 1
    # A settling time the node's (simulated) clock has not reached yet: nothing asked.
    settled = stamp + Duration(seconds=0.1)
    for _ in range(10):
        assert camera.frame_time(not_before=settled) == stamp
        spin_until(lambda: False, timeout=0.02)
    assert scene.frames_rendered == 1
    # Settled (the clock is past it) and the frame older: one new frame of the current time.
    run(48)
    assert spin_until(lambda: camera.frame_time(not_before=settled) != stamp)
    for _ in range(10):
        camera.frame_time(not_before=settled)
        spin_until(lambda: False, timeout=0.02)
    assert scene.frames_rendered == 2 and camera.frames.requests == 2
    assert camera.frame_time().nanoseconds == pytest.approx(scene.sim_time * 1e9)


def test_a_camera_that_refuses_is_streamed_instead(rig):
    task, case, scene, publisher, camera, run, spin_until = rig
    publisher.publish_camera = False          # the bridge's camera off (a driver stands in)
    assert spin_until(lambda: camera.frame_time() is None and not camera.on_demand)
    assert isinstance(camera.camera, TopCamera)
    assert scene.frames_rendered == 0
