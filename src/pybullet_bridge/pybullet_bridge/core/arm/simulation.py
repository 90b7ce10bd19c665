"""An arm in pybullet: its bodies, joint motors and the pick-and-place task it runs.

Ties the pieces together: a request is checked (:mod:`.requests`), the place spot chosen by
the pixel test, the motion planned (:mod:`.planning`) and the task run by the state machine
(:mod:`.state_machine`) from the scene's step hooks, so it lives in simulated time and is as
reproducible as the physics. The failure draw comes from the arm's own seeded generator,
once per task that will move, before the arm moves.
"""
from __future__ import annotations

import numpy as np
import pybullet as p

from ..entity import SceneEntity
from ..mobile_robot import yaw_quaternion
from ..tabletop import Cube
from .definition import Arm
from .gripper import Gripper
from .kinematics import ArmKinematics, model_path
from .planning import PickPlacePlan, plan_pick_and_place
from .recovery import drop_plan, recovery_plan
from .requests import ArmScene, check_request, choose_place_spot
from .segments import Segment
from .state_machine import PickPlaceRun
from .task import Outcome, PickPlaceTask

PEDESTAL_COLOR = (0.35, 0.35, 0.38)
# Position-motor gains (pybullet POSITION_CONTROL), tuned for tracking the smooth targets.
POSITION_GAIN = 0.3
VELOCITY_GAIN = 1.0


class SimulatedArm(Arm, SceneEntity):
    """A fixed-base arm on a pedestal that picks and places cubes."""

    def __post_init__(self):
        super().__post_init__()
        self.kinematics: ArmKinematics | None = None
        self.task: PickPlaceTask | None = None
        self._reset_runtime_state()

    def _reset_runtime_state(self) -> None:
        self._rng = np.random.default_rng(self.seed)
        self.gripper: Gripper | None = None
        self.plan: PickPlacePlan | None = None
        self.run: PickPlaceRun | None = None

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
        self.gripper = Gripper(self.kinematics)
        self.gripper.set_fingers(self.model.finger_max_opening)
        return [body] if pedestal is None else [body, pedestal]

    def command_joints(self, positions: np.ndarray, velocities: np.ndarray | None = None) -> None:
        kin = self.kinematics
        count = len(kin.arm_indices)
        p.setJointMotorControlArray(
            kin.body, kin.arm_indices, p.POSITION_CONTROL, targetPositions=list(map(float, positions)),
            targetVelocities=[0.0] * count if velocities is None else list(map(float, velocities)),
            forces=list(self.model.joint_max_force), positionGains=[POSITION_GAIN] * count,
            velocityGains=[VELOCITY_GAIN] * count, physicsClientId=kin.client)

    def joint_state(self) -> tuple[list[str], list[float], list[float], list[float]]:
        """(names, positions, velocities, efforts) of every movable joint, fingers included."""
        positions, velocities, efforts = self.kinematics.movable_states()
        return list(self.kinematics.movable_names), positions, velocities, efforts

    @property
    def busy(self) -> bool:
        return self.task is not None and not self.task.done

    # -- task requests --------------------------------------------------------------

    def start_pick_and_place(self, scene: ArmScene, object_name: str, region) -> PickPlaceTask:
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
        request = check_request(self, scene, task)
        if isinstance(request, str):
            return task.finish(Outcome.REJECTED, request, scene.sim_time)
        task.region = request.region
        spot = choose_place_spot(scene, request)
        if spot is None:
            return task.finish(Outcome.NO_FREE_SPOT, f"no free spot for '{request.cube.name}' in place_region "
                               f'{list(request.region)}: every {2 * request.half_extent:.3f} m footprint there '
                               'touches another object or leaves the support surface', scene.sim_time)
        task.target_position = spot
        plan = plan_pick_and_place(self, request, spot)
        if isinstance(plan, str):
            return task.finish(Outcome.REJECTED, plan, scene.sim_time)
        self.plan = plan
        self.gripper.grasp_offset = np.zeros(3)
        self.gripper.ignore_cubes(cube.body_ids[0] for cube in scene.entities_of(Cube))
        self.gripper.open_around(plan.cube.edge)
        self.run = PickPlaceRun(task, plan.segments, self, phase_timeout=self.limits.phase_timeout,
                                failure_probability=self.failure_probability,
                                support_height=plan.support_height, object_edge=plan.cube.edge)
        # The draw happens only for tasks that will move (see the module docstring).
        task.slipped = bool(self._rng.random() < self.failure_probability)
        self.task = task
        return task

    def cancel(self, reason: str = 'canceled') -> bool:
        """Stop the running task: put a held object back, go home, end with ABORTED.

        Returns False (nothing changes) when there is no task, it is done, the object has
        already been released, or the arm is already recovering from a failed motion.
        """
        if not self.busy:
            return False
        return self.run.cancel(reason)

    def abort(self, reason: str) -> None:
        """End the running task at once with ABORTED, without touching the simulation.

        For a scene that is being torn down (its bodies may no longer exist).
        """
        if self.run is not None:
            self.run.abort(reason)

    def before_step(self, client: int, dt: float, sim_time: float) -> None:
        if not self.busy or self.kinematics is None:
            return
        self.run.step(sim_time)

    # -- what the plan's segments and the state machine call ---------------------------

    def grasp_offset(self) -> np.ndarray:
        return self.gripper.grasp_offset

    def close_fingers(self) -> None:
        self.gripper.close_on(self.plan.cube.edge, self.task.slipped)

    def grasp(self) -> None:
        self.gripper.grasp(self.plan.cube_body, self.plan.grasp_tool, self.task.slipped)

    def release(self) -> None:
        self.gripper.release(self.plan.cube_body, self.plan.cube.edge)
        self.run.object_released()

    def holding(self) -> bool:
        return self.gripper.holding

    def recovery_plan(self, put_back: bool) -> list[Segment]:
        return recovery_plan(self, self.plan, put_back)

    def drop_plan(self) -> Segment:
        return drop_plan(self)

    def object_pose(self) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        return p.getBasePositionAndOrientation(self.plan.cube_body, physicsClientId=self.kinematics.client)
