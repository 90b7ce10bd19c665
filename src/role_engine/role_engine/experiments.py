"""The role engine's simulation experiments of the paper (Sec. V-A, Tables III and IV), without ROS.

- :func:`run_table3` (``scripts/experiment roles-table3``): GP inference initialised from the
  E-Map (our method) vs from a straight line (plain GPMP), four homogeneous robots per problem,
  every environment and every ``sigma_obs``.
- :func:`run_table4` (``scripts/experiment roles-table4``): Group Role Assignment vs
  nearest-neighbour association for three small and three large robots, E-Map initialisation
  for both.

Settings come from ``config/roles/experiments.yaml`` (documented there). Each run writes
``results.json``, ``table3.md`` / ``table4.md`` and PNG plots into its run directory and reports
one progress line per step through ``log``.

One problem, one scenario (Algorithms 1-3 with the GP planner as the evaluator): negotiate
(Algorithm 2; with or without the E-Map), optimise the process role of every agent-role pair
by GP inference from its initial path (Algorithm 3 lines 7-19), build Q = lambda F_gp + F_conf
(Eq. 13-15), assign (GRA, Hungarian; or nearest neighbour for Table IV's baseline) and measure
the assigned process roles.

Measures (where the paper is terse, what is measured here):

- *feasibility*: share of the assigned process roles that are collision-free. A process role
  fails when "there is at least a point on the graph where the center of the robot touches the
  obstacle" (Sec. V-A-1): the planner's ``collision_free``, i.e. the robot type's
  configuration-space SDF (obstacles inflated by the radius) is >= 0 at every support state and
  at GP-interpolated instants between them. A scenario whose roles cannot be assigned at all
  counts all its process roles as failures.
- *average error* (Table III): the final value of the MAP objective of Eq. 11 that GP inference
  minimises (GP prior + obstacle hinge + start / goal constraints: ``0.5 sum ||W e||^2``, what
  GPMP2's optimiser reports as its error, gtsam's ``graph.error``), averaged over all assigned
  process roles, failed ones included. It is not a distance to the goal: the goal is a
  constraint of the optimisation (sigma 1e-4) and every plan ends there.
- *cost* (Table IV, "overall cost, similar to Eq. 13"): the total qualification sum of
  Q[a, T(a)] over the assignment, averaged over problems.
- *converging time*: LM iterations (accepted steps) of the assigned process roles, averaged over
  the feasible ones only ("only the converging times for the feasible cases ... are considered").

Choices where the paper is silent: process roles start and end with the velocity of their
initial path (GPMP2 fixes start and goal velocities; zeros made the E-Map paths' corners far
harder to keep); the LM starts with GPMP2's damping (``gp.lambda_initial``); the same problems
are solved at every ``sigma_obs``. Problems: sources drawn in a disc, destinations a formation
(circle, square, diamond or line) at least ``min_travel`` away, every point with some clearance
in the largest robot's main free region, so every robot can reach every destination.
"""
from __future__ import annotations

import json
import math
import textwrap
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from pybullet_bridge.core.fields import Fields, check_int, check_number, fail, join_path, read_yaml_file, require_list

from .core.assignment import AssignmentResult, group_role_assignment, nearest_neighbour_assignment
from .core.environment import Environment, RobotEnvironment, RobotType, load_map_file
from .core.errors import RoleEngineError
from .core.formations import circle_formation, diamond_formation, line_formation, square_formation
from .core.gp_planner import GPPlanner, GPPlannerConfig, GPPlanResult
from .core.negotiation import Agent, NegotiationResult, Role, negotiate_roles
from .core.qualification import ProcessRoleEvaluation, QualificationResult, qualification_matrix

Log = Callable[[str], None]

CONFIG_FILE = Path('roles') / 'experiments.yaml'
INITIALISATIONS = ('emap', 'straight')
ASSOCIATIONS = ('gra', 'nn')
#: Formations a problem's destinations are drawn from (the shapes of core/formations.py with a size).
PLACEMENT_FORMATIONS = ('circle', 'square', 'diamond', 'line')
INIT_LABEL = {'emap': 'Our method (E-Map initialisation)', 'straight': 'GPMP (straight-line initialisation)'}
ASSOCIATION_LABEL = {'gra': 'GRA (Hungarian on Q)', 'nn': 'NN (nearest destination)'}
#: The paper's rows, printed under the tables for comparison.
PAPER_TABLE3 = {'emap': (1.0, 0.00052, 3.31), 'straight': (0.5714, 0.01346, 7.49)}
PAPER_TABLE4 = {'gra': (1.0, 0.000869, 3.11), 'nn': (1.0, 0.001749, 3.53)}
#: GPPlannerConfig fields the experiments set themselves.
GP_FIELDS_SET_HERE = {'sigma_obs': 'comes from the top-level sigma_obs list',
                      'robot_radius': 'is 0: plans run on each robot type\'s inflated SDF'}


# ---------------------------------------------------------------------------------------- configuration
@dataclass(frozen=True)
class Placement:
    """How the sources and destinations of a problem are drawn (see experiments.yaml)."""

    source_spread: float
    min_travel: float
    clearance: float
    spacing: float
    formations: tuple[str, ...]
    formation_size: tuple[float, float]
    max_attempts: int


@dataclass(frozen=True)
class RobotGroup:
    name: str
    count: int
    radius: float


@dataclass(frozen=True)
class TableSettings:
    """One table's problems. Table III: ``robots`` of ``robot_radii[p % len]``; Table IV: ``robot_groups``."""

    seed: int
    problems_per_environment: int
    placement: Placement
    robots: int = 0
    robot_radii: tuple[float, ...] = ()
    robot_groups: tuple[RobotGroup, ...] = ()


