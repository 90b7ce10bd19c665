"""The world and camera sections of a scenario: arena bounds, physics settings, walls, top-view camera."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from collab_tools.core.fields import Fields, fail

from .errors import ScenarioError

DEFAULT_PHYSICS_DT = 1.0 / 240.0  # pybullet's own default step
#: Shortest physics step: 10 kHz. A control tick is control_period / physics_dt steps (1e-300 would be
#: 1e298 steps: the bridge would never finish its first tick); 1e-4 s keeps a 10 ms tick at 100 steps.
MIN_PHYSICS_DT = 1e-4
DEFAULT_BOUNDS = (-3.0, -3.0, 3.0, 3.0)
#: Name of the wall entity the scene adds when world.walls is set.
WALLS_ENTITY_NAME = 'walls'


@dataclass(frozen=True)
class WallConfig:
    height: float
    thickness: float


@dataclass(frozen=True)
class WorldConfig:
    frame_id: str
    physics_dt: float
    gravity: float
    bounds: tuple[float, float, float, float]
    walls: WallConfig | None

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        """True if the disc of radius ``margin`` around (x, y) lies inside bounds."""
        xmin, ymin, xmax, ymax = self.bounds
        return xmin + margin <= x <= xmax - margin and ymin + margin <= y <= ymax - margin


@dataclass(frozen=True)
class CameraConfig:
    frame_id: str
    rate: float
    width: int
    height: int
    center: tuple[float, float]
    altitude: float
    fov_deg: float


def parse_world(value: Any) -> WorldConfig:
    fields = Fields({} if value is None else value, 'world',
                    allowed=('frame_id', 'physics_dt', 'gravity', 'bounds', 'walls'), error=ScenarioError)
    bounds = fields.vector('bounds', 4, DEFAULT_BOUNDS)
    xmin, ymin, xmax, ymax = bounds
    if not (xmin < xmax and ymin < ymax):
        raise fail('world.bounds', f'must be [xmin, ymin, xmax, ymax] with xmin < xmax and ymin < ymax '
                   f'(got {list(bounds)})', error=ScenarioError)
    walls = None
    if fields.raw('walls', None) is not None:
        wall_fields = Fields(fields.raw('walls'), 'world.walls', allowed=('height', 'thickness'), error=ScenarioError)
        walls = WallConfig(height=wall_fields.number('height', 0.3, gt=0.0),
                           thickness=wall_fields.number('thickness', 0.05, gt=0.0))
    return WorldConfig(
        frame_id=fields.string('frame_id', 'world'),
        physics_dt=fields.number('physics_dt', DEFAULT_PHYSICS_DT, ge=MIN_PHYSICS_DT, le=0.05),
        gravity=fields.number('gravity', -9.81),
        bounds=bounds,  # type: ignore[arg-type]
        walls=walls,
    )


def parse_camera(value: Any, world: WorldConfig) -> CameraConfig:
    fields = Fields({} if value is None else value, 'camera', allowed=(
        'frame_id', 'rate', 'width', 'height', 'center', 'altitude', 'fov_deg'), error=ScenarioError)
    xmin, ymin, xmax, ymax = world.bounds
    return CameraConfig(
        frame_id=fields.string('frame_id', 'top_camera'),
        rate=fields.number('rate', 10.0, gt=0.0, le=100.0),
        width=fields.integer('width', 320, ge=16, le=2048),
        height=fields.integer('height', 320, ge=16, le=2048),
        center=fields.vector('center', 2, ((xmin + xmax) / 2, (ymin + ymax) / 2)),  # type: ignore[arg-type]
        altitude=fields.number('altitude', 8.0, gt=0.0),
        fov_deg=fields.number('fov_deg', 45.0, gt=1.0, lt=170.0),
    )
