"""Catalogue of the robot arms the bridge can simulate (their kinematics in pybullet: :mod:`.kinematics`).

Each model is a URDF shipped with ``pybullet_data``. The numbers that are not in the
URDF are ours and documented where they are defined:

- the *tool point* (where a grasped cube's reference sits): the Panda's
  ``panda_grasptarget`` link between the fingertips (the cube's centre is held there);
  for the KUKA iiwa and the xArm6, which have no gripper in pybullet_data, the centre of
  the flange face, which holds the cube by its top face (a suction-like grasp; the
  grasp itself is a fixed constraint in every case);
- the *home* configuration, chosen so every link stays behind the base, outside the
  column above the table, so the top-view camera sees the whole table;
- the *ready* configuration, the IK rest pose that keeps solutions elbow-up;
- the *reach*: horizontal distances from the base axis at which a top-down tool pose
  (any yaw) is reachable with an IK error below 5 mm, for grasp and place poses whose
  tool height relative to the base top is within ``reach_height`` and for the travel
  poses 0.10 m above them (so up to reach_height[1] + 0.10). Measured with
  :meth:`.kinematics.ArmKinematics.solve_ik` from the home pose over azimuths of +-``REACH_AZIMUTH``; the
  unit tests check them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

#: Azimuth either side of a base's facing direction over which ``reach`` was measured (rad).
REACH_AZIMUTH = 0.8


@dataclass(frozen=True)
class ArmModel:
    name: str
    urdf: str                            # path relative to pybullet_data
    arm_joints: tuple[str, ...]          # revolute joints the planner drives, base to tip
    joint_limits: tuple[tuple[float, float], ...]   # rad, from the URDF
    joint_max_velocity: tuple[float, ...]           # rad/s, from the URDF
    joint_max_force: tuple[float, ...]              # N m, from the URDF
    tool_link: str
    tool_offset: float                   # m along the tool link's z axis to the tool point
    grasps_from_top: bool                # True: tool point on the cube's top face; False: at its centre
    finger_joints: tuple[str, ...]       # prismatic finger joints (each opens by its position)
    finger_max_opening: float            # m, per finger
    finger_force: float                  # N
    home: tuple[float, ...]
    ready: tuple[float, ...]
    reach: tuple[float, float]           # m, horizontal distance from the base axis
    reach_height: tuple[float, float]    # m, grasp/place tool height relative to the base top
    pedestal_radius: float               # m, pedestal under the base (covers the base link)

    @property
    def max_cube_edge(self) -> float:
        """Largest cube the gripper can take (m); unlimited for a flange grasp."""
        if not self.finger_joints:
            return math.inf
        return 2.0 * self.finger_max_opening - 0.01


ARM_MODELS: dict[str, ArmModel] = {
    # Franka Emika Panda (pybullet_data franka_panda/panda.urdf).
    'panda': ArmModel(
        name='panda', urdf='franka_panda/panda.urdf',
        arm_joints=tuple(f'panda_joint{i}' for i in range(1, 8)),
        joint_limits=((-2.9671, 2.9671), (-1.8326, 1.8326), (-2.9671, 2.9671), (-3.1416, 0.0),
                      (-2.9671, 2.9671), (-0.0873, 3.8223), (-2.9671, 2.9671)),
        joint_max_velocity=(2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61),
        joint_max_force=(87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0),
        tool_link='panda_grasptarget', tool_offset=0.0, grasps_from_top=False,
        finger_joints=('panda_finger_joint1', 'panda_finger_joint2'), finger_max_opening=0.04,
        finger_force=20.0,
        home=(0.0, -1.6, 0.0, -2.9, 0.0, 1.9, 0.785),
        ready=(0.0, -0.2, 0.0, -2.3, 0.0, 2.1, 0.785),
        reach=(0.27, 0.74), reach_height=(-0.05, 0.15), pedestal_radius=0.16),
    # KUKA LBR iiwa 14 (pybullet_data kuka_iiwa/model.urdf); no gripper: flange grasp.
    'kuka_iiwa': ArmModel(
        name='kuka_iiwa', urdf='kuka_iiwa/model.urdf',
        arm_joints=tuple(f'lbr_iiwa_joint_{i}' for i in range(1, 8)),
        joint_limits=((-2.9671, 2.9671), (-2.0944, 2.0944), (-2.9671, 2.9671), (-2.0944, 2.0944),
                      (-2.9671, 2.9671), (-2.0944, 2.0944), (-3.0543, 3.0543)),
        joint_max_velocity=(10.0,) * 7,
        joint_max_force=(300.0,) * 7,
        tool_link='lbr_iiwa_link_7', tool_offset=0.048, grasps_from_top=True,
        finger_joints=(), finger_max_opening=0.0, finger_force=0.0,
        home=(0.0, -0.3, 0.0, 0.9, 0.0, -0.6, 0.0),
        ready=(0.0, 0.6, 0.0, -1.2, 0.0, 1.3, 0.0),
        reach=(0.41, 0.76), reach_height=(-0.05, 0.15), pedestal_radius=0.16),
    # UFACTORY xArm6 (pybullet_data xarm/xarm6_robot.urdf); no gripper: flange grasp.
    'xarm6': ArmModel(
        name='xarm6', urdf='xarm/xarm6_robot.urdf',
        arm_joints=tuple(f'joint{i}' for i in range(1, 7)),
        joint_limits=((-6.2832, 6.2832), (-2.059, 2.0944), (-3.927, 0.1920), (-6.2832, 6.2832),
                      (-1.6930, 3.1416), (-6.2832, 6.2832)),
        joint_max_velocity=(3.14,) * 6,
        joint_max_force=(50.0, 50.0, 32.0, 32.0, 32.0, 20.0),
        tool_link='link6', tool_offset=0.004, grasps_from_top=True,
        finger_joints=(), finger_max_opening=0.0, finger_force=0.0,
        home=(0.0, -1.3, -0.3, 0.0, 1.6, 0.0),
        ready=(0.0, -0.3, -1.2, 0.0, 1.5, 0.0),
        reach=(0.25, 0.64), reach_height=(-0.05, 0.15), pedestal_radius=0.12),
}


def wrap_angle(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def grasp_yaw(object_yaw: float, approach_yaw: float) -> float:
    """Tool yaw aligned with the object's faces (object_yaw + k pi/2) closest to ``approach_yaw``.

    ``approach_yaw`` is the direction from the arm's base to the object, which keeps the
    wrist near its middle for every arm in the catalogue.
    """
    k = round(wrap_angle(approach_yaw - object_yaw) / (math.pi / 2.0))
    return wrap_angle(object_yaw + k * math.pi / 2.0)
