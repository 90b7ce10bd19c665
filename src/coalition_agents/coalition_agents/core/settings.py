"""A schema_agent's settings: the parameter table (:data:`AGENT_SETTINGS`, pure data) and what an
agent builds from the validated start values (:class:`AgentSettings`: the loaded files, the team,
the tasks, the channel's link model and retry policy), with the checks across parameters.

The node declares :data:`AGENT_SETTINGS` (``NodeParameters.declare_schema``); the dynamic ones
(:data:`DYNAMIC`) are applied while it runs (a ``set_parameters`` changes its behaviour), every
other one is read-only because the agent builds something from it once: the solution spaces
(files, task), the channel (link model, retry policy, team), the motor schemas' geometry, the life
cycle (team_wait, exit_when_done). Every error is a ConfigurationError naming the parameter, so
a node stops with exit code 2; unit tests check them without starting a node.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.settings import Setting, SettingsSchema

from .capabilities import CapabilityFile, RobotCapabilities, capability_file_from_text, load_capability_file
from .errors import CoalitionError
from .schemas import Costs, SchemaLibrary, load_costs, load_library
from .tasks import Task, load_tasks
from .transport.link_model import PRESETS, LinkModel
from .transport.liveness import PeerLiveness
from .transport.retry import RetryPolicy

FILES = ('capability_file', 'schemas_file', 'costs_file', 'tasks_file')
#: The two ways of giving the team's capabilities: a file (tracked config) or the document itself
#: (a team generated for one run reaches agents on any machine without a file). Exactly one.
CAPABILITY_SOURCES = ('capability_file', 'capabilities')
#: Parameters a running agent applies when they are set (each has an applier in the node).
DYNAMIC = ('max_speed', 'goal_tolerance', 'stream_rate', 'tick_period')
#: The bridge sensors an agent can switch and read (the node maps each to its topic).
BRIDGE_SENSORS = ('fiducial', 'gps', 'laser', 'bumper')
#: Motor schemas a driving agent can run (a task's ``motor_schema``; :mod:`.coalition_runner`).
MOTOR_SCHEMAS = ('navigate', 'push_box_cooperatively')

POSITIVE = {'low': 0.0, 'low_open': True}
NON_NEGATIVE = {'low': 0.0}


def _file_check(value: str) -> str | None:
    return None if Path(value).is_file() else f'no such file {value}'


def _optional_file_check(value: str) -> str | None:
    return _file_check(value) if value else None


def _setting(name: str, default: Any, description: str, **constraints: Any) -> Setting:
    return Setting(name, default, description, dynamic=name in DYNAMIC, **constraints)


AGENT_SETTINGS = SettingsSchema(
    _setting('capability_file', '', 'team capability YAML file (config/coalitions/capabilities/*.yaml); '
             'exactly one of capability_file and capabilities', check=_optional_file_check),
    _setting('capabilities', '', 'the team capability document itself, as YAML text (the format of a capability '
             'file), for a team that exists in no file on this machine; exactly one of capability_file and '
             'capabilities'),
    _setting('schemas_file', '', 'schema library YAML (config/coalitions/schemas.yaml)', required=True,
             check=_file_check),
    _setting('costs_file', '', 'schema costs YAML (config/coalitions/costs.yaml)', required=True, check=_file_check),
    _setting('tasks_file', '', 'tasks YAML (config/coalitions/tasks.yaml)', required=True, check=_file_check),
    _setting('task', 'none', "task name from tasks_file, or 'none' (a pure helper)"),
    _setting('team_task', '', "for task 'none': the task the team works on (its priors, helper MS)"),
    _setting('link_preset', 'paper_fig9', 'link model preset of the channel', choices=sorted(PRESETS)),
    _setting('link_delay_mean', -1.0, "one-way delay mean, s (normal, truncated at 0); -1 = the preset's", low=-1.0),
    _setting('link_delay_std', -1.0, "one-way delay std, s; -1 = the preset's", low=-1.0),
    _setting('loss_probability', 0.0, 'probability that a batch on the channel is lost', low=0.0, high=1.0),
    _setting('seed', -1, 'link model seed; -1 = fresh', low=-1),
    _setting('search_time', 3.0, 'sim s of search before negotiating the least-cost coalition at the latest',
             **POSITIVE),
    _setting('settle_time', 1.0, 'sim s the cheapest executable coalition must stay the cheapest before the leader '
             'negotiates it (earlier than search_time)', **POSITIVE),
    _setting('reorder_window', 0.05, 'sim s: a channel message is re-sent once a message sent this much later to '
             'the same robot was answered (fast retransmit); above the link delay spread', **NON_NEGATIVE),
    _setting('tail_timeout', 1.5, 'sim s: before a round trip to a robot is measured, a message with nothing later '
             'to prove it lost is re-sent after this long without any answer from that robot (then the measured '
             "timeout, >= 0.2 s; doubling up to 8 s); above a busy agent's processing lag", **POSITIVE),
    _setting('peer_timeout', 10.0, 'sim s: a robot that answers nothing for this long while it owes answers is '
             'given up (its messages undelivered)', **POSITIVE),
    _setting('hold_seconds', 0.0, 'commitment hold time sent to helpers, s; 0 = until released', **NON_NEGATIVE),
    _setting('liveness_timeout', 5.0, 'sim s: a teammate this robot works with (its leader, its helpers, the helpers '
             'it negotiates with) that sends nothing for this long is presumed dead (a helper releases its '
             'commitment, a leader re-forms without it); 0 = never; at least 2 x heartbeat_period',
             **NON_NEGATIVE),
    _setting('heartbeat_period', 1.0, 'sim s: with nothing else sent for this long to a teammate it works with, an '
             'empty batch (heartbeat) goes to it', low=0.0, low_open=True, high=60.0),
    _setting('reading_timeout', 1.0, 'sim s a sensor report stays current', **POSITIVE),
    _setting('tick_period', 0.1, 'sim s between re-evaluations (sensor readings, deadlines, motor-schema commands); '
             'dynamic', low=0.0, low_open=True, high=10.0),
    _setting('reasoning_slice', 0.01, 'wall s of reasoning per callback: the rest continues in the next one, so '
             'channel messages, sensor reports and timers (of every agent in the process) run in between',
             **POSITIVE),
    _setting('team_wait', 10.0, 'sim s to wait for every teammate on the channel before searching', **POSITIVE),
    _setting('stream_rate', 5.0, 'Hz (sim) at which a helper streams the information it serves; dynamic',
             low=0.0, low_open=True, high=1000.0),
    _setting('stream_timeout', 1.0, 'sim s after which a streamed value is stale', **POSITIVE),
    _setting('reform_timeout', 0.0, 'sim s a coalition may stay infeasible before the leader re-forms it (0 = '
             'never: it keeps the coalition)', **NON_NEGATIVE),
    _setting('max_reforms', 3, 'how often a leader re-forms before it reports failed', low=0),
    _setting('drive', False, 'run the motor schemas on cmd_vel (leader: the task MS; helper: '
             'maintain_relative_position)'),
    _setting('goal_position', [0.0, 0.0], 'x y (m) of the a-priori F_G(goal) the task MS uses', length=2),
    _setting('max_speed', 0.4, 'm/s: navigate and follow speed limit; dynamic', low=0.0, low_open=True, high=5.0),
    _setting('box_standoff', 0.55, 'm: box centre to robot centre when pushing (half box depth + radius)',
             **POSITIVE),
    _setting('push_offset', 0.0, 'm: where along the box back face the leader pushes (+ = left)'),
    _setting('goal_tolerance', 0.25, 'm: navigation / box distance to the goal that completes the task; dynamic',
             **POSITIVE),
    _setting('exit_after', [''], "with exit_when_done: exit only once these robots' agents report their task "
             "completed or failed too (an experiment's last leader)"),
    _setting('task_time_limit', 0.0, 'sim s after the search start a driving leader gives up (0 = none)',
             **NON_NEGATIVE),
    _setting('aimed_sensors', [''], "sensors of this robot that must be aimed at one referent at a time (a pan-tilt "
             "camera): two coalitions that need one on different referents conflict; the others' one reading is "
             "shared by every coalition it serves"),
    _setting('exit_when_done', False, 'exit once the coalition is set up (or failed) / the helper released'),
)


def capability_source(values: Mapping[str, Any]) -> str:
    """The parameter that gives the team's capabilities: capability_file or capabilities (exactly one)."""
    given = [name for name in CAPABILITY_SOURCES if values[name]]
    if len(given) != 1:
        raise ConfigurationError('parameter capability_file / capabilities: give exactly one of them (got '
                                 + ('both' if given else 'neither') + ')')
    return given[0]


