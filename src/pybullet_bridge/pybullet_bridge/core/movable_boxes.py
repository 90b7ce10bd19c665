"""Boxes that mobile robots can push (the ``movable_boxes`` section).

Unlike ``obstacles.boxes`` (static, mass 0) these are dynamic: a robot driving into one
pushes it, against Coulomb friction with the ground (pybullet multiplies the two
bodies' friction coefficients; the ground's is 1, so ``friction`` is the box-ground
coefficient). Robots themselves have zero friction, so a box slides along a robot's
face rather than being dragged sideways. This is the paper's box pushing task (Sec. V-5).
"""
from __future__ import annotations

import math
from typing import Any

import pybullet as p

from .fields import Fields, fail, join_path, require_list
from .scenario import SectionContext, register_section
from .scene import SceneEntity

DEFAULT_MOVABLE_BOX_COLOR = (0.55, 0.3, 0.7)


class MovableBox(SceneEntity):
    """A dynamic box resting on the ground."""

    kind = 'movable_box'

    def __init__(self, name: str, center: tuple[float, float], size: tuple[float, float], height: float,
                 mass: float, friction: float, yaw: float = 0.0,
                 color: tuple[float, float, float] = DEFAULT_MOVABLE_BOX_COLOR, config_path: str = ''):
        self.name = name
        self.center = (float(center[0]), float(center[1]))
        self.size = (float(size[0]), float(size[1]))
        self.height = float(height)
        self.mass = float(mass)
        self.friction = float(friction)
        self.yaw = float(yaw)
        self.color = tuple(color)
        self.config_path = config_path

    def half_diagonal(self) -> float:
        return math.hypot(*self.size) / 2.0

    def spawn(self, client: int) -> list[int]:
        half_extents = [self.size[0] / 2.0, self.size[1] / 2.0, self.height / 2.0]
        collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half_extents, physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half_extents, rgbaColor=[*self.color, 1.0],
                                     physicsClientId=client)
        body = p.createMultiBody(
            baseMass=self.mass, baseCollisionShapeIndex=collision, baseVisualShapeIndex=visual,
            basePosition=[*self.center, self.height / 2.0],
            baseOrientation=p.getQuaternionFromEuler([0.0, 0.0, self.yaw]), physicsClientId=client)
        p.changeDynamics(body, -1, lateralFriction=self.friction, restitution=0.0, physicsClientId=client)
        return [body]


def parse_movable_boxes(value: Any, context: SectionContext) -> list[MovableBox]:
    """Parse the ``movable_boxes`` section: a list of box entries."""
    if value is None:
        return []
    boxes: list[MovableBox] = []
    for index, item in enumerate(require_list(value, context.path)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=('name', 'center', 'size', 'height', 'mass', 'friction', 'yaw',
                                             'color'))
        box = MovableBox(
            name=fields.name('name'),
            center=fields.vector('center', 2),  # type: ignore[arg-type]
            size=fields.vector('size', 2, gt=0.0, le=10.0),  # type: ignore[arg-type]
            height=fields.number('height', 0.3, gt=0.0, le=5.0),
            mass=fields.number('mass', 2.0, gt=0.0, le=1000.0),
            friction=fields.number('friction', 0.5, ge=0.0, le=10.0),
            yaw=fields.number('yaw', 0.0),
            color=fields.color('color', DEFAULT_MOVABLE_BOX_COLOR), config_path=path)
        if not context.world.contains(*box.center, margin=box.half_diagonal()):
            raise fail(fields.path_of('center'), f'box (centre {list(box.center)}, size {list(box.size)}) '
                       f'must lie inside world.bounds {list(context.world.bounds)}')
        boxes.append(box)
    return boxes


register_section('movable_boxes', parse_movable_boxes)
