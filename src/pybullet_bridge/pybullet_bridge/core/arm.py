"""Robot arms that move cubes (the ``arms`` scenario section) and their pick-and-place task.

An arm is a fixed-base URDF from pybullet_data (see :mod:`.arm_models`) standing on a
pedestal. A pick-and-place task runs as a state machine advanced in the scene's step
hooks, so it lives in simulated time and is as reproducible as the physics:

    approach (joint-space move above the object, then a straight descent)
    -> grasp (fingers close; a fixed constraint ties the cube to the tool, created only
       when the tool is within ``GRASP_TOLERANCE`` of the grasp pose)
    -> lift -> transport (straight line at travel height) -> place (straight descent)
    -> release (constraint removed) -> retreat (straight up, then joint-space home)

Straight-line segments follow a smooth (cubic) time law capped by ``max_tool_speed``;
every physics step the tool target on the line goes through pybullet's
``calculateInverseKinematics`` (top-down tool orientation) and the joints follow with
position motors limited to the URDF efforts. Each segment may run at most its planned
duration plus ``phase_timeout`` seconds of simulated time; a segment that does not
converge ends the task with EXECUTION_FAILED and a message naming the step and the
remaining error, instead of hanging.

Simulated execution failure (SGCM paper, Sec. III: with probability p_fail an action
fails and is "an empty action"): once per task, before the arm moves, a draw from the
arm's own seeded generator decides whether the grasp slips. A slipping grasp makes the
same motion without the constraint (and without squeezing the fingers), so the object
stays where it was; the outcome is EXECUTION_FAILED. Rejected goals and goals without
a free spot draw nothing.

Where to put the object is decided once, when the task starts and the arm is still at
home (it does not hide the table then): a label image is rendered through the scene's
camera and :func:`.placement.find_place_position` runs the paper's pixel test on it.

Cancel: while the arm holds the object it carries it back to where it was picked and
sets it down there, then goes home; before the grasp it just goes home. Once the
object is released the cancel is refused (only the retreat is left). A canceled task
ends with ABORTED, as does a task whose scene is reset.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from typing import TYPE_CHECKING, Any, Callable

import numpy as np
import pybullet as p

from .arm_models import ARM_MODELS, ArmKinematics, ArmModel, grasp_yaw, model_path, top_down_orientation
from .fields import Fields, check_number, check_vector, fail, join_path, require_list
from .mobile_robot import yaw_of, yaw_quaternion
from .placement import find_place_position, meters_to_pixels, region_to_pixels
from .scenario import SectionContext, register_section
from .scene import BACKGROUND_LABEL, SceneEntity
from .tabletop import Cube, Table, rects_overlap, tables_in

if TYPE_CHECKING:
    from .scene import Scene

#: Feedback phases, in the order a task goes through them (as in PickAndPlace.action).
PHASES = ('approach', 'grasp', 'lift', 'transport', 'place', 'release', 'retreat')
PEDESTAL_COLOR = (0.35, 0.35, 0.38)

#: The tool must be this close to the grasp pose for the constraint to be created (m).
GRASP_TOLERANCE = 0.01
#: A straight-line segment has converged when the tool is this close to its end (m).
POSITION_TOLERANCE = 0.005
#: A joint-space segment has converged when every joint is this close to its goal (rad).
JOINT_TOLERANCE = 0.02
#: Plan-time IK must reach every key pose this closely, or the goal is rejected (m).
IK_TOLERANCE = 0.01
#: Height of the approach / travel poses above the grasp and place poses (m).
CLEARANCE_HEIGHT = 0.10
#: Gap left under the object when it is set down, so it never hits the table while moving (m).
DROP_GAP = 0.003
#: Gap between a flange and the top of the cube it holds (m); the flange also hovers this
#: far above neighbouring cubes of the same size while it grasps or sets one down.
FLANGE_GAP = 0.004
#: Extra finger opening on each side of the cube when approaching it (m).
FINGER_APPROACH_GAP = 0.012
#: Gap between each closed finger and the cube (m): the constraint, not friction, holds it.
FINGER_CLOSED_GAP = 0.002
GRIP_DURATION = 0.4      # s for the fingers to close
RELEASE_DURATION = 0.4   # s for the fingers to open and the object to settle
#: Shortest planned segment (s): very short moves still ramp smoothly.
MIN_SEGMENT_DURATION = 0.2
#: The cubic time law's peak speed is 1.5 x its mean speed.
CUBIC_PEAK_FACTOR = 1.5
# Position-motor gains (pybullet POSITION_CONTROL), tuned for tracking the smooth targets.
POSITION_GAIN = 0.3
VELOCITY_GAIN = 1.0
#: Result checks: the object must rest this close to its support height (m) and tilt less (deg).
REST_HEIGHT_TOLERANCE = 0.006
UPRIGHT_TOLERANCE_DEG = 10.0
#: An object whose centre is this close to a resting height counts as resting (m).
RESTING_TOLERANCE = 0.01


class Outcome(IntEnum):
    """How a task ended; the values are those of PickAndPlace.action's result constants."""

    PLACED = 0
    EXECUTION_FAILED = 1
    REJECTED = 2
    NO_FREE_SPOT = 3
    ABORTED = 4


