"""The paper's coalition experiments in simulation: schema_agent nodes on the bridge, recorded,
results computed from the bags (``scripts/experiment coalition-fig9``, ``coalition-fig7 --mode sim``,
the coalition demo).

Every run is ``config/experiments/coalition_agents.yaml`` (bridge + ``schema_agent_host`` +
recorder) with what :mod:`.core.sim_scenarios` generates: ``scenario.yaml`` in the run directory
(read by the bridge, on the orchestrator's machine); the team (capabilities with the bridge's
sensor names, the ``capabilities`` parameter) and the agents' parameters travel in the generated
experiment as the agent processes' parameters (a whole parameter-file mapping), so agent processes
on another machine read no file of the run directory (``team.yaml`` there is a record for the
reader only). The recorder keeps ``/coalition/channel``, every
robot's inbox ``/coalition/channel/<robot>`` and every ``/<robot>/coalition`` status; :func:`read_coalition_bag` turns them into a :class:`CoalitionRun`.

What is measured (from the agents' own stamps: a status is stamped when it is published, a
channel message when it leaves the link model, i.e. after its sampled delay):

* search start: the time in the leader's status detail (``search started at <t> s``), else its
  first ``searching`` status;
* found: the leader's status that reports its first executable coalition (published when the
  agent first instantiates one; the paper's "time to find the coalition solution"). Bags without
  it (older runs) fall back to the first offer that, with the earlier ones, covers the members of
  the coalition it later set up;
* formed: the leader's ``committed`` status (negotiation done). The node negotiates once its
  cheapest coalition has not improved for ``settle_time``, or at ``search_time`` at the latest:
  formed - found is settle_time plus the negotiation's round trips.

Fig. 9 runs the agents on the wall clock (``use_sim_time`` false): the paper reports wall-clock
times and the bridge may fall behind real time with 20 robots, which would make simulated stamps
understate the wall time. Fig. 7 runs them on the bridge's clock (its result is not a time).
"""
from __future__ import annotations

import json
import math
import re
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Mapping, Sequence

import yaml

from .core.channel_codec import MessageKind
from .core.errors import ConfigError
from .core.sim_scenarios import (
    COLUMN_TYPES, Placement, SensorSettings, agent_parameter_file, bridge_scenario, capability_file,
    capability_text, column_placements, column_sees_only_the_robot_ahead, placements_from_poses,
)
from .core.validation import Section, as_mapping, as_number, load_config_file

Log = Callable[[str], None]

CHANNEL = '/coalition/channel'
STATUS_TYPE = 'coalition_interfaces/msg/AgentStatus'
EXPERIMENT_FILE = 'coalition_agents.yaml'
COLUMN_CONFIG = 'scenarios/fig9_column.yaml'
#: the agents' node name, in each robot's namespace (/<robot>/schema_agent)
AGENT_NODE = 'schema_agent'
#: the leader's status detail when it has its first executable coalition (schema_agent_node)
FOUND_MARK = 'first executable coalition at'
#: the start of the search in the leader's status detail (its own clock)
SEARCH_START = re.compile(r'search started at (\d+(?:\.\d+)?) s')


def agent_label(robot: str) -> str:
    """The orchestration's label of ``robot``'s schema_agent process (its log file, ``until: exit``)."""
    from collab_tools.orchestration.node_process import NodeSpec
    return NodeSpec('coalition_agents', 'schema_agent', name=AGENT_NODE, namespace=f'/{robot}').label


def status_topic(robot: str) -> str:
    return f'/{robot}/coalition'


# === Reading a run from its bag ===================================================================

@dataclass(frozen=True)
class StatusRecord:
    stamp: float
    robot: str
    state: str
    task: str
    coalition_id: str
    leader: str
    members: tuple[str, ...]
    cost: float
    detail: str = ''


@dataclass(frozen=True)
class MessageRecord:
    stamp: float
    sender: str
    receiver: str
    kind: int
    members: tuple[str, ...] = ()
    cost: float = 0.0


