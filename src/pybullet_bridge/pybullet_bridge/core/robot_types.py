"""Robot types: the body and drive limits every mobile robot takes from its type (``robot_types``).

Built-ins ``pioneer_3dx`` and ``turtlebot3_burger`` always exist; a scenario may add types or
override fields of a built-in (see :mod:`.scenario` for the schema).
"""
from __future__ import annotations

from typing import Any

from collab_tools.core.fields import Fields, check_name, join_path, require_mapping

from .errors import ScenarioError

#: Fields a robot type defines; each may be overridden per robot.
ROBOT_TYPE_FIELDS = (
    'radius', 'height', 'mass',
    'max_linear_velocity', 'max_angular_velocity',
    'max_linear_acceleration', 'max_angular_acceleration',
    'command_timeout',
)

BUILTIN_ROBOT_TYPES: dict[str, dict[str, float]] = {
    # Adept MobileRobots Pioneer 3-DX datasheet: 455 mm wide (radius ~0.228 m),
    # 237 mm tall, 9 kg, 1.2 m/s, 300 deg/s. The ARIA firmware default
    # accelerations (0.3 m/s^2, 100 deg/s^2) are sluggish for teleoperated
    # experiments, so we use the firmware's reachable 1.0 m/s^2 and 3.0 rad/s^2.
    'pioneer_3dx': {
        'radius': 0.23, 'height': 0.24, 'mass': 9.0,
        'max_linear_velocity': 1.2, 'max_angular_velocity': 5.24,
        'max_linear_acceleration': 1.0, 'max_angular_acceleration': 3.0,
        'command_timeout': 0.5,
    },
    # ROBOTIS TurtleBot3 Burger e-Manual: 138 x 178 x 192 mm, 1 kg,
    # 0.22 m/s, 2.84 rad/s; radius 0.105 m and the accelerations
    # (acc_lim_x 2.5, acc_lim_theta 3.2) are the turtlebot3_navigation2 burger values.
    'turtlebot3_burger': {
        'radius': 0.105, 'height': 0.192, 'mass': 1.0,
        'max_linear_velocity': 0.22, 'max_angular_velocity': 2.84,
        'max_linear_acceleration': 2.5, 'max_angular_acceleration': 3.2,
        'command_timeout': 0.5,
    },
}


def parse_robot_types(value: Any) -> dict[str, dict[str, float]]:
    types = {name: dict(params) for name, params in BUILTIN_ROBOT_TYPES.items()}
    if value is None:
        return types
    for type_key, spec in require_mapping(value, 'robot_types', error=ScenarioError).items():
        path = join_path('robot_types', str(type_key))
        check_name(type_key, path, error=ScenarioError)
        fields = Fields(spec, path, allowed=ROBOT_TYPE_FIELDS, error=ScenarioError)
        base = types.get(type_key)
        params = {}
        for key in ROBOT_TYPE_FIELDS:
            if base is not None and not fields.has(key):
                params[key] = base[key]
            else:
                # Every robot type field is a strictly positive quantity.
                params[key] = fields.number(key, gt=0.0)
        types[type_key] = params
    return types
