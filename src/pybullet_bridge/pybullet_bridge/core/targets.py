"""Named markers that fiducial sensors detect (the ``targets`` section).

The paper's monitoring task has targets entering the environment (black squares in
Fig. 8) whose global positions the robots must provide; its navigation task has goal
beacons. A target is a small upright cylinder with a collision shape (robots bump into
it; rays hit it). ``mass: 0`` (default) makes it static; a positive mass makes it a
dynamic body that can be pushed.
"""
from __future__ import annotations

from typing import Any

import pybullet as p

from .fields import Fields, fail, join_path, require_list
from .scenario import SectionContext, register_section
from .scene import SceneEntity

DEFAULT_TARGET_COLOR = (0.05, 0.05, 0.05)


class Target(SceneEntity):
    """A named cylinder standing on the ground."""

    kind = 'target'

    def __init__(self, name: str, position: tuple[float, float], radius: float, height: float,
                 mass: float = 0.0, color: tuple[float, float, float] = DEFAULT_TARGET_COLOR,
                 config_path: str = ''):
        self.name = name
        self.position = (float(position[0]), float(position[1]))
        self.radius = float(radius)
        self.height = float(height)
        self.mass = float(mass)
        self.color = tuple(color)
        self.config_path = config_path

    def spawn(self, client: int) -> list[int]:
        collision = p.createCollisionShape(p.GEOM_CYLINDER, radius=self.radius, height=self.height,
                                           physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_CYLINDER, radius=self.radius, length=self.height,
                                     rgbaColor=[*self.color, 1.0], physicsClientId=client)
        return [p.createMultiBody(baseMass=self.mass, baseCollisionShapeIndex=collision,
                                  baseVisualShapeIndex=visual,
                                  basePosition=[*self.position, self.height / 2.0], physicsClientId=client)]


def parse_targets(value: Any, context: SectionContext) -> list[Target]:
    """Parse the ``targets`` section: a list of target entries."""
    if value is None:
        return []
    targets: list[Target] = []
    for index, item in enumerate(require_list(value, context.path)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=('name', 'position', 'radius', 'height', 'mass', 'color'))
        name = fields.name('name')
        position = fields.vector('position', 2)
        radius = fields.number('radius', 0.05, gt=0.0, le=1.0)
        if not context.world.contains(position[0], position[1], margin=radius):
            raise fail(fields.path_of('position'), f'target footprint (x {position[0]}, y {position[1]}, '
                       f'radius {radius}) must lie inside world.bounds {list(context.world.bounds)}')
        targets.append(Target(name, position, radius,  # type: ignore[arg-type]
                              height=fields.number('height', 0.3, gt=0.0, le=5.0),
                              mass=fields.number('mass', 0.0, ge=0.0, le=1000.0),
                              color=fields.color('color', DEFAULT_TARGET_COLOR), config_path=path))
    return targets


register_section('targets', parse_targets)
