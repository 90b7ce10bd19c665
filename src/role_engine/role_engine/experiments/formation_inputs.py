"""The inputs of ``roles-formation``: a settings/team file and a map from the command line, validated
before anything runs, and the run files generated from them.

``scripts/experiment roles-formation [--settings FILE] [--map NAV2_YAML] [--stop-player ROBOT]``:

- ``--settings``: the role nodes' settings file (format: :mod:`role_engine.core.formation_task`;
  default ``config/roles/formation_demo.yaml``). Its ``scenario`` key names the bridge scenario,
  whose ``mobile_robots`` are the team: one role player runs per robot, and each robot's
  ``cmd_vel`` is recorded.
- ``--map``: a Nav2 map YAML (format: :mod:`role_engine.core.environment`). The simulated world's
  static obstacles become that map's occupied (and unknown) cells: the scenario's ``obstacles``
  section is replaced by ``obstacles: {map: <yaml>}`` (the bridge reads the same file). The role
  engine still sees the world through the top-view camera, as in every run.

With either option the run uses generated copies in the run directory (``scenario.yaml`` when a map
is given, ``settings.yaml``, ``experiment.yaml``: the experiment of ``config/experiments/
roles_formation.yaml`` with one role player per robot of the team). Everything is loaded and
validated first: a bad file is refused (a ConfigurationError naming the file and field) before a
node starts. The clearance is measured against the obstacles of the scenario the run used
(:func:`obstacle_boxes`: its boxes, its map's boxes and the arena walls).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from collab_tools.core.fields import read_yaml_file

from ..core.errors import RoleEngineError
from ..core.formation_task import FormationTask, TeamMember, load_formation_task, team_from_scenario
from .path_measures import ObstacleBox

EXPERIMENT_FILE = 'experiments/roles_formation.yaml'
DEFAULT_SETTINGS = 'roles/formation_demo.yaml'


@dataclass
class FormationInputs:
    """What one run needs, validated: the settings, the team, the scenario the bridge loads, the
    obstacles it builds, and the experiment description (a plain mapping, ready to be dumped)."""

    task: FormationTask
    team: list[TeamMember]
    scenario_file: Path
    obstacles: list[ObstacleBox]
    experiment: dict
    generated: bool

    @property
    def radii(self) -> dict[str, float]:
        return {m.name: m.robot_type.radius for m in self.team}


def obstacle_boxes(scenario) -> list[ObstacleBox]:
    """The static obstacles of a loaded bridge scenario as boxes: ``obstacles`` (boxes and map cells)
    and the four arena walls when ``world.walls`` asks for them."""
    from pybullet_bridge.core.obstacles import WallSet

    boxes = [ObstacleBox(box.name, tuple(box.center), tuple(box.size), float(box.yaw))
             for box in scenario.sections.get('obstacles', [])]
    if scenario.world.walls is not None:
        for index, (center, size) in enumerate(WallSet.around(scenario.world).wall_boxes()):
            boxes.append(ObstacleBox(f'wall_{index}', tuple(center), tuple(size), 0.0))
    return boxes


def _existing(value: str | Path | None, option: str) -> Path | None:
    if value is None:
        return None
    path = Path(value).expanduser().resolve()
    if not path.is_file():
        raise RoleEngineError(f"{option}: file '{value}' does not exist")
    return path


def formation_inputs(config_dir: Path, run_dir: Path, *, settings: str | Path | None = None,
                     map_yaml: str | Path | None = None) -> FormationInputs:
    """Load and validate the run's inputs (module docstring); writes the generated files into
    ``run_dir`` only when an option asks for them. RoleEngineError / ScenarioError name the field."""
    from collab_tools.orchestration.experiment import load_experiment
    from pybullet_bridge.core.occupancy_map import read_nav2_map
    from pybullet_bridge.core.scenario import load_scenario

    config_dir = Path(config_dir)
    settings_path = _existing(settings, '--settings') or config_dir / DEFAULT_SETTINGS
    map_path = _existing(map_yaml, '--map')
    task = load_formation_task(settings_path)
    experiment = load_experiment(config_dir / EXPERIMENT_FILE)
    generated = settings is not None or map_path is not None
    scenario_file = task.scenario
    if map_path is not None:
        read_nav2_map(map_path, error=RoleEngineError, extra_fields=('name', 'description', 'border_is_obstacle'))
        data = read_yaml_file(task.scenario, 'scenario file', RoleEngineError)
        if not isinstance(data, dict):
            raise RoleEngineError(f'{task.scenario}: must be a mapping')
        data = dict(data, obstacles={'map': str(map_path)})
        run_dir.mkdir(parents=True, exist_ok=True)
        scenario_file = run_dir / 'scenario.yaml'
        scenario_file.write_text(f'# {task.scenario} with the obstacles of {map_path}\n'
                                 + yaml.safe_dump(data, sort_keys=False))
    scenario = load_scenario(scenario_file)
    team = team_from_scenario(scenario, task.inflation_margin)
    obstacles = obstacle_boxes(scenario)
    check_starts(scenario, obstacles, '--map' if map_path is not None else str(scenario_file))
    if generated:
        run_dir.mkdir(parents=True, exist_ok=True)
        settings_data = read_yaml_file(settings_path, 'settings file', RoleEngineError)
        settings_data = dict(settings_data, scenario=str(scenario_file))
        settings_file = run_dir / 'settings.yaml'
        settings_file.write_text(f'# {settings_path}, scenario {scenario_file}\n'
                                 + yaml.safe_dump(settings_data, sort_keys=False))
        task = load_formation_task(settings_file)
        experiment = experiment_for(experiment, settings_file, scenario_file, [m.name for m in team])
    return FormationInputs(task, team, scenario_file, obstacles, experiment, generated)


def check_starts(scenario, obstacles: list[ObstacleBox], where: str) -> None:
    """Every robot's start disc is clear of every obstacle (RoleEngineError naming the robot and box)."""
    for robot in scenario.sections.get('mobile_robots', []):
        point = np.array([robot.initial_pose[:2]])
        for box in obstacles:
            clearance = float(box.signed_distance(point)[0]) - float(robot.params.radius)
            if clearance <= 0.0:
                raise RoleEngineError(f'{where}: robot {robot.name} starts at ({point[0, 0]:g}, {point[0, 1]:g}) '
                                      f'overlapping obstacle {box.name} (clearance {clearance:.3f} m)')


