"""Boxes that mobile robots can push (the ``movable_boxes`` section).

Unlike ``obstacles.boxes`` (static, mass 0) these are dynamic: a robot driving into one
pushes it, against Coulomb friction with the ground (pybullet multiplies the two
bodies' friction coefficients; the ground's is 1, so ``friction`` is the box-ground
coefficient). Robots themselves have zero friction, so a box slides along a robot's
face rather than being dragged sideways. This is the paper's box pushing task (Sec. V-5).

Definition and parsing only; :mod:`.passive_bodies` spawns it in pybullet.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from collab_tools.core.fields import Fields, fail, join_path, require_list

from .entity import EntityDefinition
from .errors import ScenarioError
from .sections import SectionContext

DEFAULT_MOVABLE_BOX_COLOR = (0.55, 0.3, 0.7)


@dataclass(eq=False)
class MovableBox(EntityDefinition):
    """A dynamic box resting on the ground."""

    kind = 'movable_box'

    name: str
    center: tuple[float, float]
    size: tuple[float, float]
    height: float
    mass: float
    friction: float
    yaw: float = 0.0
    color: tuple[float, float, float] = DEFAULT_MOVABLE_BOX_COLOR
    config_path: str = ''

    def __post_init__(self):
        self.center = (float(self.center[0]), float(self.center[1]))
        self.size = (float(self.size[0]), float(self.size[1]))
        self.height = float(self.height)
        self.mass = float(self.mass)
        self.friction = float(self.friction)
        self.yaw = float(self.yaw)
        self.color = tuple(self.color)

    def half_diagonal(self) -> float:
        return math.hypot(*self.size) / 2.0


def parse_movable_boxes(value: Any, context: SectionContext) -> list[MovableBox]:
    """Parse the ``movable_boxes`` section: a list of box entries."""
    if value is None:
        return []
    boxes: list[MovableBox] = []
    for index, item in enumerate(require_list(value, context.path, error=ScenarioError)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=('name', 'center', 'size', 'height', 'mass', 'friction', 'yaw',
                                             'color'), error=ScenarioError)
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
                       f'must lie inside world.bounds {list(context.world.bounds)}', error=ScenarioError)
        boxes.append(box)
    return boxes

