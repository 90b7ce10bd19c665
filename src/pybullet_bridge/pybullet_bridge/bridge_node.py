"""pybullet_bridge node: runs the scene and exposes it on ROS.

Publishes /clock (simulated time), /tf and /tf_static (tf_adapter.py), the top-view camera
(camera_adapter.py: image, labels, info, pose, label legend, and image_transport's compressed
image and labels for whoever subscribes) and ground-truth body states; drives robots from
their command topics through entity adapters; serves reset, pause and step. All simulation
lives in pybullet_bridge.core; this node only converts and paces.

Names: everything but /clock, /tf and /tf_static is relative to the node's namespace
(``<robot>/cmd_vel``, ``<camera>/image_raw``, ``ground_truth/bodies``, ``~/status``), so
``-r __ns:=/sim1`` moves the whole simulation. QoS (collab_tools.qos): camera images, labels,
camera info and robot sensors are sensor data (best effort), the label legend, camera pose
and ground truth latched, cmd_vel accepted from best-effort publishers.
Malformed input is dropped, counted in ``~/status`` and logged once per kind (collab_tools.input_guard).

/clock goes out every control tick, or at ``clock_rate`` (simulated Hz) when set: each message
costs every node on simulated time a wake-up. As fast as possible, ``fast_batch_period`` runs
several ticks per timer call (the executor's round trip costs about as much as an idle tick).

Parameters (core/settings.py): real_time_factor, publish_camera, compressed_rate, jpeg_quality,
ground_truth_rate and status_rate change at run time (``ros2 param set``); the others are read-only
(camera_renderer: core/renderer.py; the renderer in use is logged and in ``~/status``).
Pacing and rate schedules are core/pacing.py's. The bridge is the clock source, so
``use_sim_time:=true`` is refused at start (exit 2).
"""

import sys
import time

from bridge_interfaces.msg import BodyState, BodyStates, SimulationStatus
from bridge_interfaces.srv import ResetScenario, StepSimulation
from builtin_interfaces.msg import Time
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg
from std_srvs.srv import SetBool

from collab_tools.core.input_checks import MalformedInput
from collab_tools.input_guard import InputGuard
from collab_tools.node_support import ConfigurationError, run
from collab_tools.parameters import NodeParameters
from collab_tools.qos import LATCHED, RELIABLE, STREAM

from . import arm_adapter  # noqa: F401  (registers the arms' adapter)
from . import sensor_adapter  # noqa: F401  (registers the robots' adapter with their sensors)
from .camera_adapter import CameraPublisher
from .core.errors import ScenarioError
from .core.frames import robot_transforms, static_transforms
from .core.pacing import RealTimeMeter, SimTimeSchedule, TickPacer, steps_per_tick
from .core.renderer import RendererError
from .core.scenario_access import ScenarioDirectories, load_scenario
from .core.scene import Scene
from .core.settings import BRIDGE_SETTINGS
from .entity_adapters import create_adapters
from .tf_adapter import TfPublisher

MAX_STEPS_PER_REQUEST = 100_000


def to_time_msg(seconds: float) -> Time:
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


