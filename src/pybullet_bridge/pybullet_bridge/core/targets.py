"""Named markers that fiducial sensors detect (the ``targets`` section).

The paper's monitoring task has targets entering the environment (black squares in
Fig. 8) whose global positions the robots must provide; its navigation task has goal
beacons. A target is a small upright cylinder with a collision shape (robots bump into
it; rays hit it). ``mass: 0`` (default) makes it static; a positive mass makes it a
dynamic body that can be pushed.

Definition and parsing only; :mod:`.passive_bodies` spawns it in pybullet.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from collab_tools.core.fields import Fields, fail, join_path, require_list

from .entity import EntityDefinition
from .errors import ScenarioError
from .sections import SectionContext

DEFAULT_TARGET_COLOR = (0.05, 0.05, 0.05)


@dataclass(eq=False)
class Target(EntityDefinition):
    """A named cylinder standing on the ground."""

    kind = 'target'

    name: str
    position: tuple[float, float]
    radius: float
    height: float
    mass: float = 0.0
    color: tuple[float, float, float] = DEFAULT_TARGET_COLOR
    config_path: str = ''

    def __post_init__(self):
        self.position = (float(self.position[0]), float(self.position[1]))
        self.radius = float(self.radius)
        self.height = float(self.height)
        self.mass = float(self.mass)
        self.color = tuple(self.color)


def parse_targets(value: Any, context: SectionContext) -> list[Target]:
    """Parse the ``targets`` section: a list of target entries."""
    if value is None:
        return []
    targets: list[Target] = []
    for index, item in enumerate(require_list(value, context.path, error=ScenarioError)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=('name', 'position', 'radius', 'height', 'mass', 'color'), error=ScenarioError)
        name = fields.name('name')
        position = fields.vector('position', 2)
        radius = fields.number('radius', 0.05, gt=0.0, le=1.0)
        if not context.world.contains(position[0], position[1], margin=radius):
            raise fail(fields.path_of('position'), f'target footprint (x {position[0]}, y {position[1]}, '
                       f'radius {radius}) must lie inside world.bounds {list(context.world.bounds)}', error=ScenarioError)
        targets.append(Target(name, position, radius,  # type: ignore[arg-type]
                              height=fields.number('height', 0.3, gt=0.0, le=5.0),
                              mass=fields.number('mass', 0.0, ge=0.0, le=1000.0),
                              color=fields.color('color', DEFAULT_TARGET_COLOR), config_path=path))
    return targets

