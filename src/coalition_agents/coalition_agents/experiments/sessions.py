"""Running schema_agent nodes on the bridge through the orchestration library (the sim experiments).

Every run is ``config/experiments/coalition_agents.yaml`` (bridge + ``schema_agent_host`` +
recorder) with what :mod:`..core.sim_scenarios` generates: ``scenario.yaml`` in the run directory
(read by the bridge, on the orchestrator's machine); the team (capabilities with the bridge's
sensor names, the ``capabilities`` parameter) and the agents' parameters travel in the generated
experiment as the agent processes' parameters (a whole parameter-file mapping), so agent processes
on another machine read no file of the run directory (``team.yaml`` there is a record for the
reader only). The recorder keeps the channel and every robot's status
(:mod:`.coalition_bag` reads them).

* :class:`AgentSetup` -- what a run needs besides the geometry (task, leaders, search and settle
  times, link model, clock, how many host processes and on which hosts);
* :func:`host_groups` -- the robots of each schema_agent_host process;
* :func:`run_session` -- generate the run and run it; returns the orchestration's result (its
  ``bag`` is the recorded run).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence

import yaml

from ..core.errors import ConfigError
from ..core.sim_scenarios import (
    Placement, SensorSettings, agent_parameter_file, bridge_scenario, capability_file, capability_text,
)
from .coalition_bag import BATCHES, BUNDLES, status_topic

Log = Callable[[str], None]

EXPERIMENT_FILE = 'coalition_agents.yaml'
#: the agents' node name, in each robot's namespace (/<robot>/schema_agent)
AGENT_NODE = 'schema_agent'


def agent_label(robot: str) -> str:
    """The orchestration's label of ``robot``'s schema_agent process (its log file, ``until: exit``)."""
    from collab_tools.orchestration.node_process import NodeSpec
    return NodeSpec('coalition_agents', 'schema_agent', name=AGENT_NODE, namespace=f'/{robot}').label


@dataclass(frozen=True)
class AgentSetup:
    """What a simulated coalition run needs besides the geometry."""

    task: str = 'navigation'
    leaders: tuple[str, ...] = ()
    search_time_s: float = 3.0
    settle_time_s: float = 1.0
    loss_probability: float = 0.0
    link_preset: str = 'paper_fig9'
    use_sim_time: bool = True
    seed: int = 0
    team_wait_s: float = 30.0
    timeout_s: float = 180.0
    #: True: the agents in schema_agent_host processes; False: one schema_agent process each
    hosted: bool = True
    #: how many schema_agent_host processes share the agents (see :func:`host_groups`)
    host_processes: int = 1
    #: where the runs' nodes are and how they meet: experiment fields ``discovery``, ``hosts``
    #: (orchestration.network), and ``process_hosts``: the host of each agent process, in
    #: host_groups order (None: the orchestrator's machine)
    discovery: Mapping | None = None
    hosts: Mapping | None = None
    process_hosts: tuple[str | None, ...] = ()
    #: s for every node to appear in the graph (the experiment's ``discovery_timeout``; None: its default)
    discovery_timeout_s: float | None = None
    #: simulated s per bridge tick (its ``control_period``; None: the bridge's parameter file)
    bridge_control_period: float | None = None


def host_groups(robots: Sequence[str], leaders: Sequence[str], processes: int) -> list[list[str]]:
    """The robots of each schema_agent_host process, as even as possible: the first group (the
    host the experiment waits for) holds every leader. Why several: one process runs its
    agents' reasoning on one core (the GIL); a second process uses the machine's second core."""
    if isinstance(processes, bool) or not isinstance(processes, int) or processes < 1:
        raise ConfigError(f'host_processes: must be an integer >= 1 (got {processes!r})')
    processes = min(processes, len(robots))
    helpers = [robot for robot in robots if robot not in leaders]
    sizes = [len(robots) // processes + (1 if index < len(robots) % processes else 0) for index in range(processes)]
    if len(leaders) > sizes[0]:
        raise ConfigError(f'host_processes: {processes} processes put at most {sizes[0]} robots in the leaders\' '
                          f'host, fewer than the {len(leaders)} leaders')
    groups = [list(leaders) + helpers[:sizes[0] - len(leaders)]]
    taken = sizes[0] - len(leaders)
    for size in sizes[1:]:
        groups.append(helpers[taken:taken + size])
        taken += size
    return groups


def check_session_inputs(placements: Sequence[Placement], types: Mapping[str, Mapping],
                         sensor_names: Mapping[str, str] | None = None, obstacles: Mapping | None = None,
                         sensors: SensorSettings | None = None) -> dict:
    """The bridge scenario :func:`run_session` would generate, validated by the bridge's own parser
    before anything runs (a ConfigError naming the field otherwise)."""
    from pybullet_bridge.core.scenario import parse_scenario
    from collab_tools.core.errors import ConfigurationError
    team = capability_file(placements, types, sensor_names)
    scenario = bridge_scenario('check', placements, team['robot_types'], sensors or SensorSettings(),
                               obstacles=obstacles)
    try:
        parse_scenario(scenario, Path.cwd())
    except ConfigurationError as exc:
        raise ConfigError(f'generated bridge scenario: {exc}') from None
    return scenario


def run_session(run_dir: Path, config_dir: Path, name: str, placements: Sequence[Placement],
                types: Mapping[str, Mapping], sensors: SensorSettings, setup: AgentSetup,
                sensor_names: Mapping[str, str] | None = None, log: Log | None = None,
                obstacles: Mapping | None = None):
    """Generate the run (the bridge scenario file with ``obstacles``, the bridge's ``obstacles``
    section; the agents' parameters inline) and run config/experiments/coalition_agents.yaml;
    returns the SessionRunResult (its ``bag`` is the recorded run)."""
    from collab_tools.orchestration.experiment import load_experiment, run_experiment
    run_dir, config_dir = Path(run_dir).resolve(), Path(config_dir).resolve()
    run_dir.mkdir(parents=True, exist_ok=True)
    coalitions = config_dir / 'coalitions'
    team = capability_file(placements, types, sensor_names)
    renamed = {name_: entry for name_, entry in team['robot_types'].items()}
    scenario = bridge_scenario(name, placements, renamed, sensors, seed=setup.seed, obstacles=obstacles)
    robots = [p.robot for p in placements]
    unknown = [r for r in setup.leaders if r not in robots]
    if unknown:
        raise ConfigError(f'leaders: unknown robot {unknown[0]!r} (robots: {", ".join(robots)})')
    # The team inline (no node reads a generated file); the other files are tracked config.
    common = {'capabilities': capability_text(team), 'schemas_file': str(coalitions / 'schemas.yaml'),
              'costs_file': str(coalitions / 'costs.yaml'), 'tasks_file': str(coalitions / 'tasks.yaml'),
              'task': 'none', 'team_task': setup.task, 'link_preset': setup.link_preset,
              'loss_probability': float(setup.loss_probability), 'search_time': float(setup.search_time_s),
              'settle_time': float(setup.settle_time_s),
              'team_wait': float(setup.team_wait_s), 'exit_when_done': False}
    per_robot = {robot: {'seed': setup.seed * 1000 + index,
                         **({'task': setup.task, 'exit_when_done': True} if robot in setup.leaders else {})}
                 for index, robot in enumerate(robots)}
    (run_dir / 'scenario.yaml').write_text(yaml.safe_dump(scenario, sort_keys=False))
    (run_dir / 'team.yaml').write_text('# a record of the run\'s team; the agents get it as their capabilities '
                                       'parameter\n' + yaml.safe_dump(team, sort_keys=False))

    def agent_parameters(group: Sequence[str]) -> dict:
        """The parameter-file mapping of the agents of ``group`` (common + theirs), given to their process."""
        return agent_parameter_file(common, {robot: per_robot[robot] for robot in group}, AGENT_NODE)
    experiment = load_experiment(config_dir / 'experiments' / EXPERIMENT_FILE)
    experiment['timeout'] = setup.timeout_s
    # What the analysis reads (coalition_bag): the channel's bundles and batches, every robot's status.
    # The recorder keeps the agents' clock (the bag's receive stamps on the same time line).
    experiment['record']['use_sim_time'] = setup.use_sim_time
    experiment['record']['topics'] = list(dict.fromkeys(list(experiment['record']['topics']) + [BUNDLES, BATCHES]
                                                        + [status_topic(r) for r in robots]))
    nodes = []
    for node in experiment['nodes']:
        if node['executable'] == 'pybullet_bridge' and setup.bridge_control_period is not None:
            nodes.append({**node, 'parameters': list(node.get('parameters', []))
                          + [{'control_period': float(setup.bridge_control_period)}]})
        elif node['executable'] != 'schema_agent_host':
            nodes.append(node)
        elif setup.hosted:
            # The experiment waits for the first host (the leaders'); the others stop with it.
            for index, group in enumerate(host_groups(robots, setup.leaders, setup.host_processes)):
                host = setup.process_hosts[index] if index < len(setup.process_hosts) else None
                nodes.append({**node, 'use_sim_time': setup.use_sim_time,
                              **({} if index == 0 else {'name': f'{node["executable"]}_{index + 1}', 'required': False}),
                              **({'host': host} if host else {}),
                              'parameters': list(node.get('parameters', [])) + [{'robots': group},
                                                                                agent_parameters(group)]})
        else:  # one schema_agent process per robot, in its namespace (the parameter mapping is keyed by it)
            nodes.extend({'package': 'coalition_agents', 'executable': 'schema_agent', 'name': AGENT_NODE,
                          'namespace': f'/{robot}', 'use_sim_time': setup.use_sim_time,
                          'required': robot in setup.leaders, 'parameters': [agent_parameters([robot])]}
                         for robot in robots)
    experiment['nodes'] = nodes
    for field_ in ('discovery', 'hosts'):
        if getattr(setup, field_) is not None:
            experiment[field_] = dict(getattr(setup, field_))
    if setup.discovery_timeout_s is not None:
        experiment['discovery_timeout'] = float(setup.discovery_timeout_s)
    if not setup.hosted:
        experiment['until'] = {'exit': agent_label(setup.leaders[0])}
    generated = run_dir / 'experiment.yaml'
    generated.write_text(yaml.safe_dump(experiment, sort_keys=False))
    return run_experiment(generated, config_dir, run_dir=run_dir, log=log)



__all__ = ['AGENT_NODE', 'AgentSetup', 'EXPERIMENT_FILE', 'agent_label', 'check_session_inputs', 'host_groups',
           'run_session']