@dataclass
class CoalitionRun:
    """The statuses and channel messages of one recorded run, in stamp order."""

    statuses: list[StatusRecord] = field(default_factory=list)
    #: logical channel messages (every message of a batch, every piggybacked ACK as kind 3)
    messages: list[MessageRecord] = field(default_factory=list)
    #: ROS messages on the channel topics (batches on the inboxes, single messages on the shared topic)
    ros_messages: int = 0

    def robots(self) -> list[str]:
        return sorted({s.robot for s in self.statuses})

    def leaders(self) -> list[str]:
        """Robots whose status names a task (they search; the others help)."""
        return sorted({s.robot for s in self.statuses if s.task and s.task != 'none'})

    def of(self, robot: str) -> list[StatusRecord]:
        return [s for s in self.statuses if s.robot == robot]


def _stamp(header) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def read_coalition_bag(bag: Path) -> CoalitionRun:
    """Statuses (``/<robot>/coalition``) and channel messages of a recorded run."""
    from collab_tools.core.bag_analysis import read_messages
    run = CoalitionRun()
    for topic, _, msg in read_messages(Path(bag)):
        if topic == CHANNEL or topic.startswith(CHANNEL + '/'):  # the shared topic and the inboxes
            run.ros_messages += 1
            stamp = _stamp(msg.header)
            if hasattr(msg, 'acked_ids'):  # an AgentMessageBatch (agent_channel): stamped when it left the link
                run.messages.extend(MessageRecord(stamp, m.sender, m.receiver, int(m.kind), tuple(m.members),
                                                  float(m.cost)) for m in msg.messages)
                run.messages.extend(MessageRecord(stamp, msg.sender, msg.recipient, MessageKind.ACK)
                                    for _ in msg.acked_ids)
            else:
                run.messages.append(MessageRecord(stamp, msg.sender, msg.receiver, int(msg.kind),
                                                  tuple(msg.members), float(msg.cost)))
        elif topic.endswith('/coalition') and hasattr(msg, 'state'):
            run.statuses.append(StatusRecord(_stamp(msg.header), msg.robot, msg.state, msg.task, msg.coalition_id,
                                             msg.leader, tuple(msg.members), float(msg.cost), msg.detail))
    run.statuses.sort(key=lambda s: s.stamp)
    run.messages.sort(key=lambda m: m.stamp)
    return run


@dataclass(frozen=True)
class LeaderTimeline:
    """One leader's search: its stamps (s, its own clock) and the coalition it set up."""

    robot: str
    search_start: float | None
    found: float | None
    formed: float | None
    state: str
    members: tuple[str, ...]
    cost: float | None
    coalition_id: str

    @property
    def found_s(self) -> float | None:
        return None if self.found is None or self.search_start is None else self.found - self.search_start

    @property
    def formed_s(self) -> float | None:
        return None if self.formed is None or self.search_start is None else self.formed - self.search_start

    def to_dict(self) -> dict:
        rounded = lambda v: None if v is None else round(v, 4)  # noqa: E731
        return {'robot': self.robot, 'state': self.state, 'members': list(self.members), 'cost': self.cost,
                'coalition_id': self.coalition_id, 'found_s': rounded(self.found_s),
                'formed_s': rounded(self.formed_s)}


def leader_timeline(run: CoalitionRun, leader: str) -> LeaderTimeline:
    """When ``leader`` started searching, found and set up its coalition (see the module docstring)."""
    statuses = run.of(leader)
    # The agent's own record of its search start (its first 'searching' status may be missed by
    # a recorder that subscribes to the latched status topic late), else that status's stamp.
    started = next((match for s in statuses for match in [SEARCH_START.search(s.detail)] if match), None)
    start = float(started.group(1)) if started else next((s.stamp for s in statuses if s.state == 'searching'), None)
    final = statuses[-1] if statuses else None
    committed = next((s for s in statuses if s.state == 'committed' and s.leader == leader), None)
    found = next((s.stamp for s in statuses if FOUND_MARK in s.detail), None)
    if committed is not None and found is None:
        helpers = set(committed.members) - {leader}
        covered: set[str] = set()
        for message in run.messages:
            if message.kind != MessageKind.OFFER or message.receiver != leader:
                continue
            provided = ({message.sender} | set(message.members)) - {leader}
            covered |= provided
            if provided == helpers or helpers <= covered:
                found = message.stamp
                break
        if not helpers:
            found = committed.stamp
    return LeaderTimeline(leader, start, found, None if committed is None else committed.stamp,
                          final.state if final else 'absent',
                          committed.members if committed else (), committed.cost if committed else None,
                          committed.coalition_id if committed else '')


