"""Pure-Python simulation core of the pybullet bridge (no ROS imports).

The bridge implements no paper; it stands in for every robot, sensor and camera the three
papers' systems use. Module map by concept ("sim" = drives pybullet; the others import no
simulator, so sgcm, role_engine and the coalition agents read scenarios without it):

**Scenario format** (a YAML file -> a validated :class:`~.scenario.Scenario`; schema in :mod:`.scenario`)
  ``scenario``         loading and parsing a file; registers the built-in sections in label order
  ``sections``         the section registry and :class:`~.sections.SectionContext` a parser gets
  ``scenario_access``  the directories ``~/reset`` may load a requested scenario from
  ``world``            ``world`` (bounds, physics step, walls) and ``camera`` sections
  ``robot_types``      built-in and scenario robot types
  ``entity``           entity definitions vs simulated entities, ground-truth body state
  ``errors``           :class:`~.errors.ScenarioError` (a ConfigurationError naming the field)
  ``mobile_robot``, ``obstacles``, ``tabletop``, ``targets``, ``movable_boxes``, ``arm.definition``
                       each section's definitions and parser
  ``occupancy_map``    occupancy images -> rectangles (the ``obstacles.map`` field; OpenCV decodes the
                       file input_files read and sized); MAX_MAP_BOXES, the most boxes a scene may have
  ``sensor_config``    a robot's ``sensors`` field
**Simulation**
  ``scene`` (sim)          a pybullet client holding a scenario's entities; steps, labels, resets
  ``passive_bodies`` (sim) bodies of obstacles, walls, tables, cubes, targets, movable boxes
  ``mobile_robot_body`` (sim)  a differential-drive robot's body and drive
  ``diff_drive``           velocity and acceleration limits of a differential drive
  ``pacing``               how many control ticks are due for a real-time factor; rate schedules
  ``throttle``             a rate limit in simulated time (compressed camera streams)
**Sensors**
  ``sensors`` (sim)        fiducial, laser, GPS and bumper readings (configured by ``sensor_config``)
**Camera**
  ``camera`` (sim)         the top-view pinhole camera: intrinsics, pixel <-> world, rendering
  ``renderer``             which renderer draws it: pybullet's EGL plugin where it loads, else TinyRenderer
  ``placement``            the pixel test: where an object fits in a region of the label image
**Arm** (``arm/``: its ``__init__`` maps the modules; models, definition, task, requests, state
  machine and outcome are pure, kinematics, segments, planning, recovery, gripper, simulation sim)
**TF frames**
  ``frames``               the frame names and the static and dynamic transforms the bridge publishes
**Node settings**
  ``settings``             the bridge node's and the camera's parameters as a SettingsSchema

Importing this package runs no module: the names below are loaded on first use, so
``import pybullet_bridge.core.<pure module>`` never pulls in the simulator.
"""
from importlib import import_module

#: Public name -> module that defines it (loaded on first access).
_EXPORTS = {
    'ARM_MODELS': '.arm.models', 'ArmModel': '.arm.models', 'Arm': '.arm.definition',
    'ArmLimits': '.arm.definition', 'Outcome': '.arm.task', 'PickPlaceTask': '.arm.task',
    'ArmKinematics': '.arm.kinematics', 'SimulatedArm': '.arm.simulation',
    'BodyStateData': '.entity', 'SceneEntity': '.entity', 'EntityDefinition': '.entity',
    'BoxObstacle': '.obstacles', 'WallSet': '.obstacles', 'load_map_boxes': '.obstacles',
    'occupancy_to_rectangles': '.occupancy_map',
    'CameraConfig': '.world', 'WallConfig': '.world', 'WorldConfig': '.world',
    'Cube': '.tabletop', 'GridSpec': '.tabletop', 'Table': '.tabletop',
    'DiffDriveLimits': '.diff_drive', 'limit_velocity': '.diff_drive',
    'MobileRobot': '.mobile_robot', 'RobotParams': '.mobile_robot',
    'SimulatedMobileRobot': '.mobile_robot_body',
    'MovableBox': '.movable_boxes', 'Target': '.targets',
    'RobotSensors': '.sensors', 'SensorSet': '.sensor_config',
    'Scenario': '.scenario', 'load_scenario': '.scenario', 'parse_scenario': '.scenario',
    'ScenarioError': '.errors', 'SectionContext': '.sections', 'register_section': '.scenario',
    'registered_sections': '.scenario', 'unregister_section': '.scenario',
    'CameraFrame': '.scene', 'Scene': '.scene', 'TopViewCamera': '.camera',
    'RendererChoice': '.renderer', 'choose_renderer': '.renderer',
    'find_free_pixel': '.placement', 'find_place_position': '.placement', 'region_to_pixels': '.placement',
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value
    return value
