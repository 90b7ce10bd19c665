"""Fixed-base arms as a scenario defines them (the ``arms`` section): model, base, limits, seed.

Definition, reach geometry and parsing only; :mod:`.simulation` runs the arm in pybullet.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from collab_tools.core.fields import Fields, check_number, check_vector, fail, join_path, require_list

from ..entity import EntityDefinition
from ..errors import ScenarioError
from ..sections import SectionContext
from ..tabletop import Cube, rects_overlap, tables_in
from .models import ARM_MODELS, ArmModel
from .timing import joint_move_duration, linear_move_duration


@dataclass(frozen=True)
class ArmLimits:
    max_joint_velocity: float   # rad/s, also capped by each joint's URDF limit
    max_tool_speed: float       # m/s of the tool point on straight segments
    phase_timeout: float        # s a segment may run beyond its planned duration


@dataclass(eq=False)
class Arm(EntityDefinition):
    """A fixed-base arm on a pedestal that picks and places cubes."""

    kind = 'arm'

    name: str
    model: ArmModel
    base: tuple[float, float, float]
    base_height: float
    failure_probability: float
    seed: int
    limits: ArmLimits
    home: tuple[float, ...]
    placement_clearance: float
    config_path: str = ''

    def __post_init__(self):
        self.base = tuple(float(v) for v in self.base)
        self.base_height = float(self.base_height)
        self.failure_probability = float(self.failure_probability)
        self.seed = int(self.seed)
        self.home = tuple(float(v) for v in self.home)
        self.placement_clearance = float(self.placement_clearance)

    # -- geometry -----------------------------------------------------------------

    def horizontal_distance(self, x: float, y: float) -> float:
        return math.hypot(x - self.base[0], y - self.base[1])

    def reach_problem(self, what: str, x: float, y: float, z: float) -> str | None:
        """Why the tool cannot work at (x, y) with the tool at height z, or None if it can."""
        low, high = self.model.reach
        distance = self.horizontal_distance(x, y)
        if not low <= distance <= high:
            return (f"{what} at ({x:.3f}, {y:.3f}) is {distance:.3f} m from the base of arm "
                    f"'{self.name}' ({self.model.name} reach {low:.2f}..{high:.2f} m); out of reach")
        height = z - self.base_height
        zlow, zhigh = self.model.reach_height
        if not zlow <= height <= zhigh:
            return (f"{what} at ({x:.3f}, {y:.3f}) is {height:+.3f} m above the base of arm '{self.name}' "
                    f'(workable {zlow:+.2f}..{zhigh:+.2f} m); out of reach')
        return None

    # -- timing -------------------------------------------------------------------

    def joint_velocity_limits(self) -> np.ndarray:
        return np.minimum(self.limits.max_joint_velocity, np.array(self.model.joint_max_velocity))

    def joint_move_duration(self, start: np.ndarray, goal: np.ndarray) -> float:
        return joint_move_duration(start, goal, self.joint_velocity_limits())

    def linear_move_duration(self, start: np.ndarray, goal: np.ndarray) -> float:
        return linear_move_duration(start, goal, self.limits.max_tool_speed)


def _derived_seed(scenario_seed: int | None, index: int) -> int:
    """Seed of arm ``index`` when the scenario gives none: reproducible, distinct per arm."""
    entropy = 0 if scenario_seed is None else scenario_seed
    return int(np.random.SeedSequence(entropy=entropy, spawn_key=(index,)).generate_state(1)[0])


def parse_arms(value: Any, context: SectionContext) -> list[Arm]:
    """Parse the ``arms`` section: a list of arm entries."""
    if value is None:
        return []
    tables = tables_in(context.earlier)
    cubes = [c for c in context.earlier.get('cubes', []) if isinstance(c, Cube)]
    arms: list[Arm] = []
    for index, item in enumerate(require_list(value, context.path, error=ScenarioError)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=(
            'name', 'model', 'base', 'base_height', 'failure_probability', 'seed', 'max_joint_velocity',
            'max_tool_speed', 'phase_timeout', 'home', 'placement_clearance'), error=ScenarioError)
        name = fields.name('name')
        model_name = fields.string('model')
        if model_name not in ARM_MODELS:
            raise fail(fields.path_of('model'), f"unknown arm model '{model_name}' "
                       f"(known: {', '.join(ARM_MODELS)})", error=ScenarioError)
        model = ARM_MODELS[model_name]
        base = fields.vector('base', 3)
        base_height = fields.number('base_height', 0.0, ge=0.0, le=2.0)
        radius = model.pedestal_radius
        if not context.world.contains(base[0], base[1], margin=radius):
            raise fail(fields.path_of('base'), f'arm base (x {base[0]}, y {base[1]}, pedestal radius {radius}) '
                       f'must lie inside world.bounds {list(context.world.bounds)}', error=ScenarioError)
        footprint = (base[0] - radius, base[1] - radius, base[0] + radius, base[1] + radius)
        for table in tables:
            if rects_overlap(footprint, table.top_rect):
                raise fail(fields.path_of('base'), f"the {model_name} pedestal (radius {radius} m) at "
                           f"({base[0]}, {base[1]}) stands inside table '{table.name}' "
                           f'{[round(v, 3) for v in table.top_rect]}', error=ScenarioError)
        for cube in cubes:
            if rects_overlap(footprint, cube.footprint()):
                raise fail(fields.path_of('base'), f"the {model_name} pedestal at ({base[0]}, {base[1]}) "
                           f"overlaps cube '{cube.name}'", error=ScenarioError)
        failure_probability = fields.number('failure_probability', 0.0, ge=0.0, le=1.0)
        seed = fields.integer('seed') if fields.raw('seed', None) is not None else \
            _derived_seed(context.seed, index)
        home = model.home
        if fields.raw('home', None) is not None:
            home_path = fields.path_of('home')
            home = check_vector(fields.raw('home'), home_path, len(model.arm_joints), error=ScenarioError)
            for joint, (value, (low, high)) in enumerate(zip(home, model.joint_limits)):
                check_number(value, join_path(home_path, joint), ge=low, le=high, error=ScenarioError)
        limits = ArmLimits(
            max_joint_velocity=fields.number('max_joint_velocity', 1.5, gt=0.0, le=10.0),
            max_tool_speed=fields.number('max_tool_speed', 0.4, gt=0.0, le=2.0),
            phase_timeout=fields.number('phase_timeout', 2.0, gt=0.0, le=60.0))
        arms.append(Arm(name, model, base, base_height, failure_probability,  # type: ignore[arg-type]
                        seed, limits, home, fields.number('placement_clearance', 0.01, ge=0.0, le=0.2),
                        config_path=path))
    return arms