def load_files(values: Mapping[str, Any]) -> tuple[SchemaLibrary, Costs, dict[str, Task], CapabilityFile]:
    """(library, costs, tasks, capability file) of the file parameters and the ``capabilities`` text;
    a problem names its parameter."""
    source = capability_source(values)
    try:
        library = load_library(values['schemas_file'])
    except (CoalitionError, ValueError, OSError) as exc:
        raise ConfigurationError(f'parameter schemas_file: {exc}') from None
    loaded = {}
    capabilities = ((source, lambda f: load_capability_file(f, library)) if source == 'capability_file'
                    else (source, lambda text: capability_file_from_text(text, library)))
    for name, loader in (('costs_file', load_costs), ('tasks_file', lambda f: load_tasks(f, library)),
                         capabilities):
        try:
            loaded[name] = loader(values[name])
        except (CoalitionError, ValueError, OSError) as exc:
            raise ConfigurationError(f'parameter {name}: {exc}') from None
    return library, loaded['costs_file'], loaded['tasks_file'], loaded[source]


def task_named(tasks: Mapping[str, Task], name: str, parameter: str) -> Task:
    if name not in tasks:
        raise ConfigurationError(f"parameter {parameter}: unknown task '{name}' (known: {', '.join(tasks)}"
                                 + (", or 'none'" if parameter == 'task' else '') + ')')
    return tasks[name]


