"""The seeded problems of Tables III and IV: sources drawn in a disc, destinations a formation.

Every point keeps some clearance in the largest robot's main free region, so every robot can
reach every destination; destinations are a circle, square, diamond or line at least
``min_travel`` from the sources' disc (``placement`` in config/roles/experiments.yaml). A problem
depends only on (seed, environment index, problem index).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.environment import Environment, RobotType
from ..core.errors import RoleEngineError
from ..core.formations import circle_formation, diamond_formation, line_formation, square_formation
from ..core.negotiation import Agent, Role
from .config import Placement, TableSettings


def rounded(array: np.ndarray, digits: int = 4) -> list:
    return np.round(np.asarray(array, dtype=float), digits).tolist()


@dataclass
class Problem:
    """Agents at their sources and roles at the formation's points, on one environment."""

    environment: str
    index: int
    agents: list[Agent]
    roles: list[Role]
    formation: str

    @property
    def sources(self) -> np.ndarray:
        return np.array([a.position for a in self.agents])

    @property
    def destinations(self) -> np.ndarray:
        return np.array([r.destination for r in self.roles])

    def describe(self) -> dict:
        types = {}
        for agent in self.agents:
            types.setdefault(agent.robot_type.name, agent.robot_type.radius)
        return {'environment': self.environment, 'problem': self.index, 'formation': self.formation,
                'robot_types': types, 'agents': [a.name for a in self.agents],
                'agent_types': [a.robot_type.name for a in self.agents],
                'sources': rounded(self.sources), 'destinations': rounded(self.destinations)}


_FORMATION_BUILDERS = {
    'circle': lambda centre, size, count, rotation: circle_formation(centre, size / 2.0, count, rotation),
    'square': square_formation, 'diamond': diamond_formation, 'line': line_formation,
}


def _robot_types(settings: TableSettings, problem_index: int) -> list[RobotType]:
    if settings.robot_groups:
        return [RobotType(g.name, g.radius) for g in settings.robot_groups for _ in range(g.count)]
    radius = settings.robot_radii[problem_index % len(settings.robot_radii)]
    return [RobotType(f'r{radius:g}', radius)] * settings.robots


class _PlacementCheck:
    """Where robots may be placed: clearance in the largest robot's main free region."""

    def __init__(self, environment: Environment, largest: RobotType, placement: Placement):
        self.view = environment.for_robot(largest)
        sizes = np.bincount(self.view.components.ravel())
        if len(sizes) < 2:
            raise RoleEngineError(f"{environment.name}: no free space for a robot of radius {largest.radius} m")
        self.main = int(np.argmax(sizes[1:]) + 1)
        self.clearance = placement.clearance
        self.bounds = self.view.frame.bounds

    def valid(self, points: np.ndarray) -> bool:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        x0, y0, x1, y1 = self.bounds
        if np.any((points[:, 0] <= x0) | (points[:, 0] >= x1) | (points[:, 1] <= y0) | (points[:, 1] >= y1)):
            return False
        cells = self.view.frame.world_to_cell(points)
        if np.any(self.view.components[cells[:, 0], cells[:, 1]] != self.main):
            return False
        return bool(np.all(self.view.sdf.distance(points) >= self.clearance))


def _separated(points: np.ndarray, gap: float) -> bool:
    if len(points) < 2:
        return True
    distances = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)
    return bool(np.min(distances[np.triu_indices(len(points), 1)]) >= gap)


def _draw_sources(rng, check: _PlacementCheck, count: int, spread: float, gap: float,
                  tries: int = 100) -> tuple[np.ndarray, np.ndarray] | None:
    """A random disc centre and ``count`` valid, separated points in the disc (one at a time), or None."""
    x0, y0, x1, y1 = check.bounds
    centre = rng.uniform((x0, y0), (x1, y1))
    points: list[np.ndarray] = []
    for _ in range(count):
        for _ in range(tries):
            angle, radius = rng.uniform(0.0, 2.0 * math.pi), spread * math.sqrt(rng.uniform(0.0, 1.0))
            point = centre + radius * np.array([math.cos(angle), math.sin(angle)])
            if check.valid(point) and all(np.linalg.norm(point - other) >= gap for other in points):
                points.append(point)
                break
        else:
            return None
    return centre, np.array(points)


def draw_problem(environment: Environment, environment_index: int, problem_index: int,
                 settings: TableSettings, formation_tries: int = 100) -> Problem:
    """One seeded problem (module docstring): sources in a disc, destinations in a formation.

    Each of ``max_attempts`` attempts draws a source disc (its points one by one) and then up to
    ``formation_tries`` formations far enough from it.
    """
    placement = settings.placement
    types = _robot_types(settings, problem_index)
    largest = max(types, key=lambda t: t.radius)
    check = _PlacementCheck(environment, largest, placement)
    gap = 2.0 * largest.radius + placement.spacing
    rng = np.random.default_rng([settings.seed, environment_index, problem_index])
    x0, y0, x1, y1 = check.bounds
    count = len(types)
    for _ in range(placement.max_attempts):
        drawn = _draw_sources(rng, check, count, placement.source_spread, gap)
        if drawn is None:
            continue
        centre, sources = drawn
        for _ in range(formation_tries):
            target = rng.uniform((x0, y0), (x1, y1))
            if np.linalg.norm(target - centre) < placement.min_travel:
                continue
            kind = placement.formations[int(rng.integers(len(placement.formations)))]
            size = rng.uniform(*placement.formation_size)
            destinations = _FORMATION_BUILDERS[kind](target, size, count, rng.uniform(0.0, 2.0 * math.pi))
            if check.valid(destinations) and _separated(destinations, gap):
                agents = [Agent(f'robot{i}', t, (float(p[0]), float(p[1])))
                          for i, (t, p) in enumerate(zip(types, sources))]
                roles = [Role(f'role{j}', (float(p[0]), float(p[1]))) for j, p in enumerate(destinations)]
                return Problem(environment.name, problem_index, agents, roles, kind)
    raise RoleEngineError(f'{environment.name}: no placement of {count} robots (radius up to {largest.radius} m) '
                          f'found in {placement.max_attempts} attempts; lower placement.min_travel, '
                          'placement.clearance or placement.formation_size')