def commitments(run: CoalitionRun) -> dict[str, list[str]]:
    """robot -> the distinct coalitions it was committed to, in order (a robot holding two at once
    shows up in :func:`conflicting_commitments`)."""
    found: dict[str, list[str]] = defaultdict(list)
    for status in run.statuses:
        if status.state == 'committed' and status.coalition_id and status.coalition_id not in found[status.robot]:
            found[status.robot].append(status.coalition_id)
    return dict(found)


def conflicting_commitments(run: CoalitionRun) -> dict[str, list[str]]:
    """robot -> coalitions it was committed to while still committed to another: a status with a
    new coalition id without an idle/failed status (release) in between."""
    conflicts: dict[str, list[str]] = {}
    for robot in run.robots():
        current = ''
        for status in run.of(robot):
            if status.state == 'committed' and status.coalition_id:
                if current and status.coalition_id != current:
                    conflicts.setdefault(robot, [current]).append(status.coalition_id)
                current = status.coalition_id
            elif status.state in ('idle', 'failed', 'searching'):
                current = ''
    return conflicts


def message_counts(run: CoalitionRun, robots: Sequence[str], start: float, end: float,
                   bin_s: float) -> dict:
    """Messages each robot sent and received (addressed to it) per time bin after ``start``."""
    if not bin_s > 0:
        raise ValueError(f'bin_s: must be > 0 (got {bin_s})')
    bins = max(1, int(math.ceil((end - start) / bin_s)))
    sent = {robot: [0] * bins for robot in robots}
    received = {robot: [0] * bins for robot in robots}
    for message in run.messages:
        index = int((message.stamp - start) // bin_s)
        if not 0 <= index < bins:
            continue
        if message.sender in sent:
            sent[message.sender][index] += 1
        if message.receiver in received:
            received[message.receiver][index] += 1
    return {'bin_s': bin_s, 'times_s': [round(i * bin_s, 6) for i in range(bins)], 'sent': sent,
            'received': received}


def _kind_name(kind: int) -> str:
    try:
        return MessageKind(kind).text
    except ValueError:
        return str(kind)


def kind_totals(run: CoalitionRun) -> dict[str, int]:
    totals: dict[str, int] = defaultdict(int)
    for message in run.messages:
        totals[_kind_name(message.kind)] += 1
    return dict(totals)


# === Running one session ===========================================================================

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


def run_session(run_dir: Path, config_dir: Path, name: str, placements: Sequence[Placement],
                types: Mapping[str, Mapping], sensors: SensorSettings, setup: AgentSetup,
                sensor_names: Mapping[str, str] | None = None, log: Log | None = None):
    """Generate the run (the bridge scenario file, the agents' parameters inline) and run
    config/experiments/coalition_agents.yaml; returns the ExperimentResult (its ``bag`` is the
    recorded run)."""
    from collab_tools.orchestration.experiment import load_experiment, run_experiment
    run_dir, config_dir = Path(run_dir).resolve(), Path(config_dir).resolve()
    run_dir.mkdir(parents=True, exist_ok=True)
    coalitions = config_dir / 'coalitions'
    team = capability_file(placements, types, sensor_names)
    renamed = {name_: entry for name_, entry in team['robot_types'].items()}
    scenario = bridge_scenario(name, placements, renamed, sensors, seed=setup.seed)
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
    experiment['record']['topics'] = (list(experiment['record']['topics']) + [f'{CHANNEL}/{r}' for r in robots]
                                      + [status_topic(r) for r in robots])
    nodes = []
    for node in experiment['nodes']:
        if node['executable'] != 'schema_agent_host':
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
    if not setup.hosted:
        experiment['until'] = {'exit': agent_label(setup.leaders[0])}
    generated = run_dir / 'experiment.yaml'
    generated.write_text(yaml.safe_dump(experiment, sort_keys=False))
    return run_experiment(generated, config_dir, run_dir=run_dir, log=log)


# === Fig. 9: the column ============================================================================

@dataclass(frozen=True)
class ColumnConfig:
    path: Path
    robots: tuple[int, ...]
    spacing_m: float
    sensors: SensorSettings
    link_preset: str
    loss_probability: float
    search_time_s: Mapping[str, float]
    settle_time_s: float
    timeout_s: float
    paper_time_s: Mapping[int, float]
    agent_processes: int = 1

    def search_time(self, robots: int) -> float:
        return self.search_time_s.get(str(robots), self.search_time_s['default'])


def column_config_from_dict(data: object, path: Path) -> ColumnConfig:
    section = Section(data, '', ('robots', 'spacing_m', 'fiducial', 'link', 'search_time_s', 'settle_time_s',
                                 'timeout_s', 'paper_time_s', 'agent_processes'))
    robots = []
    for item_path, value in section.items('robots'):
        number = as_number(value, item_path, ge=2.0)
        if number != int(number):
            raise ConfigError(f'{item_path}: must be a whole number of robots >= 2 (got {value!r})')
        robots.append(int(number))
    if not robots:
        raise ConfigError('robots: list at least one column size')
    spacing = section.number('spacing_m', gt=0.0)
    fiducial = Section(section.get('fiducial'), 'fiducial', ('fov_deg', 'range_m'))
    sensors = SensorSettings(fiducial_fov_deg=fiducial.number('fov_deg', gt=0.0),
                             fiducial_range_m=fiducial.number('range_m', gt=0.0))
    if not column_sees_only_the_robot_ahead(spacing, sensors):
        raise ConfigError(f'fiducial: each robot must see only the robot ahead: need spacing_m ({spacing:g}) <= '
                          f'range_m ({sensors.fiducial_range_m:g}) < 2 x spacing_m and fov_deg < 360')
    link = Section(section.get('link', {}), 'link', ('preset', 'loss_probability'))
    preset = link.text('preset', 'paper_fig9')
    loss = link.number('loss_probability', 0.0, ge=0.0)
    if loss > 1.0:
        raise ConfigError(f'link.loss_probability: must be in [0, 1] (got {loss})')
    search = {str(k): v for k, v in _by_robots(section.get('search_time_s'), 'search_time_s').items()}
    if 'default' not in search:
        raise ConfigError('search_time_s.default: required (the search time of column sizes not listed)')
    paper = {int(k): v for k, v in _by_robots(section.get('paper_time_s', {}), 'paper_time_s').items()
             if k != 'default'}
    processes = section.number('agent_processes', 1, ge=1.0)
    if processes != int(processes):
        raise ConfigError(f'agent_processes: must be a whole number >= 1 (got {processes!r})')
    return ColumnConfig(path, tuple(robots), spacing, sensors, preset, loss, search,
                        section.number('settle_time_s', 1.0, gt=0.0), section.number('timeout_s', 150.0, gt=0.0),
                        paper, int(processes))


def _by_robots(value: object, path: str) -> dict:
    """``{default: s, <robots>: s}`` -> {'default' | robots: seconds > 0}."""
    data = as_mapping(value, path)
    found: dict = {}
    for key, seconds in data.items():
        if key != 'default' and (isinstance(key, bool) or not isinstance(key, int) or key < 2):
            raise ConfigError(f'{path}.{key}: keys are column sizes (integers >= 2) or default')
        found[key] = as_number(seconds, f'{path}.{key}', gt=0.0)
    return found


def load_column_config(path: Path) -> ColumnConfig:
    return load_config_file(path, lambda data: column_config_from_dict(data, Path(path)))


def column_result(run: CoalitionRun, robots: int, bin_s: float = 0.05) -> dict:
    """One column run from its bag: the back robot's timeline, commitments and message counts."""
    back = f'robot_{robots}'
    timeline = leader_timeline(run, back)
    everyone = [f'robot_{k}' for k in range(1, robots + 1)]
    result = {'robots': robots, 'leader': back, **timeline.to_dict(),
              'time_s': None if timeline.found_s is None else round(timeline.found_s, 4),
              'includes_all_robots': sorted(timeline.members) == sorted(everyone),
              'messages': len(run.messages), 'ros_messages': run.ros_messages, 'kinds': kind_totals(run),
              'conflicting_commitments': conflicting_commitments(run)}
    if timeline.search_start is not None:
        end = max([m.stamp for m in run.messages] + [timeline.search_start + bin_s])
        result['counts'] = message_counts(run, everyone, timeline.search_start, end, bin_s)
    return result


def run_fig9(config_dir: str | Path, run_dir: str | Path, log: Log = print,
             sizes: Sequence[int] | None = None, config_path: str | Path | None = None) -> dict:
    """Fig. 9: one recorded run per column size; results.json, fig9.md and plots in ``run_dir``."""
    config_dir, run_dir = Path(config_dir), Path(run_dir)
    config = load_column_config(Path(config_path) if config_path else config_dir / 'coalitions' / COLUMN_CONFIG)
    wanted = tuple(sizes) if sizes else config.robots
    rows = []
    for index, robots in enumerate(wanted, start=1):
        placements = column_placements(robots, config.spacing_m)
        setup = AgentSetup(leaders=(placements[-1].robot,), search_time_s=config.search_time(robots),
                           settle_time_s=config.settle_time_s, loss_probability=config.loss_probability, link_preset=config.link_preset,
                           use_sim_time=False, seed=index, timeout_s=config.timeout_s,
                           host_processes=config.agent_processes)
        case_dir = run_dir / f'n{robots:02d}'
        log(f'[coalition-fig9 {index}/{len(wanted)}] column of {robots} robots (search_time '
            f'{setup.search_time_s:g} s) -> {case_dir}')
        began = time.monotonic()
        result = run_session(case_dir, config_dir, f'fig9_column_{robots}', placements, COLUMN_TYPES,
                             config.sensors, setup, log=None)
        row = {'robots': robots, 'run_dir': str(case_dir), 'exit_code': result.exit_code,
               'session_wall_s': round(time.monotonic() - began, 1), 'search_time_s': setup.search_time_s,
               'paper_time_s': config.paper_time_s.get(robots)}
        if result.bag is not None and result.bag.exists():
            row.update(column_result(read_coalition_bag(result.bag), robots))
        else:
            row.update({'state': 'no bag', 'time_s': None, 'formed_s': None})
        rows.append(row)
        log(f'[coalition-fig9] {robots} robots: {row.get("state")}; found after {row.get("time_s")} s, formed after '
            f'{row.get("formed_s")} s (wall, agents\' clocks); {row.get("messages", 0)} logical channel messages in '
            f'{row.get("ros_messages", 0)} ROS messages')
    ten = next((r for r in rows if r['robots'] == 10), None)
    acceptance = {'every_column_formed': all(r.get('state') == 'committed' and r.get('includes_all_robots')
                                             for r in rows),
                  'ten_robots_formed_within_3_s': None if ten is None else
                  (ten.get('formed_s') is not None and ten['formed_s'] <= 3.0),
                  'ten_robots_found_within_3_s': None if ten is None else
                  (ten.get('time_s') is not None and ten['time_s'] <= 3.0),
                  'no_conflicting_commitments': all(not r.get('conflicting_commitments') for r in rows)}
    acceptance['passed'] = all(v is not False for v in acceptance.values())
    results = {'experiment': 'coalition-fig9', 'mode': 'sim', 'config': str(config.path),
               'spacing_m': config.spacing_m,
               'fiducial': {'fov_deg': config.sensors.fiducial_fov_deg, 'range_m': config.sensors.fiducial_range_m},
               'link': {'preset': config.link_preset, 'loss_probability': config.loss_probability},
               'clock': 'wall (agents with use_sim_time false; stamps are the agents\' own)',
               'time_s': {str(r['robots']): r.get('time_s') for r in rows},
               'formed_s': {str(r['robots']): r.get('formed_s') for r in rows},
               'paper_time_s': {str(k): v for k, v in config.paper_time_s.items()},
               'acceptance': acceptance, 'runs': rows}
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2))
    (run_dir / 'fig9.md').write_text(fig9_markdown(results))
    plot_fig9(results, run_dir)
    return results