@dataclass(frozen=True)
class BenchmarkProblem:
    map: str
    start: tuple[float, float]
    goal: tuple[float, float]
    init: str


@dataclass(frozen=True)
class BenchmarkSettings:
    sigma_obs: float
    repeats: int
    problems: tuple[BenchmarkProblem, ...]
    robot_radius: float
    gra_sizes: tuple[int, ...]
    gra_repeats: int
    gra_inf_fraction: float


@dataclass(frozen=True)
class ExperimentConfig:
    """``config/roles/experiments.yaml``, validated."""

    path: Path
    maps_dir: Path
    environments: tuple[str, ...]
    sigma_obs: tuple[float, ...]
    plot_sigma: float
    total_time: float
    states: int
    gp: dict
    qualification_lambda: float
    samples_per_interval: int
    table3: TableSettings
    table4: TableSettings
    benchmark: BenchmarkSettings

    def gp_config(self, sigma_obs: float) -> GPPlannerConfig:
        return GPPlannerConfig.from_mapping({**self.gp, 'sigma_obs': sigma_obs}, 'gp')

    def map_file(self, name: str) -> Path:
        return self.maps_dir / f'{name}.yaml'

    def summary(self) -> dict:
        return {'file': str(self.path), 'environments': list(self.environments), 'sigma_obs': list(self.sigma_obs),
                'total_time_s': self.total_time, 'states': self.states, 'gp': dict(self.gp),
                'qualification_lambda': self.qualification_lambda}


def _positive_list(value: Any, path: str, *, ge: float | None = None, gt: float | None = None) -> tuple[float, ...]:
    items = require_list(value, path)
    if not items:
        raise fail(path, 'must list at least one number')
    return tuple(check_number(item, join_path(path, i), ge=ge, gt=gt) for i, item in enumerate(items))


def _parse_placement(data: Any, path: str) -> Placement:
    fields = Fields(data, path, allowed=('source_spread', 'min_travel', 'clearance', 'spacing', 'formations',
                                         'formation_size', 'max_attempts'))
    formations = require_list(fields.raw('formations'), fields.path_of('formations'))
    if not formations:
        raise fail(fields.path_of('formations'), f"must list at least one of {', '.join(PLACEMENT_FORMATIONS)}")
    for index, kind in enumerate(formations):
        if kind not in PLACEMENT_FORMATIONS:
            raise fail(join_path(fields.path_of('formations'), index),
                       f"unknown formation {kind!r} (allowed: {', '.join(PLACEMENT_FORMATIONS)})")
    size = fields.vector('formation_size', 2, gt=0.0)
    if size[0] > size[1]:
        raise fail(fields.path_of('formation_size'), f'must be [min, max] with min <= max (got {list(size)})')
    return Placement(source_spread=fields.number('source_spread', gt=0.0),
                     min_travel=fields.number('min_travel', ge=0.0),
                     clearance=fields.number('clearance', ge=0.0),
                     spacing=fields.number('spacing', ge=0.0),
                     formations=tuple(formations), formation_size=size,
                     max_attempts=fields.integer('max_attempts', ge=1))


def _parse_table(data: Any, path: str, kind: str) -> TableSettings:
    team_keys = ('robots', 'robot_radii') if kind == 'table3' else ('robot_groups',)
    fields = Fields(data, path, allowed=('seed', 'problems_per_environment', 'placement', *team_keys))
    common = dict(seed=fields.integer('seed', ge=0), problems_per_environment=fields.integer(
        'problems_per_environment', ge=1), placement=_parse_placement(fields.raw('placement'),
                                                                       fields.path_of('placement')))
    if kind == 'table3':
        return TableSettings(**common, robots=fields.integer('robots', ge=1),
                             robot_radii=_positive_list(fields.raw('robot_radii'), fields.path_of('robot_radii'),
                                                        ge=0.0))
    groups = []
    items = require_list(fields.raw('robot_groups'), fields.path_of('robot_groups'))
    if not items:
        raise fail(fields.path_of('robot_groups'), 'must list at least one group {name, count, radius}')
    for index, item in enumerate(items):
        group = Fields(item, join_path(fields.path_of('robot_groups'), index), allowed=('name', 'count', 'radius'))
        groups.append(RobotGroup(group.name('name'), group.integer('count', ge=1), group.number('radius', ge=0.0)))
    names = [g.name for g in groups]
    if len(set(names)) != len(names):
        raise fail(fields.path_of('robot_groups'), f'group names must be unique (got {names})')
    return TableSettings(**common, robot_groups=tuple(groups))


def _parse_benchmark(data: Any, path: str, environments_known: Callable[[str], bool]) -> BenchmarkSettings:
    fields = Fields(data, path, allowed=('sigma_obs', 'repeats', 'problems', 'robot_radius', 'gra_sizes',
                                         'gra_repeats', 'gra_inf_fraction'))
    problems = []
    items = require_list(fields.raw('problems'), fields.path_of('problems'))
    if not items:
        raise fail(fields.path_of('problems'), 'must list at least one problem {map, start, goal, init}')
    for index, item in enumerate(items):
        problem = Fields(item, join_path(fields.path_of('problems'), index), allowed=('map', 'start', 'goal', 'init'))
        name = problem.string('map')
        if not environments_known(name):
            raise fail(problem.path_of('map'), f"no map file {name}.yaml in the maps directory")
        init = problem.string('init')
        if init not in INITIALISATIONS:
            raise fail(problem.path_of('init'), f"must be one of {', '.join(INITIALISATIONS)} (got {init!r})")
        problems.append(BenchmarkProblem(name, problem.vector('start', 2), problem.vector('goal', 2), init))
    sizes = require_list(fields.raw('gra_sizes'), fields.path_of('gra_sizes'))
    if not sizes:
        raise fail(fields.path_of('gra_sizes'), 'must list at least one size n >= 1')
    return BenchmarkSettings(
        sigma_obs=fields.number('sigma_obs', gt=0.0), repeats=fields.integer('repeats', ge=1),
        problems=tuple(problems), robot_radius=fields.number('robot_radius', ge=0.0),
        gra_sizes=tuple(check_int(n, join_path(fields.path_of('gra_sizes'), i), ge=1) for i, n in enumerate(sizes)),
        gra_repeats=fields.integer('gra_repeats', ge=1),
        gra_inf_fraction=fields.number('gra_inf_fraction', ge=0.0, lt=1.0))