def link_model(values: Mapping[str, Any]) -> LinkModel:
    """The channel's link model: the preset, its delay overridden by link_delay_mean/std >= 0."""
    seed = values['seed']
    data: dict = {'preset': values['link_preset'], 'loss_probability': float(values['loss_probability']),
                  'seed': None if seed == -1 else seed}
    mean, std = values['link_delay_mean'], values['link_delay_std']
    try:
        if mean >= 0 or std >= 0:
            base = LinkModel.from_dict({'preset': data['preset']}).delay
            data['delay'] = {'distribution': 'normal', 'mean_s': float(mean) if mean >= 0 else base.mean_s,
                             'std_s': float(std) if std >= 0 else base.std_s}
        return LinkModel.from_dict(data)
    except (CoalitionError, ValueError, TypeError, AttributeError) as exc:
        raise ConfigurationError(f'parameter {str(exc).replace("link.", "link_", 1)}') from None


def retry_policy(values: Mapping[str, Any]) -> RetryPolicy:
    tail, peer = values['tail_timeout'], values['peer_timeout']
    return RetryPolicy(reorder_window_s=values['reorder_window'], tail_timeout_s=tail,
                       max_timeout_s=max(8.0, tail), peer_timeout_s=peer, message_lifetime_s=max(30.0, peer))


