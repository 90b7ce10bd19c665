"""``coalition-boxpush``'s inputs from the command line, validated before anything runs.

The box-pushing simulation (:mod:`.boxpush`) is an orchestration file (the bridge and one
schema_agent node per robot, each with its task and goal) plus three files it names: the bridge
scenario, the team's capability file and the agents' shared parameter file. Each can be given on
the command line (``--experiment``, ``--scenario``, ``--team``, ``--agents``; defaults: the
shipped config/experiments/coalition_boxpush.yaml and what it names). :func:`boxpush_inputs`
puts the given files into the experiment and checks, with the same parsers the nodes use, that
they fit together; a mismatch is a :class:`~..core.errors.ConfigError` naming the file and field:

* the team file and the schema library load; every agent's robot is in the team and stands in the
  scenario (``mobile_robots``) carrying every sensor its type lists; where the team file gives a
  fiducial's field of view, the scenario's fiducial has the same ``fov_deg`` and ``range``;
* the scenario loads (the bridge's parser: obstacles, the movable box ``box`` the leader pushes);
* one leader runs ``box_pushing_to_goal`` and one ``navigation``, each with a ``goal_position``
  [x, y]; one leader waits for the other (``exit_after``): the run ends when it exits;
* the shared parameter file is a ROS 2 parameter file whose ``/**`` ``goal_tolerance`` is at most
  the acceptance tolerance.
"""
from __future__ import annotations

import copy
from pathlib import Path

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.fields import check_number, read_yaml_file, require_mapping
from collab_tools.orchestration.experiment import load_experiment, parse_node

from ..core import load_capability_file
from ..core.errors import ConfigError
from .configuration import COALITIONS, CoalitionConfig

EXPERIMENT = 'coalition_boxpush.yaml'
BOX = 'box'
#: how close (m) the box and the navigating robot must end to their goals (ground truth)
ACCEPTANCE_TOLERANCE_M = 0.3
#: The two tasks of the scenario: leader robot -> what it does.
BOX_TASK, NAVIGATION_TASK = 'box_pushing_to_goal', 'navigation'
AGENT_EXECUTABLE, BRIDGE_EXECUTABLE = 'schema_agent', 'pybullet_bridge'


def agent_nodes(experiment: dict) -> dict[str, dict]:
    """robot -> merged inline parameters of its schema_agent node in the experiment file, and the
    node's orchestration label (``node``). The robot is the node's namespace (/<robot>)."""
    agents = {}
    for index, node in enumerate(experiment['nodes']):
        if node.get('executable') != AGENT_EXECUTABLE:
            continue
        params: dict = {}
        for entry in node.get('parameters', []):
            if isinstance(entry, dict):
                params.update(entry)
        robot = str(node.get('namespace') or '').strip('/').split('/')[-1]
        if not robot:
            raise ConfigError(f'experiment nodes[{index}] (schema_agent): needs namespace: /<robot>')
        agents[robot] = {**params, 'robot': robot, 'node': parse_node(node, f'nodes[{index}]').label}
    return agents


def _expand(value: str, config_dir: Path) -> Path:
    return Path(str(value).replace('{config}', str(config_dir)))


def _given(path: str | None, option: str) -> Path | None:
    if path is None:
        return None
    resolved = Path(path).resolve()
    if not resolved.is_file():
        raise ConfigError(f'{option}: no file {str(path)!r}')
    return resolved


def _put_files(experiment: dict, scenario: Path | None, team: Path | None, shared: Path | None) -> None:
    """Replace the bridge's scenario, every agent's capability_file and parameter file in place."""
    for node in experiment['nodes']:
        parameters = node.setdefault('parameters', [])
        if node.get('executable') == BRIDGE_EXECUTABLE and scenario is not None:
            for entry in parameters:
                if isinstance(entry, dict) and 'scenario' in entry:
                    entry['scenario'] = str(scenario)
        if node.get('executable') == AGENT_EXECUTABLE:
            if team is not None:
                for entry in parameters:
                    if isinstance(entry, dict) and 'capability_file' in entry:
                        entry['capability_file'] = str(team)
            if shared is not None:
                node['parameters'] = [str(shared)] + [e for e in parameters if not isinstance(e, str)]


def _bridge_scenario_path(experiment: dict, config_dir: Path) -> Path:
    for node in experiment['nodes']:
        if node.get('executable') == BRIDGE_EXECUTABLE:
            for entry in node.get('parameters', []):
                if isinstance(entry, dict) and 'scenario' in entry:
                    return _expand(entry['scenario'], config_dir)
    raise ConfigError('experiment: no pybullet_bridge node with a scenario parameter')


def _shared_parameters(experiment: dict, config_dir: Path) -> tuple[Path, float]:
    """The agents' shared parameter file and its goal_tolerance."""
    files = {str(e) for node in experiment['nodes'] if node.get('executable') == AGENT_EXECUTABLE
             for e in node.get('parameters', []) if isinstance(e, str)}
    if len(files) != 1:
        raise ConfigError(f'experiment: the schema_agent nodes must share one parameter file (got {sorted(files)})')
    path = _expand(files.pop(), config_dir)
    data = read_yaml_file(path, 'agents parameter file', ConfigError)
    try:
        shared = require_mapping(require_mapping(data, '', ConfigError).get('/**'), '/**', ConfigError)
        params = require_mapping(shared.get('ros__parameters'), '/**.ros__parameters', ConfigError)
        tolerance = check_number(params.get('goal_tolerance'), '/**.ros__parameters.goal_tolerance', gt=0.0,
                                 error=ConfigError)
    except ConfigError as exc:
        raise ConfigError(f'{path}: {exc}') from None
    if tolerance > ACCEPTANCE_TOLERANCE_M:
        raise ConfigError(f'{path}: /**.ros__parameters.goal_tolerance: the leaders must stop within the acceptance '
                          f'tolerance {ACCEPTANCE_TOLERANCE_M} m (got {tolerance})')
    return path, tolerance


