"""pybullet_bridge node: runs the scene and exposes it on ROS.

Publishes /clock (simulated time), the top-view camera (image, labels, info, pose,
label legend) and ground-truth body states; drives robots from their command topics
through entity adapters; serves reset, pause and step. All simulation lives in
pybullet_bridge.core; this node only converts and paces.
"""

import math
import sys
import time

import numpy as np
from bridge_interfaces.msg import BodyLabel, BodyState, BodyStates, LabelLegend, SimulationStatus
from bridge_interfaces.srv import ResetScenario, StepSimulation
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import CameraInfo, Image
from collab_tools.node_support import ConfigurationError, run
from std_srvs.srv import SetBool

from .core.errors import ScenarioError
from .core.scenario import load_scenario
from .core.scene import Scene
from .entity_adapters import create_adapters
from . import arm_adapter  # noqa: F401  (registers the arms' adapter)
from . import sensor_adapter  # noqa: F401  (registers the robots' adapter with their sensors)

MAX_STEPS_PER_REQUEST = 100_000
# Ticks run at most this far behind wall-clock pacing before the bridge gives up
# catching up (a slow machine then just runs below the requested real-time factor).
MAX_CATCH_UP_TICKS = 10


def to_time_msg(seconds: float) -> Time:
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


class PybulletBridge(Node):

    def __init__(self):
        super().__init__('pybullet_bridge')
        self._declare_parameters()
        self.scenario_path = self._param('scenario')
        if self.scenario_path == '':
            raise ConfigurationError('parameter scenario: required (path to a scenario YAML)')
        self.real_time_factor = self._param('real_time_factor')
        self.control_period = self._param('control_period')
        self.ground_truth_rate = self._param('ground_truth_rate')
        self.status_rate = self._param('status_rate')
        self.publish_camera = self._param('publish_camera')
        self._check_parameters()

        try:
            scenario = load_scenario(self.scenario_path)
        except ScenarioError as error:
            raise ConfigurationError(f'scenario {self.scenario_path}: {error}') from None
        self.scene = Scene(scenario)
        self.paused = bool(self._param('start_paused'))
        self.rejected_messages = 0
        self.adapters = []

        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        # Ground truth and camera keep their latest sample for late joiners, so a paused
        # simulation can still be inspected.
        latest = latched
        self.clock_pub = self.create_publisher(ClockMsg, '/clock', reliable)
        self.bodies_pub = self.create_publisher(BodyStates, '/ground_truth/bodies', latest)
        self.status_pub = self.create_publisher(SimulationStatus, '~/status', reliable)
        camera_ns = '/' + scenario.camera.frame_id
        self.image_pub = self.create_publisher(Image, f'{camera_ns}/image_raw', latest)
        self.labels_pub = self.create_publisher(Image, f'{camera_ns}/labels', latest)
        self.info_pub = self.create_publisher(CameraInfo, f'{camera_ns}/camera_info', latest)
        self.legend_pub = self.create_publisher(LabelLegend, f'{camera_ns}/label_legend', latched)
        self.camera_pose_pub = self.create_publisher(PoseStamped, f'{camera_ns}/pose', latched)

        self.create_service(ResetScenario, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.create_service(StepSimulation, '~/step', self._on_step)

        self._on_scene_loaded()
        # Pacing: a timer per control tick; with real_time_factor 0 it fires back to back.
        period = self.control_period / self.real_time_factor if self.real_time_factor > 0 else 0.0
        self.timer = self.create_timer(period, self._on_timer)
        # Status runs on the wall clock: it must report a paused or stalled simulation too.
        self.status_timer = self.create_timer(1.0 / self.status_rate, self._publish_status,
                                              clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(
            f"running scenario '{scenario.name}' ({len(self.scene.entities)} entities), "
            f'physics dt {self.scene.physics_dt:.5f} s, control period '
            f'{self.steps_per_tick * self.scene.physics_dt:.5f} s ({self.steps_per_tick} steps), '
            f'real-time factor {self.real_time_factor or "as fast as possible"}'
            f'{", paused" if self.paused else ""}')

    # --- parameters -------------------------------------------------------------------
    def _declare_parameters(self) -> None:
        def declare(name, default, description):
            # Dynamic typing: a YAML `0` for a float parameter gets our clear error
            # from _check_parameters instead of an rclpy type exception.
            self.declare_parameter(name, default, ParameterDescriptor(
                description=description, dynamic_typing=True))

        declare('scenario', '', 'path to the scenario YAML (see README: scenario files)')
        declare('real_time_factor', 1.0, 'simulated seconds per wall second; 0 = as fast as possible')
        declare('control_period', 0.01, 'simulated seconds per tick (/clock and command update), '
                'rounded to a whole number of physics steps')
        declare('ground_truth_rate', 20.0, 'Hz of simulated time for /ground_truth/bodies')
        declare('status_rate', 1.0, 'Hz of wall-clock time for ~/status (also while paused)')
        declare('publish_camera', True, 'render and publish the top-view camera')
        declare('start_paused', False, 'start paused; advance with ~/step or ~/pause false')

    def _param(self, name):
        return self.get_parameter(name).value

    def _check_parameters(self) -> None:
        def number(name, low, high, low_open):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value > high \
                    or (value <= low if low_open else value < low):
                bracket = '(' if low_open else '['
                raise ConfigurationError(
                    f'parameter {name}: must be a number in {bracket}{low}, {high}] (got {value!r})')
            setattr(self, name, float(value))

        number('real_time_factor', 0.0, 1000.0, low_open=False)
        number('control_period', 0.0, 1.0, low_open=True)
        number('ground_truth_rate', 0.0, 1000.0, low_open=True)
        number('status_rate', 0.0, 1000.0, low_open=True)
        if not isinstance(self.scenario_path, str):
            raise ConfigurationError(f'parameter scenario: must be a path string (got {self.scenario_path!r})')
        for name in ('publish_camera',):
            if not isinstance(getattr(self, name), bool):
                raise ConfigurationError(f'parameter {name}: must be true or false')

    # --- scene lifecycle ----------------------------------------------------------------
    def _on_scene_loaded(self) -> None:
        for adapter in self.adapters:
            adapter.destroy()
        self.adapters = create_adapters(self, self.scene.entities, self.reject)
        self.steps_per_tick = max(1, round(self.control_period / self.scene.physics_dt))
        self.camera_period = 1.0 / self.scene.scenario.camera.rate
        self.next_camera_time = 0.0
        self.next_ground_truth_time = 0.0
        self._pace_reference = None
        self._status_reference = (time.monotonic(), self.scene.sim_time)
        self._publish_latched()
        self._publish_due()

    def _publish_latched(self) -> None:
        scenario = self.scene.scenario
        legend = LabelLegend()
        legend.header.stamp = to_time_msg(self.scene.sim_time)
        legend.header.frame_id = scenario.camera.frame_id
        legend.entries = [BodyLabel(label=label, name=name, kind=kind)
                          for label, name, kind in self.scene.label_legend()]
        self.legend_pub.publish(legend)

        position, quaternion = self.scene.camera.optical_pose()
        pose = PoseStamped()
        pose.header.stamp = legend.header.stamp
        pose.header.frame_id = scenario.world.frame_id
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = map(float, position)
        (pose.pose.orientation.x, pose.pose.orientation.y,
         pose.pose.orientation.z, pose.pose.orientation.w) = map(float, quaternion)
        self.camera_pose_pub.publish(pose)

    def reject(self, source: str, reason: str) -> None:
        """Log and count a malformed input that was dropped."""
        self.rejected_messages += 1
        self.get_logger().warn(f'dropped input on {source}: {reason} '
                               f'({self.rejected_messages} dropped so far)',
                               throttle_duration_sec=1.0)

    # --- simulation loop -----------------------------------------------------------------
    def _on_timer(self) -> None:
        if self.paused:
            return
        ticks = 1
        if self.real_time_factor > 0:
            now = time.monotonic()
            if self._pace_reference is None:
                self._pace_reference = (now, self.scene.sim_time)
            wall0, sim0 = self._pace_reference
            behind = sim0 + (now - wall0) * self.real_time_factor - self.scene.sim_time
            ticks = int(behind / self.control_period)
            if ticks > MAX_CATCH_UP_TICKS:
                ticks = MAX_CATCH_UP_TICKS
                self._pace_reference = None  # re-anchor instead of spiralling
            if ticks <= 0:
                return
        for _ in range(ticks):
            self.advance(self.steps_per_tick)

    def advance(self, steps: int) -> None:
        """Step the physics and publish whatever is due."""
        remaining = steps
        while remaining > 0:
            chunk = min(remaining, self.steps_per_tick)
            self.scene.step(chunk)
            remaining -= chunk
            for adapter in self.adapters:
                adapter.on_tick(self.scene.sim_time)
            self._publish_due()

    def _publish_due(self) -> None:
        sim_time = self.scene.sim_time
        stamp = to_time_msg(sim_time)
        self.clock_pub.publish(ClockMsg(clock=stamp))
        # Small epsilon: rates are in simulated time and ticks land on float sums.
        epsilon = 1e-9
        if sim_time + epsilon >= self.next_ground_truth_time:
            self.next_ground_truth_time = sim_time + 1.0 / self.ground_truth_rate
            self._publish_ground_truth(stamp)
        if self.publish_camera and sim_time + epsilon >= self.next_camera_time:
            self.next_camera_time = sim_time + self.camera_period
            self._publish_camera(stamp)

    def _publish_ground_truth(self, stamp: Time) -> None:
        msg = BodyStates()
        msg.header.stamp = stamp
        msg.header.frame_id = self.scene.scenario.world.frame_id
        for body in self.scene.body_states():
            state = BodyState(name=body.name, kind=body.kind, label=body.label)
            p, q = state.pose.position, state.pose.orientation
            p.x, p.y, p.z = map(float, body.position)
            q.x, q.y, q.z, q.w = map(float, body.orientation_xyzw)
            v, w = state.twist.linear, state.twist.angular
            v.x, v.y, v.z = map(float, body.linear_velocity)
            w.x, w.y, w.z = map(float, body.angular_velocity)
            msg.bodies.append(state)
        self.bodies_pub.publish(msg)

    def _publish_camera(self, stamp: Time) -> None:
        frame = self.scene.render()
        camera = self.scene.camera
        frame_id = self.scene.scenario.camera.frame_id
        self.image_pub.publish(self._image_msg(frame.rgb, 'rgb8', stamp, frame_id))
        self.labels_pub.publish(self._image_msg(frame.labels, '16UC1', stamp, frame_id))
        info = CameraInfo()
        info.header.stamp = stamp
        info.header.frame_id = frame_id
        info.width, info.height = camera.width, camera.height
        info.distortion_model = 'plumb_bob'
        info.d = [0.0] * 5
        info.k = [float(v) for v in camera.intrinsics().flatten()]
        info.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        info.p = [float(v) for v in camera.projection().flatten()]
        self.info_pub.publish(info)

    @staticmethod
    def _image_msg(array: np.ndarray, encoding: str, stamp: Time, frame_id: str) -> Image:
        array = np.ascontiguousarray(array)
        msg = Image()
        msg.header.stamp = stamp
        msg.header.frame_id = frame_id
        msg.height, msg.width = int(array.shape[0]), int(array.shape[1])
        msg.encoding = encoding
        msg.is_bigendian = int(sys.byteorder == 'big')
        msg.step = int(array.strides[0])
        msg.data = array.tobytes()
        return msg

    def _publish_status(self) -> None:
        now = time.monotonic()
        wall0, sim0 = self._status_reference
        elapsed = now - wall0
        measured = (self.scene.sim_time - sim0) / elapsed if elapsed > 0 else 0.0
        self._status_reference = (now, self.scene.sim_time)
        msg = SimulationStatus(paused=self.paused, step_count=self.scene.step_count,
                               physics_dt=self.scene.physics_dt,
                               target_real_time_factor=self.real_time_factor,
                               measured_real_time_factor=measured,
                               rejected_messages=self.rejected_messages,
                               scenario_name=self.scene.scenario.name)
        msg.header.stamp = to_time_msg(self.scene.sim_time)
        msg.header.frame_id = self.scene.scenario.world.frame_id
        self.status_pub.publish(msg)

    # --- services -----------------------------------------------------------------------
    def _on_reset(self, request: ResetScenario.Request, response: ResetScenario.Response):
        path = request.scenario_path or self.scenario_path
        try:
            scenario = load_scenario(path)
        except ScenarioError as error:
            response.success = False
            response.message = f'scenario {path}: {error}; still running {self.scene.scenario.name}'
            self.get_logger().error(response.message)
            return response
        self.scene.reset(scenario)
        self.scenario_path = path
        self.rejected_messages = 0
        self._on_scene_loaded()
        response.success = True
        response.message = f"reset to scenario '{scenario.name}' from {path}"
        self.get_logger().info(response.message)
        return response

    def _on_pause(self, request: SetBool.Request, response: SetBool.Response):
        self.paused = bool(request.data)
        self._pace_reference = None
        response.success = True
        response.message = 'paused' if self.paused else 'running'
        return response

    def _on_step(self, request: StepSimulation.Request, response: StepSimulation.Response):
        if not self.paused:
            response.success = False
            response.message = 'the simulation is running; pause it first (~/pause true)'
        elif not 1 <= request.steps <= MAX_STEPS_PER_REQUEST:
            response.success = False
            response.message = f'steps: must be in [1, {MAX_STEPS_PER_REQUEST}] (got {request.steps})'
        else:
            self.advance(request.steps)
            response.success = True
            response.message = f'stepped {request.steps} physics steps'
        response.sim_time = to_time_msg(self.scene.sim_time)
        return response

    def destroy_node(self):
        for adapter in self.adapters:
            adapter.destroy()
        self.scene.close()
        super().destroy_node()


def main(args=None) -> int:
    return run(PybulletBridge, 'pybullet_bridge', args)


if __name__ == '__main__':
    sys.exit(main())