def fig9_markdown(results: dict) -> str:
    lines = ['Time for the robot at the back of the column to find / set up its coalition (Fig. 9), wall-clock '
             's from its search start, schema_agent nodes on the bridge, link delay '
             f'{results["link"]["preset"]} (loss {results["link"]["loss_probability"]:g}).', '',
             '| robots | found (s) | formed (s) | search_time (s) | paper (s) | state | members | cost | messages '
             '(logical / ROS) |',
             '|---|---|---|---|---|---|---|---|---|']
    fmt = lambda v: '-' if v is None else f'{v:.3f}'  # noqa: E731
    for r in results['runs']:
        paper = '-' if r.get('paper_time_s') is None else f'~{r["paper_time_s"]:g}'
        cost = '-' if r.get('cost') is None else f'{r["cost"]:g}'
        lines.append(f'| {r["robots"]} | {fmt(r.get("time_s"))} | {fmt(r.get("formed_s"))} | {r["search_time_s"]:g} | '
                     f'{paper} | {r.get("state")} | {len(r.get("members", []))} | {cost} | {r.get("messages", 0)} / '
                     f'{r.get("ros_messages", 0)} |')
    lines += ['', '- found: the back robot\'s status reporting its first executable coalition (from the bag); '
              'the paper\'s Fig. 9 measures this ("time to find the coalition solution").',
              '- formed: its committed AgentStatus. The node negotiates once its cheapest coalition has not '
              'improved for settle_time, or at search_time at the latest.',
              '- The paper: about 28 s for ten robots with fixed 0.2 s gaps (T_G, T_C) between steps; ours is '
              'event-driven (agents evaluate when channel messages arrive). The paper\'s other Fig. 9 points are '
              'only in its plot, not in its text.',
              '- messages: logical channel messages (each piggybacked ACK counted as one, retries included) / '
              'ROS messages (AgentMessageBatch: one per sender, recipient and processing step). The link model '
              'applies per batch: one delay and one loss draw per batch, so a loss probability is per batch.',
              f'- Acceptance: {json.dumps(results["acceptance"])}']
    return '\n'.join(lines) + '\n'


