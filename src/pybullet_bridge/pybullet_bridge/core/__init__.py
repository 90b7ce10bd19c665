"""Pure-Python simulation core of the pybullet bridge (no ROS imports).

Importing this package registers the built-in scenario sections
(``mobile_robots``, ``obstacles``, ``tables``, ``cubes``, ``arms``, ``targets``,
``movable_boxes``).
"""
from .errors import ScenarioError
from .scenario import (
    CameraConfig, Scenario, SectionContext, WallConfig, WorldConfig,
    load_scenario, parse_scenario, register_section, registered_sections, unregister_section,
)
from .diff_drive import DiffDriveLimits, limit_velocity
from .camera import TopViewCamera
from .scene import BodyStateData, CameraFrame, Scene, SceneEntity
from .mobile_robot import MobileRobot, RobotParams
from .obstacles import BoxObstacle, WallSet, load_map_boxes, occupancy_to_rectangles
from .tabletop import Cube, GridSpec, Table
from .placement import find_free_pixel, find_place_position, region_to_pixels
from .arm_models import ARM_MODELS, ArmKinematics, ArmModel
from .arm import Arm, ArmLimits, Outcome, PickPlaceTask
from .targets import Target
from .movable_boxes import MovableBox
from .sensor_config import SensorSet
from .sensors import RobotSensors

__all__ = [
    'ARM_MODELS', 'Arm', 'ArmKinematics', 'ArmLimits', 'ArmModel', 'BodyStateData', 'BoxObstacle',
    'CameraConfig', 'CameraFrame', 'Cube', 'DiffDriveLimits', 'GridSpec', 'MobileRobot', 'MovableBox',
    'Outcome', 'PickPlaceTask', 'RobotParams', 'RobotSensors', 'Scenario', 'ScenarioError', 'Scene',
    'SceneEntity', 'SectionContext', 'SensorSet', 'Table', 'Target', 'TopViewCamera', 'WallConfig',
    'WallSet', 'WorldConfig', 'find_free_pixel', 'find_place_position', 'limit_velocity',
    'load_map_boxes', 'load_scenario', 'occupancy_to_rectangles', 'parse_scenario', 'region_to_pixels',
    'register_section', 'registered_sections', 'unregister_section',
]
