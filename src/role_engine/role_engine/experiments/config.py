"""The settings of Tables III and IV (and of the GPMP benchmark): ``config/roles/experiments.yaml``, validated.

Command-line inputs of ``roles-table3`` / ``roles-table4`` (:func:`request_config`):
``--config FILE`` (another experiments file), ``--maps YAML [YAML ...]`` (Nav2 map YAMLs that
replace the file's environments, each named by its stem), or ``--map-image PNG --resolution R
[--origin X Y [YAW]]`` (one image; a Nav2 YAML for it is written into the run directory), then
``--only NAME ...`` narrows the environments.

The file is documented where it lives; every error names the offending field (RoleEngineError).
:func:`table_config` is what the table experiments start from: the file, narrowed by the
run's options (``only``: a subset of environments; ``sigma_obs`` and ``problems_per_environment``,
used by the tests to run a small table).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any, Callable

from collab_tools.core import fields as shared_fields
from collab_tools.core.fields import join_path

from ..core.errors import RoleEngineError
from ..core.gp_planner import GPPlannerConfig

# The shared field readers, raising RoleEngineError.
Fields = partial(shared_fields.Fields, error=RoleEngineError)
fail = partial(shared_fields.fail, error=RoleEngineError)
require_list = partial(shared_fields.require_list, error=RoleEngineError)
check_number = partial(shared_fields.check_number, error=RoleEngineError)
check_int = partial(shared_fields.check_int, error=RoleEngineError)
read_yaml_file = partial(shared_fields.read_yaml_file, error=RoleEngineError)

CONFIG_FILE = Path('roles') / 'experiments.yaml'
INITIALISATIONS = ('emap', 'straight')
#: Formations a problem's destinations are drawn from (the shapes of core/formations.py with a size).
PLACEMENT_FORMATIONS = ('circle', 'square', 'diamond', 'line')
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
    #: Environments given as map files (name -> Nav2 map YAML) instead of ``maps_dir/<name>.yaml``.
    map_files: tuple[tuple[str, Path], ...] = ()

    def gp_config(self, sigma_obs: float) -> GPPlannerConfig:
        return GPPlannerConfig.from_mapping({**self.gp, 'sigma_obs': sigma_obs}, 'gp')

    def map_file(self, name: str) -> Path:
        return dict(self.map_files).get(name, self.maps_dir / f'{name}.yaml')

    def summary(self) -> dict:
        return {'file': str(self.path), 'environments': list(self.environments),
                'map_files': {name: str(self.map_file(name)) for name in self.environments},
                'sigma_obs': list(self.sigma_obs),
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


def table_config(config_dir: str | Path, environments=None, sigma_obs=None,
                 problems_per_environment=None, *, config_file: str | Path | None = None, maps=None,
                 map_image: str | Path | None = None, resolution: float | None = None, origin=None,
                 run_dir: str | Path | None = None) -> ExperimentConfig:
    """The experiments file (``config_file``, default ``config_dir/roles/experiments.yaml``), its
    environments replaced by ``maps`` (Nav2 map YAMLs; each named by its file stem) or by one
    ``map_image`` with its ``resolution`` and ``origin`` [x, y(, yaw)] (a Nav2 YAML for it is written to
    ``run_dir``), then narrowed to a subset of environments (``environments``: the names), other
    sigma_obs values or fewer problems. Every map is read here: RoleEngineError naming the option or
    the file's field before anything runs."""
    if config_file is not None and not Path(config_file).is_file():
        raise RoleEngineError(f"--config: file '{config_file}' does not exist")
    config = load_experiment_config(Path(config_file) if config_file is not None else Path(config_dir) / CONFIG_FILE)
    if maps is not None and map_image is not None:
        raise RoleEngineError('--maps, --map-image: give one of them (a map list or one map image)')
    if map_image is not None:
        maps = [image_map_yaml(map_image, resolution, origin, run_dir)]
    elif resolution is not None or origin is not None:
        raise RoleEngineError('--resolution, --origin: only with --map-image')
    if maps is not None:
        config = replace(config, **_map_list(maps))
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


def _map_list(maps) -> dict:
    """environments and map_files of a list of map YAMLs (each read and validated now)."""
    from ..core.environment import load_map_file

    paths = [Path(m).expanduser().resolve() for m in (maps or [])]
    if not paths:
        raise RoleEngineError('--maps: give at least one map YAML')
    names = [p.stem for p in paths]
    for given, path in zip(maps, paths):
        if not path.is_file():
            raise RoleEngineError(f"--maps: file '{given}' does not exist")
        if names.count(path.stem) > 1:
            raise RoleEngineError(f'--maps: two maps are named {path.stem!r} (the file stem names an environment)')
        load_map_file(path)
    return {'environments': tuple(names), 'map_files': tuple(zip(names, paths))}


def image_map_yaml(image: str | Path, resolution, origin, run_dir) -> Path:
    """A Nav2 map YAML for one occupancy image (white free, black occupied, Nav2's thresholds), written
    into ``run_dir``; ``origin`` [x, y] or [x, y, yaw] of the image's bottom-left corner, default [0, 0, 0]."""
    import yaml

    image_path = Path(image).expanduser().resolve()
    if not image_path.is_file():
        raise RoleEngineError(f"--map-image: file '{image}' does not exist")
    if resolution is None:
        raise RoleEngineError('--resolution: required with --map-image (m per pixel, > 0)')
    resolution = check_number(resolution, '--resolution', gt=0.0)
    origin = [0.0, 0.0] if origin is None else list(origin)
    if len(origin) not in (2, 3):
        raise RoleEngineError(f'--origin: must be x y or x y yaw (got {origin})')
    origin = [check_number(v, f'--origin[{i}]') for i, v in enumerate(origin)] + [0.0] * (3 - len(origin))
    if run_dir is None:
        raise RoleEngineError('--map-image: needs a run directory to write its map YAML into')
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir / f'{image_path.stem}.yaml'
    path.write_text(yaml.safe_dump({'image': str(image_path), 'resolution': resolution, 'origin': origin,
                                    'negate': 0, 'occupied_thresh': 0.65, 'free_thresh': 0.25, 'mode': 'trinary'},
                                   sort_keys=False))
    return path


def request_config(request) -> ExperimentConfig:
    """The table experiments' configuration from a request's options (roles-table3 and roles-table4)."""
    return table_config(request.config_dir, request.option('only'), request.option('sigma_obs'),
                        request.option('problems_per_environment'), config_file=request.option('config'),
                        maps=request.option('maps'), map_image=request.option('map_image'),
                        resolution=request.option('resolution'), origin=request.option('origin'),
                        run_dir=request.run_dir)