@dataclass
class PickPlaceTask:
    """One pick-and-place request and its progress; read by the bridge adapter."""

    object_name: str
    region: tuple[float, ...]
    phase: str = 'approach'
    progress: float = 0.0
    outcome: Outcome | None = None
    message: str = ''
    #: Where the object rests when the task ends (world frame); None if it was never checked.
    placed_position: tuple[float, float, float] | None = None
    #: Centre (x, y) the pixel test chose for the object.
    target_position: tuple[float, float] | None = None
    #: The failure draw of this task: True = the grasp slips.
    slipped: bool = False
    started_at: float | None = None
    finished_at: float | None = None

    @property
    def done(self) -> bool:
        return self.outcome is not None

    def finish(self, outcome: Outcome, message: str, sim_time: float | None = None) -> PickPlaceTask:
        self.outcome = outcome
        self.message = message
        self.finished_at = sim_time
        if outcome in (Outcome.PLACED, Outcome.EXECUTION_FAILED):
            self.progress = 1.0
        return self


class _MotionFailure(Exception):
    """A segment did not converge in time."""


def cubic(tau: float) -> tuple[float, float]:
    """Smooth time law s(tau) = 3 tau^2 - 2 tau^3 and ds/dtau on [0, 1]."""
    tau = min(max(tau, 0.0), 1.0)
    return 3.0 * tau ** 2 - 2.0 * tau ** 3, 6.0 * tau * (1.0 - tau)


@dataclass
class _Segment:
    """One step of the motion plan. Subclasses fill in begin/command/converged."""

    phase: str
    step: str                 # what it does, for messages
    estimate: float           # planned duration for progress (s)
    duration: float = 0.0     # actual duration, fixed at begin (s)
    start_time: float = 0.0

    def begin(self, arm: Arm, sim_time: float) -> None:
        self.start_time = sim_time
        self.duration = self.estimate

    def command(self, arm: Arm, sim_time: float) -> None:
        """Set the motor targets for this step."""

    def converged(self, arm: Arm) -> bool:
        return True

    def error_text(self, arm: Arm) -> str:
        return ''

    def end(self, arm: Arm) -> None:
        """Called once when the segment is done (before the next begins)."""


@dataclass
class _JointMove(_Segment):
    goal: Callable[[], np.ndarray] | np.ndarray | None = None
    _start: np.ndarray | None = None
    _goal: np.ndarray | None = None

    def begin(self, arm: Arm, sim_time: float) -> None:
        self.start_time = sim_time
        self._start = arm.kinematics.arm_positions()
        self._goal = np.asarray(self.goal() if callable(self.goal) else self.goal, dtype=float)
        self.duration = arm.joint_move_duration(self._start, self._goal)

    def command(self, arm: Arm, sim_time: float) -> None:
        s, ds = cubic((sim_time - self.start_time) / self.duration)
        delta = self._goal - self._start
        arm.command_joints(self._start + s * delta, ds / self.duration * delta)

    def converged(self, arm: Arm) -> bool:
        return float(np.max(np.abs(arm.kinematics.arm_positions() - self._goal))) < JOINT_TOLERANCE

    def error_text(self, arm: Arm) -> str:
        error = float(np.max(np.abs(arm.kinematics.arm_positions() - self._goal)))
        return f'a joint is {error:.3f} rad from its goal'


@dataclass
class _LinearMove(_Segment):
    goal: Callable[[], np.ndarray] | np.ndarray | None = None
    yaw: float = 0.0
    _start: np.ndarray | None = None
    _goal: np.ndarray | None = None

    def begin(self, arm: Arm, sim_time: float) -> None:
        self.start_time = sim_time
        self._start, _ = arm.kinematics.tool_pose()
        self._goal = np.asarray(self.goal() if callable(self.goal) else self.goal, dtype=float)
        self.duration = arm.linear_move_duration(self._start, self._goal)

    def command(self, arm: Arm, sim_time: float) -> None:
        s, _ = cubic((sim_time - self.start_time) / self.duration)
        target = self._start + s * (self._goal - self._start)
        arm.command_joints(arm.kinematics.ik_step(target, top_down_orientation(self.yaw)))

    def tool_error(self, arm: Arm) -> float:
        position, _ = arm.kinematics.tool_pose()
        return float(np.linalg.norm(position - self._goal))

    def converged(self, arm: Arm) -> bool:
        return self.tool_error(arm) < POSITION_TOLERANCE

    def error_text(self, arm: Arm) -> str:
        return f'the tool is {self.tool_error(arm) * 100:.1f} cm from its target'


@dataclass
class _Hold(_Segment):
    """Keep the arm still for a while; run ``on_begin`` / ``on_end`` around it."""

    on_begin: Callable[[], None] | None = None
    on_end: Callable[[], None] | None = None
    _hold: np.ndarray | None = None

    def begin(self, arm: Arm, sim_time: float) -> None:
        super().begin(arm, sim_time)
        self._hold = arm.kinematics.arm_positions()
        if self.on_begin is not None:
            self.on_begin()

    def command(self, arm: Arm, sim_time: float) -> None:
        arm.command_joints(self._hold)

    def end(self, arm: Arm) -> None:
        if self.on_end is not None:
            self.on_end()