def plot_fig9(results: dict, run_dir: Path) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    runs = [r for r in results['runs'] if r.get('time_s') is not None]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot([r['robots'] for r in runs], [r['time_s'] for r in runs], 'o-', label='found (ours)')
    ax.plot([r['robots'] for r in runs if r.get('formed_s') is not None],
            [r['formed_s'] for r in runs if r.get('formed_s') is not None], 's--', label='formed (settle_time / search_time)')
    paper = results['paper_time_s']
    if paper:
        ax.plot([int(k) for k in paper], list(paper.values()), 'k*', ms=12, label='paper (text)')
    ax.set_xlabel('robots in the column')
    ax.set_ylabel('wall-clock s from search start')
    ax.set_yscale('log')
    ax.grid(alpha=0.3, which='both')
    ax.legend()
    ax.set_title('Fig. 9 (top): time for the back robot to find its coalition')
    fig.tight_layout()
    fig.savefig(run_dir / 'fig9_time.png', dpi=100)
    plt.close(fig)
    largest = max((r for r in runs if 'counts' in r and r['robots'] <= 10), key=lambda r: r['robots'], default=None)
    if largest is None:
        return
    counts = largest['counts']
    robots = list(counts['sent'])
    shown = sorted({robots[0], robots[len(robots) // 3], robots[2 * len(robots) // 3], robots[-1]},
                   key=robots.index)
    fig, axes = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    for ax, which in zip(axes, ('sent', 'received')):
        for robot in shown:
            ax.plot(counts['times_s'], counts[which][robot], drawstyle='steps-post', label=robot)
        if largest.get('time_s') is not None:
            ax.axvline(largest['time_s'], color='k', ls=':', label='back robot found its coalition')
        if largest.get('formed_s') is not None:
            ax.axvline(largest['formed_s'], color='k', ls='--', label='coalition set up')
        ax.set_ylabel(f'messages {which} / {counts["bin_s"] * 1000:g} ms')
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[1].set_xlabel('wall s from the back robot\'s search start')
    fig.suptitle(f'Fig. 9 (bottom): messages sent and received (addressed to the robot), {largest["robots"]} robots')
    fig.tight_layout()
    fig.savefig(run_dir / 'fig9_messages.png', dpi=100)
    plt.close(fig)


# === Fig. 7 / Table V: the clusters ================================================================

#: The paper's sensor names in the Fig. 7 team file -> the bridge's.
FIG7_SENSOR_NAMES = {'localization': 'gps'}


def fig7_sim_result(run: CoalitionRun, core: Mapping[str, dict]) -> dict:
    """Per initiator: what the nodes set up (from the bag) next to the core's cheapest coalition."""
    rows = []
    for robot in sorted(core):
        timeline = leader_timeline(run, robot)
        expected = core[robot]
        rows.append({**timeline.to_dict(), 'core_members': expected and expected['members'],
                     'core_cost': expected and expected['cost'],
                     'matches_core': expected is not None and timeline.state == 'committed'
                     and sorted(timeline.members) == sorted(expected['members'])
                     and timeline.cost is not None and abs(timeline.cost - expected['cost']) < 1e-6})
    return {'leaders': rows, 'commitments': commitments(run), 'conflicting_commitments': conflicting_commitments(run),
            'messages': len(run.messages), 'ros_messages': run.ros_messages, 'kinds': kind_totals(run)}


def run_fig7_sim(config_dir: str | Path, run_dir: str | Path, log: Log = print, loss: float = 0.0,
                 scenario_path: str | Path | None = None, search_time_s: float = 6.0, seed: int = 0) -> dict:
    """Fig. 7 / Table V with schema_agent nodes on the bridge: the core experiment (possible vs
    executable, geometric sensing) first, then the same poses in simulation (the bridge's fiducials
    with occlusion); the coalitions the nodes set up are read from the bag and compared with the
    core's cheapest executable ones."""
    from .experiments import CoalitionConfig, load_scenario, run_fig7_core, FIG7_SCENARIO
    config_dir, run_dir = Path(config_dir), Path(run_dir)
    core = run_fig7_core(config_dir / 'coalitions', run_dir / 'core', log=log, scenario_path=scenario_path)
    config = CoalitionConfig.load(config_dir / 'coalitions')
    scenario = load_scenario(Path(scenario_path) if scenario_path else config.directory / FIG7_SCENARIO, config)
    # The team file's robot types as data (capability_file renames their sensors for the bridge).
    team_file = config.directory / yaml.safe_load(Path(scenario.path).read_text())['team']
    types = yaml.safe_load(team_file.read_text())['robot_types']
    robot_types = {robot: caps.name for robot, caps in scenario.team.items()}
    placements = placements_from_poses({r: (p.x, p.y, p.heading_deg) for r, p in scenario.poses.items()}, robot_types)
    view = scenario.sensors['fiducial']
    sensors = SensorSettings(fiducial_fov_deg=view.fov_deg, fiducial_range_m=view.range_m)
    setup = AgentSetup(task=scenario.task.name, leaders=scenario.initiators, search_time_s=search_time_s,
                       loss_probability=loss, use_sim_time=True, seed=seed, timeout_s=240.0)
    log(f'[coalition-fig7 sim] {len(placements)} robots on the bridge, loss {loss:g}, search_time {search_time_s:g} s')
    result = run_session(run_dir / 'sim', config_dir, 'fig7_clusters', placements, types, sensors, setup,
                         sensor_names=FIG7_SENSOR_NAMES, log=None)
    if result.bag is None or not result.bag.exists():
        raise RuntimeError(f'fig7 sim: no bag ({result.message}); logs in {run_dir / "sim" / "logs"}')
    sim = fig7_sim_result(read_coalition_bag(result.bag), core['chosen'])
    results = {'experiment': 'coalition-fig7', 'mode': 'sim', 'loss_probability': loss, 'search_time_s': search_time_s,
               'exit_code': result.exit_code, 'table5_core': core['table5'], 'core_chosen': core['chosen'], **sim}
    results['acceptance'] = {
        'every_initiator_committed': all(r['state'] == 'committed' for r in sim['leaders']),
        'matches_core': all(r['matches_core'] for r in sim['leaders']),
        'no_robot_in_two_coalitions': not sim['conflicting_commitments']
        and all(len(c) <= 1 for c in sim['commitments'].values())}
    results['acceptance']['passed'] = (results['acceptance']['every_initiator_committed']
                                       and results['acceptance']['no_robot_in_two_coalitions'])
    for row in sim['leaders']:
        log(f'[coalition-fig7 sim] {row["robot"]}: {row["state"]} {", ".join(row["members"]) or "-"} cost '
            f'{row["cost"]} (core: {row["core_members"] and ", ".join(row["core_members"])} {row["core_cost"]}); '
            f'found {row["found_s"]} s, formed {row["formed_s"]} s')
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2))
    (run_dir / 'table5_sim.md').write_text(fig7_sim_markdown(results))
    plot_fig7_sim(scenario, results, run_dir / 'fig7_sim.png')
    return results