@dataclass(frozen=True)
class AgentSettings:
    """One robot's agent, built from validated parameter values (:meth:`build`)."""

    robot: str
    values: Mapping[str, Any]
    library: SchemaLibrary
    costs: Costs
    tasks: Mapping[str, Task]
    team: Mapping[str, RobotCapabilities]
    #: the robot's own task (None: a pure helper) and the task the team works on
    task: Task | None
    team_task: Task | None
    link: LinkModel
    retry: RetryPolicy

    @classmethod
    def build(cls, values: Mapping[str, Any], robot: str, where: str = '') -> 'AgentSettings':
        """Validate ``values`` (parameter name -> value; missing ones take their default) for
        ``robot`` and load what they name; ``where`` names the robot's origin in an error
        (e.g. ``namespace /robot_1``). ConfigurationError names the parameter."""
        values = AGENT_SETTINGS.validate(values, ignore=('robot', 'team_namespace'))
        values['exit_after'] = [name for name in values['exit_after'] if name]
        values['aimed_sensors'] = list(dict.fromkeys(name for name in values['aimed_sensors'] if name))
        library, costs, tasks, capability_file = load_files(values)
        source = capability_source(values)
        team_of = "the capability file's" if source == 'capability_file' else "parameter capabilities'"
        team = dict(capability_file.robots)
        if robot not in team:
            raise ConfigurationError(f"{where or 'robot'}: robot '{robot}' is not in {team_of} robots "
                                     f"({', '.join(team) or 'none'})")
        for sensor in team[robot].sensors:
            if sensor.sensor not in BRIDGE_SENSORS:
                raise ConfigurationError(
                    f"parameter {source}: robot {robot}'s sensor '{sensor.sensor}' is not a bridge sensor "
                    f"(allowed: {', '.join(BRIDGE_SENSORS)})")
        own = [sensor.sensor for sensor in team[robot].sensors]
        aimed = [name for name in values['aimed_sensors'] if name not in own]
        if aimed:
            raise ConfigurationError(f"parameter aimed_sensors: {aimed[0]!r} is not a sensor of {robot} "
                                     f"({', '.join(own) or 'none'})")
        task = None if values['task'] == 'none' else task_named(tasks, values['task'], 'task')
        team_task = task_named(tasks, values['team_task'], 'team_task') if values['team_task'] else None
        if task is None and team_task is None:
            raise ConfigurationError("parameter team_task: required when task is 'none' (the task the team works "
                                     f"on: {', '.join(tasks)})")
        link = link_model(values)
        if 0 < values['liveness_timeout'] < 2 * values['heartbeat_period']:
            raise ConfigurationError(f"parameter liveness_timeout: {values['liveness_timeout']:g} s is below twice "
                                     f"heartbeat_period ({values['heartbeat_period']:g} s): a live teammate whose "
                                     'heartbeat is late would be presumed dead')
        if values['drive'] and task is not None and task.motor_schema not in MOTOR_SCHEMAS:
            raise ConfigurationError(f"parameter drive: task {values['task']}'s motor schema {task.motor_schema} has "
                                     f"no implementation here (implemented: {', '.join(MOTOR_SCHEMAS)})")
        unknown = [name for name in values['exit_after'] if name not in team]
        if unknown:
            raise ConfigurationError(f"parameter exit_after: {unknown[0]!r} is not in {team_of} robots "
                                     f"({', '.join(team)})")
        return cls(robot, values, library, costs, tasks, team, task, team_task, link, retry_policy(values))

    def __getitem__(self, name: str) -> Any:
        """A validated start value by parameter name."""
        return self.values[name]

    def liveness(self) -> PeerLiveness:
        """The channel's view of its teammates' sessions and silence (liveness_timeout, heartbeat_period)."""
        return PeerLiveness(self.robot, self.values['liveness_timeout'], self.values['heartbeat_period'],
                            self.retry.stall_s)

    @property
    def task_name(self) -> str:
        return self.values['task']

    @property
    def team_motor_schema(self) -> str:
        return (self.task if self.task is not None else self.team_task).motor_schema  # type: ignore[union-attr]

    def solution_cache_key(self) -> tuple[str, str]:
        """Agents with the same schema library and costs files may share a solution-space cache."""
        return (str(Path(self.values['schemas_file']).resolve()), str(Path(self.values['costs_file']).resolve()))