def load_experiment_config(path: str | Path) -> ExperimentConfig:
    """Read and validate the experiments file (format in config/roles/experiments.yaml)."""
    path = Path(path)
    where = str(path)
    data = read_yaml_file(path, 'experiments file')
    fields = Fields(data, where, allowed=('maps_dir', 'environments', 'sigma_obs', 'plot_sigma', 'trajectory', 'gp',
                                          'qualification', 'table3', 'table4', 'benchmark'))
    maps_dir = (path.parent / fields.string('maps_dir')).resolve()
    if not maps_dir.is_dir():
        raise fail(fields.path_of('maps_dir'), f"directory '{maps_dir}' does not exist")
    environments = require_list(fields.raw('environments'), fields.path_of('environments'))
    if not environments:
        raise fail(fields.path_of('environments'), 'must list at least one map name')
    for index, name in enumerate(environments):
        if not isinstance(name, str) or not (maps_dir / f'{name}.yaml').is_file():
            raise fail(join_path(fields.path_of('environments'), index),
                       f"no map file {name}.yaml in '{maps_dir}'")
    sigmas = _positive_list(fields.raw('sigma_obs'), fields.path_of('sigma_obs'), gt=0.0)
    plot_sigma = fields.number('plot_sigma', gt=0.0)
    if not any(math.isclose(plot_sigma, s) for s in sigmas):
        raise fail(fields.path_of('plot_sigma'), f'must be one of sigma_obs {list(sigmas)} (got {plot_sigma})')
    trajectory = Fields(fields.raw('trajectory'), fields.path_of('trajectory'), allowed=('total_time', 'states'))
    gp_data = fields.raw('gp')
    for key, why in GP_FIELDS_SET_HERE.items():
        if isinstance(gp_data, dict) and key in gp_data:
            raise fail(join_path(fields.path_of('gp'), key), f'not settable here: it {why}')
    gp = dict(Fields(gp_data, fields.path_of('gp'),
                     allowed=[f for f in GPPlannerConfig.__dataclass_fields__ if f not in GP_FIELDS_SET_HERE]).data)
    GPPlannerConfig.from_mapping({**gp, 'sigma_obs': sigmas[0]}, fields.path_of('gp'))   # validates every field
    qualification = Fields(fields.raw('qualification'), fields.path_of('qualification'),
                           allowed=('lambda', 'samples_per_interval'))
    return ExperimentConfig(
        path=path.resolve(), maps_dir=maps_dir, environments=tuple(environments), sigma_obs=sigmas,
        plot_sigma=plot_sigma, total_time=trajectory.number('total_time', gt=0.0),
        states=trajectory.integer('states', ge=2), gp=gp,
        qualification_lambda=qualification.number('lambda', ge=0.0),
        samples_per_interval=qualification.integer('samples_per_interval', ge=1),
        table3=_parse_table(fields.raw('table3'), fields.path_of('table3'), 'table3'),
        table4=_parse_table(fields.raw('table4'), fields.path_of('table4'), 'table4'),
        benchmark=_parse_benchmark(fields.raw('benchmark'), fields.path_of('benchmark'),
                                   lambda name: (maps_dir / f'{name}.yaml').is_file()))


def _config_with_overrides(config_dir: Path, environments, sigma_obs, problems_per_environment) -> ExperimentConfig:
    config = load_experiment_config(Path(config_dir) / CONFIG_FILE)
    if environments is not None:
        unknown = [e for e in environments if e not in config.environments]
        if not environments or unknown:
            raise RoleEngineError(f"environments: must be a non-empty subset of {', '.join(config.environments)} "
                                  f"(got {list(environments)})")
        config = replace(config, environments=tuple(environments))
    if sigma_obs is not None:
        values = tuple(float(s) for s in sigma_obs)
        if not values or any(not math.isfinite(s) or s <= 0 for s in values):
            raise RoleEngineError(f'sigma_obs: must be one or more numbers > 0 (got {list(sigma_obs)})')
        plot = config.plot_sigma if any(math.isclose(config.plot_sigma, s) for s in values) else values[0]
        config = replace(config, sigma_obs=values, plot_sigma=plot)
    if problems_per_environment is not None:
        if isinstance(problems_per_environment, bool) or not isinstance(problems_per_environment, int) \
                or problems_per_environment < 1:
            raise RoleEngineError(f'problems_per_environment: must be an integer >= 1 (got {problems_per_environment!r})')
        config = replace(config, table3=replace(config.table3, problems_per_environment=problems_per_environment),
                         table4=replace(config.table4, problems_per_environment=problems_per_environment))
    return config


# ---------------------------------------------------------------------------------------- problems
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
                'sources': _round(self.sources), 'destinations': _round(self.destinations)}


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


