"""Pure-Python simulation core of the pybullet bridge (no ROS imports).

Importing this package registers the built-in scenario sections
(``mobile_robots``, ``obstacles``).
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

__all__ = [
    'BodyStateData', 'BoxObstacle', 'CameraConfig', 'CameraFrame', 'DiffDriveLimits', 'MobileRobot',
    'RobotParams', 'Scenario', 'ScenarioError', 'Scene', 'SceneEntity', 'SectionContext',
    'TopViewCamera', 'WallConfig', 'WallSet', 'WorldConfig', 'limit_velocity', 'load_map_boxes',
    'load_scenario', 'occupancy_to_rectangles', 'parse_scenario', 'register_section',
    'registered_sections', 'unregister_section',
]