def fig7_sim_markdown(results: dict) -> str:
    lines = [f'Fig. 7 / Table V in simulation (schema_agent nodes, bridge fiducials, link paper_fig9, loss '
             f'{results["loss_probability"]:g}).', '',
             '| robot | possible (core) | executable (core, costs) | set up in simulation | cost | core cheapest | '
             'matches core | found (s) | formed (s) |', '|---|---|---|---|---|---|---|---|---|']
    table5 = {e['robot']: e for e in results['table5_core']}
    for row in results['leaders']:
        entry = table5.get(row['robot'], {})
        costs = ', '.join(f'{c:g}' for c in entry.get('executable_costs', []))
        lines.append(f'| {row["robot"]} | {entry.get("possible")} | {entry.get("executable")} ({costs or "-"}) | '
                     f'{", ".join(row["members"]) or row["state"]} | {row["cost"]} | '
                     f'{", ".join(row["core_members"] or [])} ({row["core_cost"]}) | {row["matches_core"]} | '
                     f'{row["found_s"]} | {row["formed_s"]} |')
    lines += ['', f'Commitments per robot (from the bag\'s statuses): {json.dumps(results["commitments"])}',
              f'Robots committed to two coalitions at once: {json.dumps(results["conflicting_commitments"]) or "none"}',
              f'Channel messages: {results["messages"]} logical ({json.dumps(results["kinds"])}) in '
              f'{results.get("ros_messages", 0)} ROS messages (batches; the loss probability applies per batch: '
              'a lost batch loses all its messages, which the retries re-send)',
              f'Acceptance: {json.dumps(results["acceptance"])}']
    return '\n'.join(lines) + '\n'