# ---------------------------------------------------------------------------------------- GP evaluation
class GPProcessRoleEvaluator:
    """Evaluator of :func:`~.core.qualification.qualification_matrix` that optimises by GP inference.

    Algorithm 3 lines 7-19: the process role of an agent for a role is the GP planner's solution
    from the pair's initial path, on the agent type's configuration-space SDF; F_gp (Eq. 14) is
    its GP prior cost. Every plan is kept in ``plans[(agent name, role name)]``.
    """

    def __init__(self, config: GPPlannerConfig, total_time: float):
        self.config = config
        self.total_time = float(total_time)
        self.plans: dict[tuple[str, str], GPPlanResult] = {}
        self.seconds: dict[tuple[str, str], float] = {}
        self._planners: dict[str, GPPlanner] = {}

    def __call__(self, agent: Agent, role: Role, initial: np.ndarray,
                 robot_env: RobotEnvironment) -> ProcessRoleEvaluation:
        name = robot_env.robot_type.name
        if name not in self._planners:
            self._planners[name] = GPPlanner(self.config, robot_env.sdf)
        began = time.perf_counter()
        result = self._planners[name].plan(initial, self.total_time)
        self.seconds[(agent.name, role.name)] = time.perf_counter() - began
        self.plans[(agent.name, role.name)] = result
        return ProcessRoleEvaluation(result.trajectory, result.term_costs['gp_prior'], result.iterations)


@dataclass
class Evaluated:
    """One problem at one sigma_obs: every pair's plan and the qualification matrix."""

    negotiation: NegotiationResult
    qualification: QualificationResult | None
    evaluator: GPProcessRoleEvaluator
    seconds: float

    def plan(self, agent: int, role: int) -> GPPlanResult:
        return self.evaluator.plans[(self.negotiation.agents[agent].name, self.negotiation.roles[role].name)]


def evaluate_problem(negotiation: NegotiationResult, config: ExperimentConfig, sigma_obs: float) -> Evaluated:
    """GP inference for every reachable agent-role pair and Q (Eq. 13); None Q when negotiation failed."""
    evaluator = GPProcessRoleEvaluator(config.gp_config(sigma_obs), config.total_time)
    began = time.perf_counter()
    qualification = None
    if negotiation.feasible:
        # F_conf (Eq. 15) uses the planner's own hinge (Eq. 21): the same safety distance epsilon.
        qualification = qualification_matrix(negotiation, evaluate=evaluator, lam=config.qualification_lambda,
                                              epsilon=evaluator.config.epsilon,
                                              samples_per_interval=config.samples_per_interval)
    return Evaluated(negotiation, qualification, evaluator, time.perf_counter() - began)


def assigned_measures(evaluated: Evaluated, assignment: AssignmentResult | None) -> dict:
    """Per assigned process role: feasible, error (Eq. 11), iterations, clearance, q (Eq. 13)."""
    agents = len(evaluated.negotiation.agents)
    roles = len(evaluated.negotiation.roles)
    if assignment is None or not assignment.feasible:
        if not evaluated.negotiation.feasible:
            reason = 'negotiation infeasible: ' + '; '.join(evaluated.negotiation.reasons)
        else:
            reason = assignment.reason if assignment is not None else 'no assignment'
        return {'assigned': False, 'reason': reason, 'pairs': [], 'feasible': [False] * min(agents, roles),
                'error': [], 'iterations': [], 'converged': [], 'min_clearance_m': [], 'q': [], 'total_cost': None}
    plans = [evaluated.plan(a, r) for a, r in assignment.pairs]
    q = evaluated.qualification.q
    return {
        'assigned': True, 'reason': '', 'pairs': [[int(a), int(r)] for a, r in assignment.pairs],
        'feasible': [bool(p.collision_free) for p in plans],
        'error': [float(p.cost) for p in plans],
        'iterations': [int(p.iterations) for p in plans],
        'converged': [bool(p.converged) for p in plans],
        'min_clearance_m': [float(p.min_clearance) for p in plans],
        'q': [float(q[a, r]) for a, r in assignment.pairs],
        'total_cost': float(assignment.total_cost),
    }


def all_pair_measures(evaluated: Evaluated) -> dict:
    """Every agent-role pair's plan (not only the assigned ones), for the per-problem detail."""
    plans = list(evaluated.evaluator.plans.values())
    if not plans:
        return {'pairs': 0}
    return {'pairs': len(plans), 'feasibility': sum(p.collision_free for p in plans) / len(plans),
            'error_mean': float(np.mean([p.cost for p in plans])),
            'iterations_mean': float(np.mean([p.iterations for p in plans])),
            'plan_seconds_total': float(sum(evaluated.evaluator.seconds.values()))}


class MeasureTotals:
    """Accumulates assigned process roles into the tables' numbers."""

    def __init__(self):
        self.feasible: list[bool] = []
        self.errors: list[float] = []
        self.feasible_iterations: list[int] = []
        self.costs: list[float] = []
        self.unassigned = 0

    def add(self, measures: dict) -> None:
        self.feasible.extend(measures['feasible'])
        self.errors.extend(measures['error'])
        self.feasible_iterations.extend(i for i, ok in zip(measures['iterations'], measures['feasible']) if ok)
        if measures['total_cost'] is not None:
            self.costs.append(measures['total_cost'])
        else:
            self.unassigned += 1

    def summary(self) -> dict:
        return {
            'feasibility': (sum(self.feasible) / len(self.feasible)) if self.feasible else None,
            'error': float(np.mean(self.errors)) if self.errors else None,
            'cost': float(np.mean(self.costs)) if self.costs else None,
            'iterations': float(np.mean(self.feasible_iterations)) if self.feasible_iterations else None,
            'process_roles': len(self.feasible), 'feasible_process_roles': int(sum(self.feasible)),
            'unassigned_problems': self.unassigned,
        }


