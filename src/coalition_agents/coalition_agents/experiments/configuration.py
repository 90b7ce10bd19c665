"""The experiments' inputs: the coalition configuration directory and the Fig. 7 scenario file.

* :class:`CoalitionConfig` -- ``config/coalitions/`` (schema library, costs, tasks) loaded once;
* :func:`load_scenario` -- a scenario of robots with poses for the geometric sensing model
  (``config/coalitions/scenarios/fig7.yaml``: the team file, the task, the initiators, default
  fields of view per sensor, every robot's pose, the obstacles, the goals and the paper's Table V
  for the side-by-side comparison). Errors name the file and the field. The format is documented
  in ``config/coalitions/scenarios/fig7.yaml``; in short:

  - ``team``: the capability file; relative to the scenario file's directory, else (the shipped
    scenarios' convention) to ``config/coalitions/``; ``team_path`` (``--team``) replaces it.
    Each robot's geometric sensor takes its field of view from its type's sensor entry
    (``fov_deg``, ``range_m``); ``sensors`` gives defaults for types that give none.
  - ``obstacles``: the bridge's ``obstacles`` section (``boxes``, ``map``; the bridge's parser),
    relative paths from the scenario file; boxes taller than the simulated sensor (0.12 m) block
    lines of sight, a robot whose footprint overlaps an obstacle is refused.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

from collab_tools.core.fields import Fields, check_number, load_config_file, require_list

from ..core import (
    ConfigError, Costs, RobotCapabilities, SchemaLibrary, Task, load_capability_file, load_costs, load_library,
    load_tasks,
)
from ..core.geometric_sensing import FieldOfView, GeometricSensing, Pose
from ..core.sim_scenarios import ROBOT_RADIUS_M, Obstacles, check_footprints, parse_obstacles

#: Where a ``config_dir`` keeps the coalition files (``scripts/experiment`` passes the workspace's config/).
COALITIONS = 'coalitions'
FIG7_SCENARIO = 'scenarios/fig7.yaml'


@dataclass(frozen=True)
class CoalitionConfig:
    """The coalition configuration directory (config/coalitions/) loaded once."""

    directory: Path
    library: SchemaLibrary
    costs: Costs
    tasks: Mapping[str, Task]

    @classmethod
    def load(cls, config_dir: str | Path) -> 'CoalitionConfig':
        directory = Path(config_dir)
        library = load_library(directory / 'schemas.yaml')
        return cls(directory, library, load_costs(directory / 'costs.yaml'),
                   load_tasks(directory / 'tasks.yaml', library))

    def task(self, name: str, path: str = 'task') -> Task:
        if name not in self.tasks:
            raise ConfigError(f"{path}: unknown task {name!r} (tasks.yaml defines {', '.join(sorted(self.tasks))})")
        return self.tasks[name]


@dataclass(frozen=True)
class Scenario:
    """Robots with poses for the geometric sensing model (config/coalitions/scenarios/*.yaml)."""

    path: Path
    team: Mapping[str, RobotCapabilities]
    task: Task
    initiators: tuple[str, ...]
    sensors: Mapping[str, FieldOfView]
    poses: Mapping[str, Pose]
    goals: Mapping[str, tuple[float, float]]
    paper_table5: Mapping[str, dict]
    obstacles: Obstacles = Obstacles()
    team_file: Path | None = None

    def sensing(self, blind: bool = False) -> GeometricSensing:
        """The geometric sensing model of this scenario (per-robot views, obstacles and the other
        robots' bodies occlude, as in the bridge); ``blind``: configuration ignored."""
        return GeometricSensing(self.team, self.poses, self.sensors, self.obstacles.occluding, ROBOT_RADIUS_M,
                                blind=blind)

    def views(self) -> dict[str, dict[str, FieldOfView]]:
        """robot -> geometric sensor -> its field of view (own or the scenario's default)."""
        sensing = self.sensing()
        return {robot: {sensor: sensing.view_of(robot, sensor) for sensor in sorted(sensing.geometric_sensors)
                        if any(s.sensor == sensor for s in self.team[robot].sensors)} for robot in self.team}


def _point(value: object, path: str) -> tuple[float, float]:
    items = require_list(value, path, ConfigError)
    if len(items) != 2:
        raise ConfigError(f'{path}: must be [x, y] (got {len(items)} numbers)')
    x, y = (check_number(item, f'{path}[{i}]', error=ConfigError) for i, item in enumerate(items))
    return x, y


def _robot_name(value: object, path: str, team: Mapping[str, RobotCapabilities]) -> str:
    if value not in team:
        raise ConfigError(f'{path}: unknown robot {value!r} (team: {", ".join(team)})')
    return str(value)


def resolve_team(team: str, scenario_path: Path, config: CoalitionConfig) -> Path:
    """The scenario's ``team`` file: relative to the scenario's directory, else to config/coalitions/."""
    candidates = [Path(scenario_path).parent / team, config.directory / team]
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    raise ConfigError(f"team: no file {team!r} next to the scenario nor in {config.directory} "
                      f"(tried {', '.join(str(c) for c in candidates)})")


def scenario_from_dict(data: object, config: CoalitionConfig, path: Path,
                       team_path: str | Path | None = None) -> Scenario:
    section = Fields(data, '', ('team', 'task', 'initiators', 'sensors', 'robots', 'goals', 'paper_table5',
                                'obstacles'), error=ConfigError)
    if team_path is not None:
        team_file = Path(team_path)
        if not team_file.is_file():
            raise ConfigError(f'--team: no file {str(team_path)!r}')
    else:
        team_file = resolve_team(section.string('team'), path, config)
    team = load_capability_file(team_file, config.library).robots
    if not team:
        raise ConfigError(f'team: {team_file} names no robots (its robots: mapping is empty)')
    task = config.task(section.name('task'))
    initiators = tuple(_robot_name(v, p, team) for p, v in section.items('initiators'))
    if not initiators:
        raise ConfigError('initiators: name at least one robot of the team')
    sensors = {}
    known_sensors = {s.sensor for capabilities in team.values() for s in capabilities.sensors}
    for entry_path, sensor, value in section.entries('sensors', []):
        if sensor not in known_sensors:
            raise ConfigError(f'{entry_path}: no robot of the team has a sensor {sensor!r} '
                              f'(sensors: {", ".join(sorted(known_sensors))})')
        entry = Fields(value, entry_path, ('fov_deg', 'range_m'), error=ConfigError)
        fov = entry.number('fov_deg', gt=0.0)
        if fov > 360.0:
            raise ConfigError(f"{entry.path_of('fov_deg')}: must be in (0, 360] (got {fov})")
        sensors[sensor] = FieldOfView(fov, entry.number('range_m', gt=0.0))
    obstacles = parse_obstacles(section.raw('obstacles', None), Path(path).parent, section.path_of('obstacles'))
    poses = {}
    for entry_path, robot, value in section.entries('robots'):
        _robot_name(robot, entry_path, team)
        entry = Fields(value, entry_path, ('position', 'heading_deg', 'label'), error=ConfigError)
        x, y = _point(entry.raw('position'), entry.path_of('position'))
        poses[robot] = Pose(x, y, entry.number('heading_deg'), entry.string('label', robot, allow_empty=True))
    missing = [robot for robot in team if robot not in poses]
    if missing:
        raise ConfigError(f'robots: no pose for {", ".join(missing)} (every robot of {team_file} needs one)')
    check_footprints({robot: (pose.x, pose.y) for robot, pose in poses.items()}, obstacles)
    goals = {_robot_name(robot, p, team): _point(v, p) for p, robot, v in section.entries('goals', [])}
    paper = {}
    for entry_path, robot, value in section.entries('paper_table5', []):
        _robot_name(robot, entry_path, team)
        entry = Fields(value, entry_path, ('possible', 'executable_costs'), error=ConfigError)
        possible = entry.number('possible', ge=0.0)
        if possible != int(possible):
            raise ConfigError(f"{entry.path_of('possible')}: must be a whole number (got {possible})")
        paper[robot] = {'possible': int(possible),
                        'executable_costs': [check_number(v, p, error=ConfigError)
                                             for p, v in entry.items('executable_costs')]}
    return Scenario(path, team, task, initiators, sensors, poses, goals, paper, obstacles, team_file)


def load_scenario(path: str | Path, config: CoalitionConfig, team_path: str | Path | None = None) -> Scenario:
    """Read and validate a scenario (``team_path`` replaces its ``team``); errors name the file and
    the field."""
    path = Path(path)
    scenario = load_config_file(path, lambda data: scenario_from_dict(data, config, path, team_path),
                                error=ConfigError)
    try:
        scenario.sensing()  # every geometric sensor has a field of view
    except ConfigError as exc:
        raise ConfigError(f'{path}: {exc}') from None
    return scenario


__all__ = ['COALITIONS', 'CoalitionConfig', 'FIG7_SCENARIO', 'Scenario', 'load_scenario', 'resolve_team',
           'scenario_from_dict']