@dataclass(frozen=True)
class _Request:
    """A checked pick-and-place request: where the object is and where it may go."""

    cube: Cube
    center: np.ndarray            # object centre now (world)
    yaw: float                    # object yaw now (rad)
    grasp_height: float           # tool point above the object's centre at the grasp (m)
    region: tuple[float, float, float, float]
    place_table: Table | None     # surface under the region's centre; None = the ground
    support_height: float         # its height (m)
    place_center_z: float         # object centre height when it is let go (m)
    half_extent: float            # half side of the footprint tested in the image, clearance included (m)


@dataclass(frozen=True)
class ArmLimits:
    max_joint_velocity: float   # rad/s, also capped by each joint's URDF limit
    max_tool_speed: float       # m/s of the tool point on straight segments
    phase_timeout: float        # s a segment may run beyond its planned duration


class Arm(SceneEntity):
    """A fixed-base arm on a pedestal that picks and places cubes."""

    kind = 'arm'

    def __init__(self, name: str, model: ArmModel, base: tuple[float, float, float], base_height: float,
                 failure_probability: float, seed: int, limits: ArmLimits, home: tuple[float, ...],
                 placement_clearance: float, config_path: str = ''):
        self.name = name
        self.model = model
        self.base = tuple(float(v) for v in base)
        self.base_height = float(base_height)
        self.failure_probability = float(failure_probability)
        self.seed = int(seed)
        self.limits = limits
        self.home = tuple(float(v) for v in home)
        self.placement_clearance = float(placement_clearance)
        self.config_path = config_path
        self.kinematics: ArmKinematics | None = None
        self.task: PickPlaceTask | None = None
        self._reset_runtime_state()

    def _reset_runtime_state(self) -> None:
        self._rng = np.random.default_rng(self.seed)
        self._segments: list[_Segment] = []
        self._segment: _Segment | None = None
        self._constraint: int | None = None
        self._cube: Cube | None = None
        self._cube_body: int | None = None
        self._finished_estimate = 0.0
        self._total_estimate = 1.0
        self._canceled = False
        self._cancel_reason = ''
        self._put_back = False
        self._released = False
        self._failure = ''
        self._recovering = False
        self._grasp_offset = np.zeros(3)
        self._support_height = 0.0

    # -- geometry -----------------------------------------------------------------

    def horizontal_distance(self, x: float, y: float) -> float:
        return math.hypot(x - self.base[0], y - self.base[1])

    def reach_problem(self, what: str, x: float, y: float, z: float) -> str | None:
        """Why the tool cannot work at (x, y) with the tool at height z, or None if it can."""
        low, high = self.model.reach
        distance = self.horizontal_distance(x, y)
        if not low <= distance <= high:
            return (f"{what} at ({x:.3f}, {y:.3f}) is {distance:.3f} m from the base of arm "
                    f"'{self.name}' ({self.model.name} reach {low:.2f}..{high:.2f} m); out of reach")
        height = z - self.base_height
        zlow, zhigh = self.model.reach_height
        if not zlow <= height <= zhigh:
            return (f"{what} at ({x:.3f}, {y:.3f}) is {height:+.3f} m above the base of arm '{self.name}' "
                    f'(workable {zlow:+.2f}..{zhigh:+.2f} m); out of reach')
        return None

    # -- physics ------------------------------------------------------------------

    def spawn(self, client: int) -> list[int]:
        if self.task is not None and not self.task.done:
            self.task.finish(Outcome.ABORTED, 'the scene was reset while the arm was moving')
        self._reset_runtime_state()
        x, y, yaw = self.base
        pedestal = None
        if self.base_height > 0.0:
            radius = self.model.pedestal_radius
            shape = p.createCollisionShape(p.GEOM_CYLINDER, radius=radius, height=self.base_height,
                                           physicsClientId=client)
            visual = p.createVisualShape(p.GEOM_CYLINDER, radius=radius, length=self.base_height,
                                         rgbaColor=[*PEDESTAL_COLOR, 1.0], physicsClientId=client)
            pedestal = p.createMultiBody(0.0, shape, visual, basePosition=[x, y, self.base_height / 2.0],
                                         physicsClientId=client)
        body = p.loadURDF(model_path(self.model), basePosition=[x, y, self.base_height],
                          baseOrientation=yaw_quaternion(yaw), useFixedBase=True, physicsClientId=client)
        self.kinematics = ArmKinematics(self.model, body, client)
        self.kinematics.reset_arm(self.home)
        self.command_joints(np.array(self.home))
        self._set_fingers(self.model.finger_max_opening)
        return [body] if pedestal is None else [body, pedestal]

    def command_joints(self, positions: np.ndarray, velocities: np.ndarray | None = None) -> None:
        kin = self.kinematics
        count = len(kin.arm_indices)
        p.setJointMotorControlArray(
            kin.body, kin.arm_indices, p.POSITION_CONTROL, targetPositions=list(map(float, positions)),
            targetVelocities=[0.0] * count if velocities is None else list(map(float, velocities)),
            forces=list(self.model.joint_max_force), positionGains=[POSITION_GAIN] * count,
            velocityGains=[VELOCITY_GAIN] * count, physicsClientId=kin.client)

    def _set_fingers(self, opening: float) -> None:
        kin = self.kinematics
        if not kin.finger_indices:
            return
        opening = min(max(opening, 0.0), self.model.finger_max_opening)
        p.setJointMotorControlArray(kin.body, kin.finger_indices, p.POSITION_CONTROL,
                                    targetPositions=[opening] * len(kin.finger_indices),
                                    forces=[self.model.finger_force] * len(kin.finger_indices),
                                    physicsClientId=kin.client)

    def joint_velocity_limits(self) -> np.ndarray:
        return np.minimum(self.limits.max_joint_velocity, np.array(self.model.joint_max_velocity))

    def joint_move_duration(self, start: np.ndarray, goal: np.ndarray) -> float:
        slowest = float(np.max(np.abs(goal - start) / self.joint_velocity_limits()))
        return max(MIN_SEGMENT_DURATION, CUBIC_PEAK_FACTOR * slowest)

    def linear_move_duration(self, start: np.ndarray, goal: np.ndarray) -> float:
        distance = float(np.linalg.norm(np.asarray(goal) - np.asarray(start)))
        return max(MIN_SEGMENT_DURATION, CUBIC_PEAK_FACTOR * distance / self.limits.max_tool_speed)

    def joint_state(self) -> tuple[list[str], list[float], list[float], list[float]]:
        """(names, positions, velocities, efforts) of every movable joint, fingers included."""
        positions, velocities, efforts = self.kinematics.movable_states()
        return list(self.kinematics.movable_names), positions, velocities, efforts

    @property
    def busy(self) -> bool:
        return self.task is not None and not self.task.done

    # -- task requests --------------------------------------------------------------

    def start_pick_and_place(self, scene: Scene, object_name: str, region) -> PickPlaceTask:
        """Validate a request and start it; never raises for bad input.

        Returns the task: already finished with REJECTED or NO_FREE_SPOT (and a message
        saying why) if it cannot be done, otherwise running (advanced by the step hooks).
        """
        region_tuple = tuple(region) if isinstance(region, (list, tuple, np.ndarray)) else ()
        task = PickPlaceTask(object_name=str(object_name), region=region_tuple, started_at=scene.sim_time)
        if self.busy:
            return task.finish(Outcome.REJECTED, f"arm '{self.name}' is busy moving "
                               f"'{self.task.object_name}' (phase {self.task.phase}); wait for its result "
                               'or cancel it', scene.sim_time)
        request = self._check_request(scene, task)
        if isinstance(request, str):
            return task.finish(Outcome.REJECTED, request, scene.sim_time)
        task.region = request.region
        spot = self._pixel_test(scene, request)
        if spot is None:
            return task.finish(Outcome.NO_FREE_SPOT, f"no free spot for '{request.cube.name}' in place_region "
                               f'{list(request.region)}: every {2 * request.half_extent:.3f} m footprint there '
                               'touches another object or leaves the support surface', scene.sim_time)
        task.target_position = spot
        problem = self._plan_motion(scene, request, spot)
        if problem is not None:
            return task.finish(Outcome.REJECTED, problem, scene.sim_time)
        # The draw happens only for tasks that will move (see the module docstring).
        task.slipped = bool(self._rng.random() < self.failure_probability)
        self.task = task
        return task

    def _check_request(self, scene: Scene, task: PickPlaceTask) -> _Request | str:
        """The request's geometry, or why it cannot be done."""
        cubes = ', '.join(entity.name for entity in scene.entities_of(Cube)) or 'none'
        try:
            cube = scene.entity(task.object_name)
        except KeyError:
            return f"unknown object '{task.object_name}' (cubes in the scene: {cubes})"
        if not isinstance(cube, Cube):
            return (f"'{task.object_name}' is a {cube.kind}, not a cube; only cubes can be picked "
                    f'(cubes: {cubes})')
        try:
            region = check_vector(list(task.region), 'place_region', 4)
        except ValueError as error:
            return f'{error}: [xmin, ymin, xmax, ymax] in metres'
        xmin, ymin, xmax, ymax = region
        if not (xmin < xmax and ymin < ymax):
            return (f'place_region {list(region)} is empty: need xmin < xmax and ymin < ymax '
                    '([xmin, ymin, xmax, ymax] in metres)')
        if cube.edge > self.model.max_cube_edge:
            return (f"cube '{cube.name}' (edge {cube.edge} m) does not fit the {self.model.name} gripper "
                    f'(at most {self.model.max_cube_edge:.3f} m)')

        body = cube.body_ids[0]
        position, orientation = p.getBasePositionAndOrientation(body, physicsClientId=scene.client)
        center = np.array(position)
        tables = scene.entities_of(Table)
        if self._resting_height(tables, cube, center) is None:
            return (f"object '{cube.name}' is not resting on a table or the ground (centre at z "
                    f'{center[2]:.3f} m); another arm may be holding it')
        grasp_height = (cube.edge / 2.0 + FLANGE_GAP) if self.model.grasps_from_top else 0.0
        problem = self.reach_problem(f"object '{cube.name}'", center[0], center[1], center[2] + grasp_height)
        if problem:
            return problem

        place_table = next((t for t in tables if t.contains((xmin + xmax) / 2.0, (ymin + ymax) / 2.0)), None)
        support_height = place_table.height if place_table else 0.0
        place_center_z = support_height + cube.edge / 2.0 + DROP_GAP
        for corner_x, corner_y in ((xmin, ymin), (xmin, ymax), (xmax, ymin), (xmax, ymax)):
            problem = self.reach_problem('place_region corner', corner_x, corner_y,
                                         place_center_z + grasp_height)
            if problem:
                return problem

        # The object keeps its yaw, so its footprint is the bounding box of the turned square.
        object_yaw = yaw_of(orientation)
        half_extent = cube.edge / 2.0 * (abs(math.cos(object_yaw)) + abs(math.sin(object_yaw)))
        half_extent += self.placement_clearance
        if 2.0 * half_extent > min(xmax - xmin, ymax - ymin):
            return (f"place_region {list(region)} is smaller than the footprint of '{cube.name}' "
                    f'({2 * half_extent:.3f} m with {self.placement_clearance} m clearance)')
        camera = scene.camera
        if region_to_pixels(camera, region, support_height) is None:
            return f'place_region {list(region)} is outside the camera view {list(camera.ground_footprint())}'
        if meters_to_pixels(camera, 2.0 * half_extent, support_height) < 1.0:
            return 'the camera resolution is too coarse for the pixel test (footprint below one pixel)'
        return _Request(cube=cube, center=center, yaw=object_yaw, grasp_height=grasp_height,
                        region=tuple(region), place_table=place_table, support_height=support_height,
                        place_center_z=place_center_z, half_extent=half_extent)

    def _pixel_test(self, scene: Scene, request: _Request) -> tuple[float, float] | None:
        """Centre for the object in the region, from a label image taken now (the arm is at home)."""
        labels = scene.render().labels
        # Not obstacles: the object itself, the arms, and the surface it will stand on.
        free = {request.cube.label} | {arm.label for arm in scene.entities_of(Arm)}
        every = {BACKGROUND_LABEL} | {entity.label for entity in scene.entities}
        free.add(request.place_table.label if request.place_table is not None else BACKGROUND_LABEL)
        return find_place_position(scene.camera, labels, every - free, request.region, request.half_extent,
                                   request.support_height)

    def _plan_motion(self, scene: Scene, request: _Request, spot: tuple[float, float]) -> str | None:
        """Solve the key poses and queue the segments; return why it is impossible, or None."""
        cube = request.cube
        yaw_to_object = math.atan2(request.center[1] - self.base[1], request.center[0] - self.base[0])
        tool_yaw = grasp_yaw(request.yaw, yaw_to_object)
        down = top_down_orientation(tool_yaw)
        grasp_tool = request.center + np.array([0.0, 0.0, request.grasp_height])
        place_tool = np.array([spot[0], spot[1], request.place_center_z + request.grasp_height])
        travel_z = max(grasp_tool[2], place_tool[2]) + CLEARANCE_HEIGHT
        above_pick = np.array([grasp_tool[0], grasp_tool[1], travel_z])
        above_place = np.array([place_tool[0], place_tool[1], travel_z])
        kin = self.kinematics
        q_grasp, grasp_error = kin.solve_ik(grasp_tool, down, start=self.home)
        _, place_error = kin.solve_ik(place_tool, down, start=self.home)
        q_above_pick, above_pick_error = kin.solve_ik(above_pick, down, start=q_grasp, rest=q_grasp)
        _, above_place_error = kin.solve_ik(above_place, down, start=q_above_pick, rest=q_above_pick)
        for what, error in (('grasp pose', grasp_error), ('place pose', place_error),
                            ('travel pose above the object', above_pick_error),
                            ('travel pose above the place spot', above_place_error)):
            if error > IK_TOLERANCE:
                return (f"the {self.model.name} of arm '{self.name}' cannot reach the {what} of "
                        f"'{cube.name}' (inverse kinematics error {error * 100:.1f} cm); out of reach")

        self._cube = cube
        self._cube_body = cube.body_ids[0]
        self._support_height = request.support_height
        self._travel_z = travel_z
        self._tool_yaw = tool_yaw
        self._grasp_tool = grasp_tool
        self._grasp_offset = np.zeros(3)
        self._canceled = self._put_back = self._released = self._recovering = False
        self._failure = ''

        def place_target() -> np.ndarray:
            # Put the object's centre (not the tool) over the chosen pixel.
            return np.array([spot[0], spot[1], request.place_center_z]) - self._grasp_offset

        def above_place_target() -> np.ndarray:
            return np.array([*place_target()[:2], travel_z])

        home = np.array(self.home)
        line = self.linear_move_duration
        self._fingers_ignore_cubes(scene)
        self._set_fingers(cube.edge / 2.0 + FINGER_APPROACH_GAP)
        self._segments = [
            _JointMove('approach', 'move above the object', self.joint_move_duration(home, q_above_pick),
                       goal=q_above_pick),
            _LinearMove('approach', 'descend to the grasp pose', line(above_pick, grasp_tool), goal=grasp_tool,
                        yaw=tool_yaw),
            _Hold('grasp', 'close the gripper', GRIP_DURATION, on_begin=self._close_fingers,
                  on_end=self._grasp),
            _LinearMove('lift', 'lift the object', line(grasp_tool, above_pick), goal=above_pick, yaw=tool_yaw),
            _LinearMove('transport', 'carry the object over the place spot', line(above_pick, above_place),
                        goal=above_place_target, yaw=tool_yaw),
            _LinearMove('place', 'lower the object', line(above_place, place_tool), goal=place_target,
                        yaw=tool_yaw),
            _Hold('release', 'open the gripper', RELEASE_DURATION, on_begin=self._release),
            _LinearMove('retreat', 'rise from the object', line(place_tool, above_place), goal=above_place,
                        yaw=tool_yaw),
            _JointMove('retreat', 'return home', self.joint_move_duration(q_above_pick, home), goal=home),
        ]
        self._total_estimate = sum(segment.estimate for segment in self._segments)
        self._finished_estimate = 0.0
        self._segment = None
        return None

    @staticmethod
    def _resting_height(tables: list[Table], cube: Cube, center: np.ndarray) -> float | None:
        """Height of the surface the cube rests on, or None if it is not resting."""
        for table in tables:
            if table.contains(center[0], center[1]) and abs(center[2] - table.height - cube.edge / 2.0) \
                    < RESTING_TOLERANCE:
                return table.height
        if abs(center[2] - cube.edge / 2.0) < RESTING_TOLERANCE:
            return 0.0
        return None

    def cancel(self, reason: str = 'canceled') -> bool:
        """Stop the running task: put a held object back, go home, end with ABORTED.

        Returns False (nothing changes) when there is no task, it is done, the object has
        already been released, or the arm is already recovering from a failed motion.
        """
        if not self.busy or self._released or self._canceled or self._recovering:
            return False
        self._canceled = True
        self._cancel_reason = reason
        self._put_back = self._constraint is not None
        self._segments = self._recovery_plan(put_back=self._put_back)
        self._segment = None
        return True

    def abort(self, reason: str) -> None:
        """End the running task at once with ABORTED, without touching the simulation.

        For a scene that is being torn down (its bodies may no longer exist).
        """
        if self.busy:
            self.task.finish(Outcome.ABORTED, reason)
        self._segments = []
        self._segment = None

    def _recovery_plan(self, put_back: bool) -> list[_Segment]:
        """Segments that end a task early: optionally put the object back, then go home."""
        yaw = self._tool_yaw
        travel_z = self._travel_z
        segments: list[_Segment] = []

        def up_from_here() -> np.ndarray:
            position, _ = self.kinematics.tool_pose()
            return np.array([position[0], position[1], max(position[2], travel_z)])

        segments.append(_LinearMove('retreat' if not put_back else 'transport', 'rise to travel height',
                                    0.5, goal=up_from_here, yaw=yaw))
        if put_back:
            back_tool = self._grasp_tool
            segments += [
                _LinearMove('transport', 'carry the object back', 1.0,
                            goal=np.array([back_tool[0], back_tool[1], travel_z]), yaw=yaw),
                _LinearMove('place', 'set the object back down', 0.5,
                            goal=back_tool + np.array([0.0, 0.0, DROP_GAP]), yaw=yaw),
                _Hold('release', 'open the gripper', RELEASE_DURATION, on_begin=self._release),
                _LinearMove('retreat', 'rise from the object', 0.5,
                            goal=np.array([back_tool[0], back_tool[1], travel_z]), yaw=yaw),
            ]
        segments.append(_JointMove('retreat', 'return home', 1.0, goal=np.array(self.home)))
        # Progress keeps going up: the remaining estimate is rescaled to what is left.
        self._total_estimate = self._finished_estimate + sum(s.estimate for s in segments)
        return segments

    # -- gripper events ---------------------------------------------------------------

    def _fingers_ignore_cubes(self, scene: Scene) -> None:
        # pybullet_data's Panda finger collision hulls are ~3.5 cm thick, far thicker than the
        # real fingertips, and would knock over cubes 1 cm away that real fingers clear. The
        # grasp is the fixed constraint anyway, so fingers only show the motion to cubes.
        kin = self.kinematics
        for cube in scene.entities_of(Cube):
            for finger in kin.finger_indices:
                p.setCollisionFilterPair(kin.body, cube.body_ids[0], finger, -1, 0, physicsClientId=kin.client)

    def _close_fingers(self) -> None:
        edge = self._cube.edge
        # A slipping grasp does not squeeze: the fingers stay clear of the cube.
        gap = FINGER_APPROACH_GAP if self.task.slipped else FINGER_CLOSED_GAP
        self._set_fingers(edge / 2.0 + gap)

    def _grasp(self) -> None:
        kin = self.kinematics
        tool, _ = kin.tool_pose()
        error = float(np.linalg.norm(tool - self._grasp_tool))
        if error > GRASP_TOLERANCE:
            raise _MotionFailure(f'the tool is {error * 100:.1f} cm from the grasp pose '
                                 f'(tolerance {GRASP_TOLERANCE * 100:.0f} cm); no grasp')
        if self.task.slipped:
            return
        client, cube = kin.client, self._cube_body
        link = p.getLinkState(kin.body, kin.tool_index, computeForwardKinematics=True, physicsClientId=client)
        cube_position, cube_orientation = p.getBasePositionAndOrientation(cube, physicsClientId=client)
        inverse = p.invertTransform(link[4], link[5])
        relative_position, relative_orientation = p.multiplyTransforms(
            inverse[0], inverse[1], cube_position, cube_orientation)
        self._constraint = p.createConstraint(
            kin.body, kin.tool_index, cube, -1, p.JOINT_FIXED, [0.0, 0.0, 0.0],
            parentFramePosition=relative_position, childFramePosition=[0.0, 0.0, 0.0],
            parentFrameOrientation=relative_orientation, physicsClientId=client)
        p.changeConstraint(self._constraint, maxForce=200.0, physicsClientId=client)
        self._set_held_collisions(False)
        # Place the object's centre, not the tool: remember where it sits relative to the tool.
        self._grasp_offset = np.array(cube_position) - tool

    def _set_held_collisions(self, enabled: bool) -> None:
        kin = self.kinematics
        for link in range(-1, p.getNumJoints(kin.body, physicsClientId=kin.client)):
            p.setCollisionFilterPair(kin.body, self._cube_body, link, -1, int(enabled),
                                     physicsClientId=kin.client)

    def _release(self) -> None:
        if self._constraint is not None:
            p.removeConstraint(self._constraint, physicsClientId=self.kinematics.client)
            self._constraint = None
            self._set_held_collisions(True)
        self._released = not self._canceled
        self._set_fingers(self._cube.edge / 2.0 + FINGER_APPROACH_GAP)

    # -- stepping ---------------------------------------------------------------------

    def before_step(self, client: int, dt: float, sim_time: float) -> None:
        if not self.busy or self.kinematics is None:
            return
        try:
            self._advance(sim_time)
        except _MotionFailure as failure:
            self._fail(str(failure), sim_time)

    def _advance(self, sim_time: float) -> None:
        task = self.task
        segment = self._segment
        if segment is not None:
            elapsed = sim_time - segment.start_time
            if elapsed >= segment.duration:
                if segment.converged(self):
                    self._finished_estimate += segment.estimate
                    self._segment = None
                    segment.end(self)
                elif elapsed > segment.duration + self.limits.phase_timeout:
                    raise _MotionFailure(f"phase '{segment.phase}' ({segment.step}) did not finish within "
                                         f'{segment.duration + self.limits.phase_timeout:.1f} s of '
                                         f'simulated time: {segment.error_text(self)}')
        if self._segment is None:
            if not self._segments:
                self._complete(sim_time)
                return
            self._segment = self._segments.pop(0)
            self._segment.begin(self, sim_time)
            task.phase = self._segment.phase
        segment = self._segment
        segment.command(self, sim_time)
        within = min(sim_time - segment.start_time, segment.duration) / segment.duration * segment.estimate
        task.progress = max(task.progress, min(1.0, (self._finished_estimate + within) / self._total_estimate))

    def _fail(self, message: str, sim_time: float) -> None:
        if self._recovering:
            # The recovery itself is stuck: stop here rather than loop.
            self._segments = []
            self._segment = None
            self._failure = f'{self._failure}; then {message}; the arm stopped where it is'
            self._complete(sim_time)
            return
        self._failure = message
        self._recovering = True
        held = self._constraint is not None
        self._segments = self._recovery_plan(put_back=False)
        if held:
            # Setting a held object down safely needs the very motion that failed: drop it here.
            self._segments.insert(0, _Hold('release', 'drop the object', RELEASE_DURATION,
                                           on_begin=self._release))
        self._segment = None

    def _complete(self, sim_time: float) -> None:
        task = self.task
        client = self.kinematics.client
        position, orientation = p.getBasePositionAndOrientation(self._cube_body, physicsClientId=client)
        task.placed_position = tuple(float(v) for v in position)
        x, y, z = task.placed_position
        where = f'({x:.3f}, {y:.3f}, {z:.3f})'
        if self._canceled:
            what = 'was put back; it rests at' if self._put_back else 'was not grasped; it is at'
            trouble = f' (while going back: {self._failure})' if self._failure else ''
            task.finish(Outcome.ABORTED, f"{self._cancel_reason}: '{task.object_name}' {what} {where}{trouble}",
                        sim_time)
        elif self._failure:
            task.finish(Outcome.EXECUTION_FAILED, f"{self._failure}; '{task.object_name}' is at {where}",
                        sim_time)
        elif task.slipped:
            task.finish(Outcome.EXECUTION_FAILED, f"the grasp slipped (simulated execution failure, "
                        f"failure_probability {self.failure_probability}); '{task.object_name}' stayed at "
                        f'{where}', sim_time)
        else:
            task.finish(*self._judge_placement(orientation), sim_time)
        self._segments = []
        self._segment = None

    def _judge_placement(self, orientation) -> tuple[Outcome, str]:
        task = self.task
        x, y, z = task.placed_position
        xmin, ymin, xmax, ymax = task.region
        rotation = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        tilt = math.degrees(math.acos(min(1.0, float(np.max(np.abs(rotation[2, :]))))))
        resting_z = self._support_height + self._cube.edge / 2.0
        where = f'({x:.3f}, {y:.3f}, {z:.3f})'
        if not (xmin <= x <= xmax and ymin <= y <= ymax):
            return Outcome.EXECUTION_FAILED, (f"'{task.object_name}' ended at {where}, outside place_region "
                                              f'{list(task.region)}')
        if abs(z - resting_z) > REST_HEIGHT_TOLERANCE or tilt > UPRIGHT_TOLERANCE_DEG:
            return Outcome.EXECUTION_FAILED, (f"'{task.object_name}' ended at {where} tilted {tilt:.0f} deg; "
                                              f'it does not rest flat at z {resting_z:.3f}')
        return Outcome.PLACED, f"'{task.object_name}' placed at {where}"