class Tally:
    """:class:`MeasureTotals` of each method overall, per environment, per sigma_obs and per scenario."""

    def __init__(self, methods: tuple[str, ...], environments: tuple[str, ...], sigmas: tuple[float, ...]):
        self.methods = methods
        self.groups = {('all',): None, **{('environment', e): e for e in environments},
                       **{('sigma', _sigma_key(s)): s for s in sigmas},
                       **{('scenario', e, _sigma_key(s)): (e, s) for e in environments for s in sigmas}}
        self.totals = {group: {m: MeasureTotals() for m in methods} for group in self.groups}

    def add(self, environment: str, sigma: float, method: str, measures: dict) -> None:
        key = _sigma_key(sigma)
        for group in (('all',), ('environment', environment), ('sigma', key), ('scenario', environment, key)):
            self.totals[group][method].add(measures)

    def _summaries(self, group) -> dict:
        return {m: self.totals[group][m].summary() for m in self.methods}

    def report(self) -> dict:
        """The results.json sections: one summary per method, then the breakdowns."""
        return {
            **self._summaries(('all',)),
            'per_environment': {g[1]: self._summaries(g) for g in self.groups if g[0] == 'environment'},
            'per_sigma': {g[1]: self._summaries(g) for g in self.groups if g[0] == 'sigma'},
            'scenarios': [{'environment': e, 'sigma_obs': float(s), **self._summaries(g)}
                          for g, (e, s) in ((g, v) for g, v in self.groups.items() if g[0] == 'scenario')],
        }


def _round(array: np.ndarray, digits: int = 4) -> list:
    return np.round(np.asarray(array, dtype=float), digits).tolist()


def _finite_or_none(matrix: np.ndarray) -> list:
    return [[float(v) if math.isfinite(v) else None for v in row] for row in np.asarray(matrix, dtype=float)]


def _sigma_key(sigma: float) -> str:
    return f'{sigma:g}'


def _percent(value: float | None) -> str:
    return '-' if value is None else f'{100.0 * value:.2f}%'


def _number(value: float | None, digits: int = 5) -> str:
    return '-' if value is None else f'{value:.{digits}g}'


def _mean_or_none(values) -> float | None:
    values = list(values)
    return float(np.mean(values)) if values else None


def _run_text(name: str, measures: dict, second: str) -> str:
    """Progress text of one method: collision-free count and the table's second column."""
    feasible = measures['feasible']
    iterations = [i for i, ok in zip(measures['iterations'], feasible) if ok]
    value = _mean_or_none(measures['error']) if second == 'error' else measures['total_cost']
    return (f'{name} {sum(feasible)}/{len(feasible)} collision-free, {second} {_number(value, 4)}, '
            f'{_number(_mean_or_none(iterations), 3)} it')


def _start_run(config_dir, run_dir, environments, sigma_obs, problems_per_environment):
    config = _config_with_overrides(Path(config_dir), environments, sigma_obs, problems_per_environment)
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    return config, run_dir


def _finish_run(results: dict, run_dir: Path, table_name: str, acceptance, markdown, log: Log) -> dict:
    accepted, message = acceptance(results)
    results['acceptance'] = {'passed': accepted, 'message': message}
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2) + '\n')
    (run_dir / f'{table_name}.md').write_text(markdown(results))
    log(f"[{results['experiment']}] {message}; wall time {results['wall_time_s']:.0f} s")
    return results


# ---------------------------------------------------------------------------------------- Table III
def run_table3(config_dir: str | Path, run_dir: str | Path, log: Log = print, *, environments=None,
               sigma_obs=None, problems_per_environment=None) -> dict:
    """Table III: E-Map vs straight-line initialisation of GP inference (module docstring).

    ``config_dir`` is the workspace's ``config/`` (the file is ``roles/experiments.yaml``); the
    keyword arguments narrow the run (a subset of environments, other sigma_obs values, fewer
    problems) without editing the file.
    """
    config, run_dir = _start_run(config_dir, run_dir, environments, sigma_obs, problems_per_environment)
    settings = config.table3
    count = settings.problems_per_environment
    steps = len(config.environments) * count * len(config.sigma_obs)
    tally = Tally(INITIALISATIONS, config.environments, config.sigma_obs)
    problems, examples = [], {}
    started = time.perf_counter()
    step = 0
    for env_index, env_name in enumerate(config.environments):
        environment = load_map_file(config.map_file(env_name))
        example = env_index % count     # the plotted problem; varies the robot size between panels
        for p in range(count):
            problem = draw_problem(environment, env_index, p, settings)
            negotiations = {init: negotiate_roles(problem.agents, problem.roles, environment,
                                                  total_time=config.total_time, num_intervals=config.states - 1,
                                                  use_emap=(init == 'emap'))
                            for init in INITIALISATIONS}
            detail = {**problem.describe(), 'robot_radius': problem.agents[0].robot_type.radius, 'runs': {}}
            for sigma in config.sigma_obs:
                step += 1
                began = time.perf_counter()
                runs = detail['runs'].setdefault(_sigma_key(sigma), {})
                for init in INITIALISATIONS:
                    evaluated = evaluate_problem(negotiations[init], config, sigma)
                    assignment = (group_role_assignment(evaluated.qualification.q)
                                  if evaluated.qualification is not None else None)
                    measures = assigned_measures(evaluated, assignment)
                    tally.add(env_name, sigma, init, measures)
                    runs[init] = {**measures, 'all_pairs': all_pair_measures(evaluated),
                                  'Q': _finite_or_none(evaluated.qualification.q) if evaluated.qualification else None}
                    if p == example and math.isclose(sigma, config.plot_sigma):
                        examples[(env_name, init)] = (environment, problem, evaluated, assignment)
                log(f'[roles-table3 {step}/{steps}] {env_name} problem {p + 1}/{count} '
                    f'(r = {problem.agents[0].robot_type.radius:g} m, {problem.formation}) sigma_obs={sigma:g}: '
                    + '; '.join(_run_text(init, runs[init], 'error') for init in INITIALISATIONS)
                    + f' ({time.perf_counter() - began:.1f} s)')
            problems.append(detail)
    results = {
        'experiment': 'roles-table3', 'config': config.summary(), 'problems_per_environment': count,
        'robots': settings.robots, 'robot_radii': list(settings.robot_radii), 'seed': settings.seed,
        'definitions': {
            'feasibility': 'share of assigned process roles whose robot centre never enters the inflated '
                           'obstacles (support states and GP-interpolated instants)',
            'error': 'final value of the Eq. 11 objective (0.5 sum of squared whitened errors, = gtsam '
                     'graph.error) of the assigned process roles, averaged over all of them',
            'iterations': 'LM iterations of the assigned process roles, averaged over the feasible ones'},
        **tally.report(), 'problems': problems,
        'paper': {init: dict(zip(('feasibility', 'error', 'iterations'), PAPER_TABLE3[init])) for init in INITIALISATIONS},
        'wall_time_s': time.perf_counter() - started,
    }
    _plot_table3_examples(examples, config, run_dir / 'table3_examples.png')
    _plot_per_environment(results, INITIALISATIONS, INIT_LABEL, 'feasibility', 'feasibility (%)',
                          'Table III: feasibility per environment', run_dir / 'table3_feasibility.png', percent=True)
    return _finish_run(results, run_dir, 'table3', table3_acceptance, table3_markdown, log)