def _check_team_in_scenario(agents: dict[str, dict], config: CoalitionConfig, config_dir: Path,
                            scenario_path: Path) -> None:
    from pybullet_bridge.core.scenario import load_scenario as load_bridge_scenario
    try:
        scenario = load_bridge_scenario(scenario_path)
    except ConfigurationError as exc:
        raise ConfigError(f'--scenario: {exc}') from None
    robots = {robot.name: robot for robot in scenario.sections.get('mobile_robots', [])}
    if BOX not in {box.name for box in scenario.sections.get('movable_boxes', [])}:
        raise ConfigError(f'{scenario_path}: movable_boxes: no box named {BOX!r} (the box the leader pushes)')
    teams: dict[Path, dict] = {}
    for robot, params in agents.items():
        if 'capability_file' not in params:
            raise ConfigError(f'experiment: /{robot}/schema_agent: no capability_file parameter')
        team_path = _expand(params['capability_file'], config_dir)
        if team_path not in teams:
            teams[team_path] = load_capability_file(team_path, config.library).robots
        team = teams[team_path]
        if robot not in team:
            raise ConfigError(f'{team_path}: robots: no robot {robot!r} (the experiment runs an agent for it)')
        if robot not in robots:
            raise ConfigError(f'{scenario_path}: mobile_robots: no robot {robot!r} (the experiment runs an agent for it)')
        carried = robots[robot].sensors
        for sensor in team[robot].sensor_names:
            if carried is None or sensor not in carried:
                raise ConfigError(f'{scenario_path}: mobile_robots.{robot}.sensors: no {sensor} (its type '
                                  f'{team[robot].name!r} in {team_path.name} lists one)')
            view = team[robot].sensor_view(sensor)
            if view is not None and sensor == 'fiducial' and (
                    abs(carried[sensor].fov_deg - view[0]) > 1e-9 or abs(carried[sensor].range - view[1]) > 1e-9):
                raise ConfigError(f'{scenario_path}: mobile_robots.{robot}.sensors.fiducial: fov_deg '
                                  f'{carried[sensor].fov_deg:g}, range {carried[sensor].range:g} differ from its type '
                                  f'{team[robot].name!r} in {team_path.name} ({view[0]:g} deg, {view[1]:g} m)')


def _check_leaders(agents: dict[str, dict], config: CoalitionConfig) -> dict:
    leaders = {robot: params for robot, params in agents.items() if params.get('task', 'none') != 'none'}
    for robot, params in leaders.items():
        config.task(str(params['task']), f'experiment: /{robot}/schema_agent task')
        goal = params.get('goal_position')
        if (not isinstance(goal, (list, tuple)) or len(goal) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in goal)):
            raise ConfigError(f'experiment: /{robot}/schema_agent goal_position: must be [x, y] (got {goal!r})')
    for task in (BOX_TASK, NAVIGATION_TASK):
        count = sum(1 for params in leaders.values() if params['task'] == task)
        if count != 1:
            raise ConfigError(f'experiment: exactly one schema_agent must run task {task} (got {count})')
    waiting = [params for params in agents.values() if [r for r in params.get('exit_after', []) if r]]
    if not waiting:
        raise ConfigError('experiment: no schema_agent with exit_after (the leader that waits for the other one '
                          'ends the run)')
    return waiting[0]


def boxpush_inputs(config_dir: Path, experiment_path: str | None = None, scenario: str | None = None,
                   team: str | None = None, agents_file: str | None = None) -> tuple[dict, dict[str, dict], float]:
    """The experiment to run (files put in, ``until`` set), its agents and the leaders'
    goal_tolerance; everything checked (module docstring) before anything runs."""
    config_dir = Path(config_dir).resolve()
    path = _given(experiment_path, '--experiment') or config_dir / 'experiments' / EXPERIMENT
    try:
        experiment = copy.deepcopy(load_experiment(path))
    except ConfigurationError as exc:
        raise ConfigError(f'--experiment: {exc}') from None
    _put_files(experiment, _given(scenario, '--scenario'), _given(team, '--team'), _given(agents_file, '--agents'))
    try:
        agents = agent_nodes(experiment)
    except ConfigurationError as exc:
        raise ConfigError(f'{path}: {exc}') from None
    if not agents:
        raise ConfigError(f'{path}: nodes: no schema_agent node')
    _, goal_tolerance = _shared_parameters(experiment, config_dir)
    config = CoalitionConfig.load(config_dir / COALITIONS)
    last = _check_leaders(agents, config)
    _check_team_in_scenario(agents, config, config_dir, _bridge_scenario_path(experiment, config_dir))
    experiment['until'] = {'exit': last['node']}
    return experiment, agents, goal_tolerance


__all__ = ['ACCEPTANCE_TOLERANCE_M', 'BOX', 'BOX_TASK', 'EXPERIMENT', 'NAVIGATION_TASK', 'agent_nodes',
           'boxpush_inputs']
