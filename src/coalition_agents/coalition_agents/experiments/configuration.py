"""The experiments' inputs: the coalition configuration directory and the Fig. 7 scenario file.

* :class:`CoalitionConfig` -- ``config/coalitions/`` (schema library, costs, tasks) loaded once;
* :func:`load_scenario` -- a scenario of robots with poses for the geometric sensing model
  (``config/coalitions/scenarios/fig7.yaml``: the team file, the task, the initiators, each
  geometric sensor's field of view and range, every robot's pose, the goals and the paper's
  Table V for the side-by-side comparison). Errors name the file and the field.
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


def scenario_from_dict(data: object, config: CoalitionConfig, path: Path) -> Scenario:
    section = Fields(data, '', ('team', 'task', 'initiators', 'sensors', 'robots', 'goals', 'paper_table5'),
                     error=ConfigError)
    team_file = section.string('team')
    team = load_capability_file(config.directory / team_file, config.library).robots
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
    poses = {}
    for entry_path, robot, value in section.entries('robots'):
        _robot_name(robot, entry_path, team)
        entry = Fields(value, entry_path, ('position', 'heading_deg', 'label'), error=ConfigError)
        x, y = _point(entry.raw('position'), entry.path_of('position'))
        poses[robot] = Pose(x, y, entry.number('heading_deg'), entry.string('label', robot, allow_empty=True))
    missing = [robot for robot in team if robot not in poses]
    if missing:
        raise ConfigError(f'robots: no pose for {", ".join(missing)} (every robot of {team_file} needs one)')
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
    return Scenario(path, team, task, initiators, sensors, poses, goals, paper)


def load_scenario(path: str | Path, config: CoalitionConfig) -> Scenario:
    """Read and validate a scenario; errors name the file and the field."""
    path = Path(path)
    scenario = load_config_file(path, lambda data: scenario_from_dict(data, config, path), error=ConfigError)
    GeometricSensing(scenario.team, scenario.poses, scenario.sensors)  # every geometric sensor has a FOV
    return scenario


__all__ = ['COALITIONS', 'CoalitionConfig', 'FIG7_SCENARIO', 'Scenario', 'load_scenario', 'scenario_from_dict']