def table3_acceptance(results: dict) -> tuple[bool, str]:
    """E-Map initialisation 100 % feasible and better than the straight line (feasibility, then error)."""
    emap, straight = results['emap'], results['straight']
    full = emap['feasibility'] == 1.0
    beats = (emap['feasibility'] > straight['feasibility']
             or (emap['feasibility'] == straight['feasibility'] and emap['error'] < straight['error']))
    message = (f"E-Map feasibility {_percent(emap['feasibility'])} vs straight line "
               f"{_percent(straight['feasibility'])}, error {_number(emap['error'])} vs "
               f"{_number(straight['error'])}")
    return full and beats, message + ('' if full and beats else ' (acceptance NOT met: E-Map must be 100 % '
                                                                'feasible and beat the straight line)')


def _breakdown_markdown(results: dict, methods: tuple[str, ...], short: dict[str, str],
                        second: str) -> list[str]:
    """Per-environment and per-sigma_obs tables: feasibility, ``second`` and iterations per method."""
    columns = [f'{short[m]} {name}' for m in methods for name in ('feasibility', second, 'iterations')]
    lines = []
    for heading, first, breakdown in (('Per environment', 'environment', results['per_environment']),
                                      ('Per sigma_obs', 'sigma_obs', results['per_sigma'])):
        lines += ['', f'## {heading}', '', f"| {first} | {' | '.join(columns)} |",
                  '|' + '---|' * (len(columns) + 1)]
        for key, row in breakdown.items():
            lines.append(f'| {key} | ' + ' | '.join(
                f"{_percent(row[m]['feasibility'])} | {_number(row[m][second])} | {_number(row[m]['iterations'], 3)}"
                for m in methods) + ' |')
    return lines


def _closing_markdown(results: dict) -> list[str]:
    return (['', '## Definitions', ''] + [f'- **{k}**: {v}.' for k, v in results['definitions'].items()]
            + ['', f"Acceptance: {results['acceptance']['message']}.", ''])


def table3_markdown(results: dict) -> str:
    config = results['config']
    lines = ['# Table III: E-Map initialisation vs straight-line GPMP', '',
             f"{len(config['environments'])} environments x {len(config['sigma_obs'])} sigma_obs "
             f"({', '.join(f'{s:g}' for s in config['sigma_obs'])}) = "
             f"{len(config['environments']) * len(config['sigma_obs'])} scenarios, "
             f"{results['problems_per_environment']} problems of {results['robots']} robots each "
             f"({results['emap']['process_roles']} assigned process roles per method).", '',
             '| method | feasibility | average error | average converging time (iterations) |',
             '|---|---|---|---|']
    for init in INITIALISATIONS:
        r = results[init]
        lines.append(f"| {INIT_LABEL[init]} | {_percent(r['feasibility'])} | {_number(r['error'])} | "
                     f"{_number(r['iterations'], 3)} |")
    lines += ['', 'The paper: ' + '; '.join(
        f"{INIT_LABEL[i]} {_percent(v[0])}, {v[1]}, {v[2]}" for i, v in PAPER_TABLE3.items()) + '.']
    lines += _breakdown_markdown(results, INITIALISATIONS, {'emap': 'E-Map', 'straight': 'straight'}, 'error')
    return '\n'.join(lines + _closing_markdown(results))