def plot_fig7_sim(scenario, results: dict, path: Path) -> None:
    """The poses and the coalitions the nodes set up (ellipse per coalition), with their costs."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.patches import Ellipse, Wedge
    from .experiments import _enclose
    colours = ('#d62728', '#2ca02c', '#e6b800', '#1f77b4', '#9467bd')
    fig, ax = plt.subplots(figsize=(9, 8))
    view = next(iter(scenario.sensors.values()))
    for robot, pose in scenario.poses.items():
        ax.add_patch(Wedge((pose.x, pose.y), view.range_m, pose.heading_deg - view.fov_deg / 2,
                           pose.heading_deg + view.fov_deg / 2, fc='grey', alpha=0.06, ec='grey', lw=0.5))
        ax.plot(pose.x, pose.y, 'o', ms=15, mfc='white', mec='black')
        ax.text(pose.x, pose.y, pose.label, ha='center', va='center', fontsize=9, fontweight='bold')
    for index, row in enumerate(results['leaders']):
        if row['state'] != 'committed':
            continue
        colour = colours[index % len(colours)]
        _enclose(ax, [scenario.poses[m] for m in row['members']], colour, Ellipse)
        pose = scenario.poses[row['robot']]
        ax.text(pose.x, pose.y - 1.6, f'cost {row["cost"]:g}', ha='center', color=colour, fontweight='bold')
    ax.set_aspect('equal')
    ax.autoscale()
    ax.margins(0.15)
    ax.grid(alpha=0.25)
    ax.set_title(f'Fig. 7(b) in simulation: coalitions set up by the schema_agent nodes '
                 f'(loss {results["loss_probability"]:g})', fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# === The demo ======================================================================================

def run_column_demo(config_dir: str | Path, run_dir: str | Path, robots: int = 3, search_time_s: float = 3.0,
                    log: Log = print):
    """scripts/demo's coalition scenario: a short column (Fig. 9 geometry, paper link model); the
    robot at the back forms its coalition through the robots ahead. Returns the ExperimentResult;
    coalition.json in ``run_dir`` summarises the bag."""
    config_dir, run_dir = Path(config_dir), Path(run_dir)
    config = load_column_config(config_dir / 'coalitions' / COLUMN_CONFIG)
    placements = column_placements(robots, config.spacing_m)
    setup = AgentSetup(leaders=(placements[-1].robot,), search_time_s=search_time_s, use_sim_time=True,
                       link_preset=config.link_preset, timeout_s=90.0)
    result = run_session(run_dir, config_dir, f'demo_column_{robots}', placements, COLUMN_TYPES, config.sensors,
                         setup, log=None)
    if result.bag is not None and result.bag.exists():
        summary = column_result(read_coalition_bag(result.bag), robots)
        summary.pop('counts', None)
        (Path(run_dir) / 'coalition.json').write_text(json.dumps(summary, indent=2))
        log(f'[demo coalitions] {summary["leader"]}: {summary["state"]} with {", ".join(summary["members"]) or "-"} '
            f'(cost {summary["cost"]}), formed {summary["formed_s"]} s after its search started')
    return result