def experiment_for(data: dict, settings_file: Path, scenario_file: Path, robots: list[str]) -> dict:
    """The experiment with every ``settings_file`` / ``scenario`` parameter pointing at these files, one
    role player per robot (copies of the file's first player, in the robot's namespace) and the
    robots' ``cmd_vel`` and ``tracked_pose`` (what the players steer by) recorded instead of the file's."""
    data = copy.deepcopy(data)
    players = [node for node in data['nodes'] if node.get('executable') == 'role_player']
    if not players:
        raise RoleEngineError(f'{EXPERIMENT_FILE}: nodes: no role_player node to copy')
    others = [node for node in data['nodes'] if node.get('executable') != 'role_player']
    data['nodes'] = others + [dict(copy.deepcopy(players[0]), namespace=f'/{robot}') for robot in robots]
    for node in data['nodes']:
        parameters = []
        for entry in node.get('parameters') or []:
            if isinstance(entry, dict):
                entry = dict(entry)
                if 'settings_file' in entry:
                    entry['settings_file'] = str(settings_file)
                if 'scenario' in entry:
                    entry['scenario'] = str(scenario_file)
            parameters.append(entry)
        node['parameters'] = parameters
    record = data.get('record')
    if isinstance(record, dict) and isinstance(record.get('topics'), list):
        topics = [t for t in record['topics'] if not str(t).endswith(('/cmd_vel', '/tracked_pose'))]
        record['topics'] = topics + [f'/{robot}/{topic}' for robot in robots for topic in ('cmd_vel', 'tracked_pose')]
    return data