def _derived_seed(scenario_seed: int | None, index: int) -> int:
    """Seed of arm ``index`` when the scenario gives none: reproducible, distinct per arm."""
    entropy = 0 if scenario_seed is None else scenario_seed
    return int(np.random.SeedSequence(entropy=entropy, spawn_key=(index,)).generate_state(1)[0])


def parse_arms(value: Any, context: SectionContext) -> list[Arm]:
    """Parse the ``arms`` section: a list of arm entries."""
    if value is None:
        return []
    tables = tables_in(context.earlier)
    cubes = [c for c in context.earlier.get('cubes', []) if isinstance(c, Cube)]
    arms: list[Arm] = []
    for index, item in enumerate(require_list(value, context.path)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=(
            'name', 'model', 'base', 'base_height', 'failure_probability', 'seed', 'max_joint_velocity',
            'max_tool_speed', 'phase_timeout', 'home', 'placement_clearance'))
        name = fields.name('name')
        model_name = fields.string('model')
        if model_name not in ARM_MODELS:
            raise fail(fields.path_of('model'), f"unknown arm model '{model_name}' "
                       f"(known: {', '.join(ARM_MODELS)})")
        model = ARM_MODELS[model_name]
        base = fields.vector('base', 3)
        base_height = fields.number('base_height', 0.0, ge=0.0, le=2.0)
        radius = model.pedestal_radius
        if not context.world.contains(base[0], base[1], margin=radius):
            raise fail(fields.path_of('base'), f'arm base (x {base[0]}, y {base[1]}, pedestal radius {radius}) '
                       f'must lie inside world.bounds {list(context.world.bounds)}')
        footprint = (base[0] - radius, base[1] - radius, base[0] + radius, base[1] + radius)
        for table in tables:
            if rects_overlap(footprint, table.top_rect):
                raise fail(fields.path_of('base'), f"the {model_name} pedestal (radius {radius} m) at "
                           f"({base[0]}, {base[1]}) stands inside table '{table.name}' "
                           f'{[round(v, 3) for v in table.top_rect]}')
        for cube in cubes:
            if rects_overlap(footprint, cube.footprint()):
                raise fail(fields.path_of('base'), f"the {model_name} pedestal at ({base[0]}, {base[1]}) "
                           f"overlaps cube '{cube.name}'")
        failure_probability = fields.number('failure_probability', 0.0, ge=0.0, le=1.0)
        seed = fields.integer('seed') if fields.raw('seed', None) is not None else \
            _derived_seed(context.seed, index)
        home = model.home
        if fields.raw('home', None) is not None:
            home_path = fields.path_of('home')
            home = check_vector(fields.raw('home'), home_path, len(model.arm_joints))
            for joint, (value, (low, high)) in enumerate(zip(home, model.joint_limits)):
                check_number(value, join_path(home_path, joint), ge=low, le=high)
        limits = ArmLimits(
            max_joint_velocity=fields.number('max_joint_velocity', 1.5, gt=0.0, le=10.0),
            max_tool_speed=fields.number('max_tool_speed', 0.4, gt=0.0, le=2.0),
            phase_timeout=fields.number('phase_timeout', 2.0, gt=0.0, le=60.0))
        arms.append(Arm(name, model, base, base_height, failure_probability,  # type: ignore[arg-type]
                        seed, limits, home, fields.number('placement_clearance', 0.01, ge=0.0, le=0.2),
                        config_path=path))
    return arms


register_section('arms', parse_arms)