class PybulletBridge(Node):

    def __init__(self):
        super().__init__('pybullet_bridge')
        self.params = NodeParameters(self)
        self.params.refuse_use_sim_time('the bridge is the clock source: it publishes /clock')
        settings = self.params.declare_schema(BRIDGE_SETTINGS, on_change={
            'real_time_factor': self._set_real_time_factor, 'ground_truth_rate': self._set_ground_truth_rate,
            'status_rate': self._set_status_rate})
        self.scenario_path = settings['scenario']
        self.control_period = settings['control_period']
        self.status_rate = settings['status_rate']
        self.pacer = TickPacer(self.control_period, settings['real_time_factor'])
        self.fast_batch_period = settings['fast_batch_period']
        self.ground_truth = SimTimeSchedule(settings['ground_truth_rate'])
        # clock_rate 0: /clock every tick; else at that rate (and after every ~/step).
        self.clock = SimTimeSchedule(settings['clock_rate']) if settings['clock_rate'] > 0 else None

        self.scenario_directories = ScenarioDirectories(settings['scenario_directories'])  # ScenarioError: exit 2
        try:
            scenario = load_scenario(self.scenario_path)
        except ScenarioError as error:
            raise ConfigurationError(f'parameter scenario: {error}') from None
        try:
            self.scene = Scene(scenario, renderer=settings['camera_renderer'])
        except RendererError as error:
            raise ConfigurationError(f'parameter camera_renderer: {error}') from None
        self.paused = settings['start_paused']
        self.rejected_messages = 0     # every dropped input (a command, a request), for ~/status
        self.inputs = InputGuard.of(self)
        self.inputs.on_reject = self._count_rejected
        self.adapters = []

        self.clock_pub = self.create_publisher(ClockMsg, '/clock', STREAM)
        # Ground truth keeps its latest sample for late joiners, so a paused simulation can
        # still be inspected; the camera is a sensor (best effort, no history).
        self.bodies_pub = self.create_publisher(BodyStates, 'ground_truth/bodies', LATCHED)
        self.status_pub = self.create_publisher(SimulationStatus, '~/status', RELIABLE)
        self.tf = TfPublisher(self)
        self.camera = CameraPublisher(self, self.params, scenario.camera.frame_id)

        self.inputs.serve(ResetScenario, '~/reset', self._on_reset)
        self.inputs.serve(SetBool, '~/pause', self._on_pause)
        self.inputs.serve(StepSimulation, '~/step', self._on_step)

        self._on_scene_loaded()
        self.timer = None
        self._start_pacing_timer()
        self.status_timer = None
        self._start_status_timer()
        self.get_logger().info(
            f"running scenario '{scenario.name}' ({len(self.scene.entities)} entities), "
            f'physics dt {self.scene.physics_dt:.5f} s, control period '
            f'{self.steps_per_tick * self.scene.physics_dt:.5f} s ({self.steps_per_tick} steps), '
            f'real-time factor {self.real_time_factor or "as fast as possible"}'
            f'{", paused" if self.paused else ""}; camera renderer {self.scene.renderer.name} '
            f'({self.scene.renderer.reason})')

    # --- parameters -------------------------------------------------------------------
    @property
    def real_time_factor(self) -> float:
        return self.pacer.real_time_factor

    @property
    def ground_truth_rate(self) -> float:
        return self.ground_truth.rate

    def _set_real_time_factor(self, value: float) -> None:
        self.pacer.real_time_factor = value
        self._start_pacing_timer()
        self.get_logger().info(f'real-time factor {value or "as fast as possible"}')

    def _set_ground_truth_rate(self, value: float) -> None:
        self.ground_truth.set_rate(value, self.scene.sim_time)
        for adapter in self.adapters:
            adapter.on_rate_change(self.scene.sim_time)

    def _set_status_rate(self, value: float) -> None:
        self.status_rate = value
        self._start_status_timer()

    def _start_pacing_timer(self) -> None:
        """(Re)start the tick timer for the current real-time factor; pacing re-anchors."""
        if self.timer is not None:
            self.destroy_timer(self.timer)
        self.pacer.reanchor()
        # A timer per control tick; with real_time_factor 0 it fires back to back.
        self.timer = self.create_timer(self.pacer.timer_period, self._on_timer)

    def _start_status_timer(self) -> None:
        if self.status_timer is not None:
            self.destroy_timer(self.status_timer)
        # Status runs on the wall clock: it must report a paused or stalled simulation too.
        self.status_timer = self.create_timer(1.0 / self.status_rate, self._publish_status,
                                              clock=Clock(clock_type=ClockType.STEADY_TIME))

    # --- scene lifecycle ----------------------------------------------------------------
    def _on_scene_loaded(self) -> None:
        for adapter in self.adapters:
            adapter.destroy()
        self.adapters = create_adapters(self, self.scene.entities,
                                        lambda source, reason: self.inputs.reject(source, MalformedInput(reason)))
        self.steps_per_tick = steps_per_tick(self.control_period, self.scene.physics_dt)
        self.pacer.batch_ticks = max(1, round(self.fast_batch_period / (self.steps_per_tick * self.scene.physics_dt)))
        self.ground_truth.restart()
        if self.clock is not None:
            self.clock.restart()
        self.pacer.reanchor()
        self.status_meter = RealTimeMeter(time.monotonic(), self.scene.sim_time)
        self._publish_latched()
        self._publish_due()

    def _publish_latched(self) -> None:
        scenario = self.scene.scenario
        stamp = to_time_msg(self.scene.sim_time)
        self.camera.on_scene_loaded(self.scene, stamp)
        position, quaternion = self.scene.camera.optical_pose()
        self.tf.publish_static(static_transforms(scenario.world.frame_id, self.scene.entities,
                                                 scenario.camera.frame_id, position, quaternion), stamp)

    def _count_rejected(self, source: str, error: BaseException) -> None:   # the input guard's on_reject
        self.rejected_messages += 1

    # --- simulation loop -----------------------------------------------------------------
    def _on_timer(self) -> None:
        if self.paused:
            return
        for _ in range(self.pacer.ticks_due(time.monotonic(), self.scene.sim_time)):
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
        if self.clock is None or self.clock.take_if_due(sim_time):
            self.clock_pub.publish(ClockMsg(clock=stamp))
        if self.ground_truth.take_if_due(sim_time):
            self._publish_ground_truth(stamp)
        self.camera.publish_due(self.scene, stamp)

    def _publish_ground_truth(self, stamp: Time) -> None:
        msg = BodyStates()
        msg.header.stamp = stamp
        msg.header.frame_id = self.scene.scenario.world.frame_id
        bodies = self.scene.body_states()
        for body in bodies:
            state = BodyState(name=body.name, kind=body.kind, label=body.label)
            p, q = state.pose.position, state.pose.orientation
            p.x, p.y, p.z = map(float, body.position)
            q.x, q.y, q.z, q.w = map(float, body.orientation_xyzw)
            v, w = state.twist.linear, state.twist.angular
            v.x, v.y, v.z = map(float, body.linear_velocity)
            w.x, w.y, w.z = map(float, body.angular_velocity)
            msg.bodies.append(state)
        self.bodies_pub.publish(msg)
        self.tf.publish(robot_transforms(msg.header.frame_id, bodies), stamp)

    def _publish_status(self) -> None:
        measured = self.status_meter.measure(time.monotonic(), self.scene.sim_time)
        msg = SimulationStatus(paused=self.paused, step_count=self.scene.step_count,
                               physics_dt=self.scene.physics_dt,
                               target_real_time_factor=self.real_time_factor,
                               measured_real_time_factor=measured,
                               rejected_messages=self.rejected_messages,
                               scenario_name=self.scene.scenario.name,
                               camera_frames=self.scene.frames_rendered,
                               camera_renderer=self.scene.renderer.name)
        msg.header.stamp = to_time_msg(self.scene.sim_time)
        msg.header.frame_id = self.scene.scenario.world.frame_id
        self.status_pub.publish(msg)

    # --- services -----------------------------------------------------------------------
    def _on_reset(self, request: ResetScenario.Request, response: ResetScenario.Response):
        try:   # only from the scenario_directories, read within input_files' bounds (core/scenario_access.py)
            scenario, path = self.scenario_directories.load(request.scenario_path, self.scenario_path)
        except ScenarioError as error:
            response.success = False
            response.message = f'{error}; still running {self.scene.scenario.name}'
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
        self.pacer.reanchor()
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
            if self.clock is not None:  # the time stepped to, whatever the clock rate
                self.clock_pub.publish(ClockMsg(clock=to_time_msg(self.scene.sim_time)))
            response.success = True
            response.message = f'stepped {request.steps} physics steps'
        response.sim_time = to_time_msg(self.scene.sim_time)
        return response

    def destroy_node(self):
        for adapter in self.adapters:
            adapter.destroy(node_closing=True)
        self.scene.close()
        super().destroy_node()


def main(args=None) -> int:
    return run(PybulletBridge, 'pybullet_bridge', args)


if __name__ == '__main__':
    sys.exit(main())