# ---------------------------------------------------------------------------------------- Table IV
def run_table4(config_dir: str | Path, run_dir: str | Path, log: Log = print, *, environments=None,
               sigma_obs=None, problems_per_environment=None) -> dict:
    """Table IV: GRA vs nearest-neighbour association with small and large robots (module docstring)."""
    config, run_dir = _start_run(config_dir, run_dir, environments, sigma_obs, problems_per_environment)
    settings = config.table4
    count = settings.problems_per_environment
    steps = len(config.environments) * count * len(config.sigma_obs)
    tally = Tally(ASSOCIATIONS, config.environments, config.sigma_obs)
    problems, examples = [], {}
    comparisons = {'gra_lower': 0, 'equal': 0, 'gra_higher': 0, 'not_comparable': 0}
    started = time.perf_counter()
    step = 0
    for env_index, env_name in enumerate(config.environments):
        environment = load_map_file(config.map_file(env_name))
        example = env_index % count
        for p in range(count):
            problem = draw_problem(environment, env_index, p, settings)
            negotiation = negotiate_roles(problem.agents, problem.roles, environment, total_time=config.total_time,
                                          num_intervals=config.states - 1, use_emap=True)
            detail = {**problem.describe(), 'runs': {}}
            for sigma in config.sigma_obs:
                step += 1
                began = time.perf_counter()
                evaluated = evaluate_problem(negotiation, config, sigma)
                assignments: dict[str, AssignmentResult | None] = {'gra': None, 'nn': None}
                if evaluated.qualification is not None:
                    q = evaluated.qualification.q
                    assignments['gra'] = group_role_assignment(q)
                    assignments['nn'] = nearest_neighbour_assignment(problem.sources, problem.destinations, q)
                run = {'Q': _finite_or_none(evaluated.qualification.q) if evaluated.qualification else None,
                       'all_pairs': all_pair_measures(evaluated)}
                for method in ASSOCIATIONS:
                    run[method] = assigned_measures(evaluated, assignments[method])
                    tally.add(env_name, sigma, method, run[method])
                comparisons[_compare_costs(run['gra']['total_cost'], run['nn']['total_cost'])] += 1
                detail['runs'][_sigma_key(sigma)] = run
                if p == example and math.isclose(sigma, config.plot_sigma):
                    examples[env_name] = (environment, problem, evaluated, assignments)
                log(f'[roles-table4 {step}/{steps}] {env_name} problem {p + 1}/{count} ({problem.formation}) '
                    f'sigma_obs={sigma:g}: ' + '; '.join(_run_text(m, run[m], 'cost') for m in ASSOCIATIONS)
                    + f' ({time.perf_counter() - began:.1f} s)')
            problems.append(detail)
    results = {
        'experiment': 'roles-table4', 'config': config.summary(), 'problems_per_environment': count,
        'seed': settings.seed,
        'robot_groups': [{'name': g.name, 'count': g.count, 'radius': g.radius} for g in settings.robot_groups],
        'definitions': {
            'feasibility': 'share of assigned process roles whose robot centre never enters its type\'s '
                           'inflated obstacles (a problem that cannot be assigned counts as all failed)',
            'cost': 'total qualification sum Q[a, T(a)] of the assignment (Eq. 13, Q = lambda F_gp + F_conf), '
                    'averaged over problems',
            'iterations': 'LM iterations of the assigned process roles, averaged over the feasible ones',
            'nn': 'each destination goes to the closest free robot, closest pair first (straight-line distance)'},
        **tally.report(), 'cost_comparison': comparisons, 'problems': problems,
        'paper': {m: dict(zip(('feasibility', 'cost', 'iterations'), PAPER_TABLE4[m])) for m in ASSOCIATIONS},
        'wall_time_s': time.perf_counter() - started,
    }
    _plot_table4_examples(examples, config, run_dir / 'table4_assignments.png')
    _plot_per_environment(results, ASSOCIATIONS, ASSOCIATION_LABEL, 'cost', 'mean total cost (Eq. 13)',
                          'Table IV: assignment cost per environment', run_dir / 'table4_cost.png')
    return _finish_run(results, run_dir, 'table4', table4_acceptance, table4_markdown, log)


def _compare_costs(gra_cost: float | None, nn_cost: float | None) -> str:
    if gra_cost is None or nn_cost is None:
        return 'not_comparable'
    if math.isclose(gra_cost, nn_cost, rel_tol=1e-12, abs_tol=1e-15):
        return 'equal'
    return 'gra_lower' if gra_cost < nn_cost else 'gra_higher'


def table4_acceptance(results: dict) -> tuple[bool, str]:
    """GRA's mean total cost below NN's, and never above it on any problem."""
    gra, nn, comparisons = results['gra'], results['nn'], results['cost_comparison']
    passed = (gra['cost'] is not None and nn['cost'] is not None and gra['cost'] < nn['cost']
              and comparisons['gra_higher'] == 0)
    message = (f"GRA mean cost {_number(gra['cost'])} vs NN {_number(nn['cost'])} "
               f"(GRA lower on {comparisons['gra_lower']}, equal on {comparisons['equal']}, higher on "
               f"{comparisons['gra_higher']} problem runs); feasibility GRA {_percent(gra['feasibility'])}, "
               f"NN {_percent(nn['feasibility'])}")
    return passed, message + ('' if passed else ' (acceptance NOT met: GRA cost must be below NN)')


def table4_markdown(results: dict) -> str:
    config = results['config']
    team = ', '.join(f"{g['count']} {g['name']} (r = {g['radius']:g} m)" for g in results['robot_groups'])
    lines = ['# Table IV: GRA vs nearest-neighbour association (E-Map initialisation for both)', '',
             f"{team}; {len(config['environments'])} environments x {len(config['sigma_obs'])} sigma_obs = "
             f"{len(config['environments']) * len(config['sigma_obs'])} scenarios, "
             f"{results['problems_per_environment']} problems each.", '',
             '| method | feasibility | overall cost | converging time (iterations) |', '|---|---|---|---|']
    for method in ASSOCIATIONS:
        r = results[method]
        lines.append(f"| {ASSOCIATION_LABEL[method]} | {_percent(r['feasibility'])} | {_number(r['cost'])} | "
                     f"{_number(r['iterations'], 3)} |")
    c = results['cost_comparison']
    lines += ['', f"GRA's cost is lower than NN's on {c['gra_lower']} problem runs, equal on {c['equal']} "
                  f"(NN picked the optimal assignment), higher on {c['gra_higher']}.", '',
              'The paper: ' + '; '.join(f"{m.upper()} {_percent(v[0])}, {v[1]}, {v[2]}"
                                        for m, v in PAPER_TABLE4.items()) + '.']
    lines += _breakdown_markdown(results, ASSOCIATIONS, {'gra': 'GRA', 'nn': 'NN'}, 'cost')
    return '\n'.join(lines + _closing_markdown(results))


# ---------------------------------------------------------------------------------------- plots
def _suptitle(fig, text: str, columns: int) -> None:
    fig.suptitle(textwrap.fill(text, max(60, 45 * columns)), fontsize=9)


def _pyplot():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def _draw_map(ax, environment: Environment, views: list[RobotEnvironment]) -> None:
    """Obstacles black, the largest robot's inflation margin grey, free space white (y up)."""
    shade = np.ones(environment.shape)
    for view in views:
        shade = np.where(view.inflated, 0.75, shade)
    shade = np.where(environment.occupied, 0.0, shade)
    x0, y0, x1, y1 = environment.frame.bounds
    ax.imshow(shade, origin='lower', extent=(x0, x1, y0, y1), cmap='gray', vmin=0.0, vmax=1.0,
              interpolation='nearest')
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect('equal')
    ax.set_xticks([])
    ax.set_yticks([])


def _draw_team(ax, problem: Problem, evaluated: Evaluated, assignment: AssignmentResult | None) -> None:
    from matplotlib.patches import Circle
    colours = ['tab:red', 'tab:blue', 'tab:orange', 'tab:purple', 'tab:brown', 'tab:cyan', 'tab:pink', 'tab:olive']
    for agent in problem.agents:
        ax.add_patch(Circle(agent.position, max(agent.robot_type.radius, 0.03), facecolor='limegreen',
                            edgecolor='darkgreen', zorder=3))
    largest = max(a.robot_type.radius for a in problem.agents)
    for role in problem.roles:
        ax.add_patch(Circle(role.destination, max(largest, 0.03), facecolor='none', edgecolor='blue', lw=1.2, zorder=3))
    if assignment is None or not assignment.feasible:
        return
    for k, (a, r) in enumerate(assignment.pairs):
        plan = evaluated.plan(a, r)
        colour = colours[k % len(colours)]
        ax.plot(plan.trajectory[:, 0], plan.trajectory[:, 1], '-', color=colour, lw=1.2, zorder=4)
        if not plan.collision_free:
            view = evaluated.negotiation.robot_envs[problem.agents[a].robot_type.name]
            inside = view.sdf.distance(plan.trajectory[:, :2]) < 0.0
            ax.plot(plan.trajectory[inside, 0], plan.trajectory[inside, 1], 'x', color='red', ms=5, zorder=5)


def _plot_table3_examples(examples: dict, config: ExperimentConfig, path: Path) -> None:
    if not examples:
        return
    plt = _pyplot()
    envs = [e for e in config.environments if (e, 'emap') in examples]
    fig, axes = plt.subplots(2, len(envs), figsize=(max(3.0 * len(envs), 4.0), 7.0), squeeze=False)
    for column, env in enumerate(envs):
        for row, init in enumerate(INITIALISATIONS):
            environment, problem, evaluated, assignment = examples[(env, init)]
            ax = axes[row][column]
            _draw_map(ax, environment, list(evaluated.negotiation.robot_envs.values()))
            _draw_team(ax, problem, evaluated, assignment)
            feasible = sum(evaluated.plan(a, r).collision_free for a, r in assignment.pairs) if assignment else 0
            ax.set_title(f'{env} r={problem.agents[0].robot_type.radius:g}: {feasible}/{len(problem.roles)} free',
                         fontsize=8)
            if column == 0:
                ax.set_ylabel(INIT_LABEL[init].split(' (')[1].rstrip(')'), fontsize=9)
    _suptitle(fig, f'Process roles after GP inference, sigma_obs = {config.plot_sigma:g} (one problem per '
                   'environment; green: sources, blue: destinations, x: in collision)', len(envs))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_table4_examples(examples: dict, config: ExperimentConfig, path: Path) -> None:
    if not examples:
        return
    plt = _pyplot()
    envs = [e for e in config.environments if e in examples]
    fig, axes = plt.subplots(2, len(envs), figsize=(max(3.0 * len(envs), 4.0), 7.0), squeeze=False)
    for column, env in enumerate(envs):
        environment, problem, evaluated, assignments = examples[env]
        for row, method in enumerate(ASSOCIATIONS):
            ax = axes[row][column]
            _draw_map(ax, environment, list(evaluated.negotiation.robot_envs.values()))
            _draw_team(ax, problem, evaluated, assignments[method])
            cost = assignments[method].total_cost if assignments[method] else math.inf
            ax.set_title(f'{env}: cost {cost:.4g}', fontsize=8)
            if column == 0:
                ax.set_ylabel(method.upper(), fontsize=9)
    _suptitle(fig, f'GRA vs NN, sigma_obs = {config.plot_sigma:g} (one problem per environment; green discs: '
                   'robots at their sources, sized by radius; blue: destinations)', len(envs))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_per_environment(results: dict, methods, labels, measure: str, ylabel: str, title: str, path: Path,
                          percent: bool = False) -> None:
    plt = _pyplot()
    envs = list(results['per_environment'])
    fig, ax = plt.subplots(figsize=(1.4 * len(envs) + 2.5, 3.4))
    width = 0.8 / len(methods)
    for k, method in enumerate(methods):
        values = [results['per_environment'][e][method][measure] for e in envs]
        values = [(100.0 * v if percent else v) if v is not None else 0.0 for v in values]
        ax.bar(np.arange(len(envs)) + (k - (len(methods) - 1) / 2) * width, values, width, label=labels[method])
    ax.set_xticks(np.arange(len(envs)), envs)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(axis='y', alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
