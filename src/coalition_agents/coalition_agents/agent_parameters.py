"""The ROS parameters of a schema_agent node: one table of descriptors (type, range, description)
and what the node builds from their start-up values (README "Coalition nodes: parameters").

Dynamic parameters (:data:`DYNAMIC`) are applied while the node runs: the node passes one applier
per name to :func:`declare_agent_parameters` (a ``set_parameters`` then changes its behaviour);
every other parameter is read-only (rclpy refuses a set), because the node builds something from
it once: the solution spaces (files, task), the channel (link model, retry policy, team), the
motor schemas' geometry, the life cycle (team_wait, exit_when_done).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from collab_tools.node_support import ConfigurationError
from collab_tools.parameters import NodeParameters

from .core.capabilities import capability_file_from_text, load_capability_file
from .core.errors import CoalitionError
from .core.link_model import PRESETS, LinkModel
from .core.reliable_channel import RetryPolicy
from .core.schemas import load_costs, load_library
from .core.tasks import load_tasks

FILES = ('capability_file', 'schemas_file', 'costs_file', 'tasks_file')
#: The two ways of giving the team's capabilities: a file (tracked config) or the document itself
#: (a team generated for one run reaches agents on any machine without a file). Exactly one.
CAPABILITY_SOURCES = ('capability_file', 'capabilities')
#: Parameters a running agent applies when they are set (each has an applier in the node).
DYNAMIC = ('max_speed', 'goal_tolerance', 'stream_rate', 'tick_period')

POSITIVE = {'low': 0.0, 'low_open': True}
NON_NEGATIVE = {'low': 0.0}


def _file_check(value: str) -> str | None:
    return None if Path(value).is_file() else f'no such file {value}'


def _optional_file_check(value: str) -> str | None:
    return _file_check(value) if value else None


#: name -> (default, description, constraints for NodeParameters.declare)
PARAMETERS: dict[str, tuple[Any, str, dict]] = {
    'capability_file': ('', 'team capability YAML file (config/coalitions/capabilities/*.yaml); '
                            'exactly one of capability_file and capabilities', {'check': _optional_file_check}),
    'capabilities': ('', 'the team capability document itself, as YAML text (the format of a capability file), '
                         'for a team that exists in no file on this machine; exactly one of capability_file and '
                         'capabilities', {}),
    'schemas_file': ('', 'schema library YAML (config/coalitions/schemas.yaml)',
                     {'required': True, 'check': _file_check}),
    'costs_file': ('', 'schema costs YAML (config/coalitions/costs.yaml)', {'required': True, 'check': _file_check}),
    'tasks_file': ('', 'tasks YAML (config/coalitions/tasks.yaml)', {'required': True, 'check': _file_check}),
    'task': ('none', "task name from tasks_file, or 'none' (a pure helper)", {}),
    'team_task': ('', "for task 'none': the task the team works on (its priors, helper MS)", {}),
    'link_preset': ('paper_fig9', 'link model preset of the channel', {'choices': sorted(PRESETS)}),
    'link_delay_mean': (-1.0, "one-way delay mean, s (normal, truncated at 0); -1 = the preset's", {'low': -1.0}),
    'link_delay_std': (-1.0, "one-way delay std, s; -1 = the preset's", {'low': -1.0}),
    'loss_probability': (0.0, 'probability that a batch on the channel is lost', {'low': 0.0, 'high': 1.0}),
    'seed': (-1, 'link model seed; -1 = fresh', {'low': -1}),
    'search_time': (3.0, 'sim s of search before negotiating the least-cost coalition at the latest', POSITIVE),
    'settle_time': (1.0, 'sim s the cheapest executable coalition must stay the cheapest before the leader '
                         'negotiates it (earlier than search_time)', POSITIVE),
    'reorder_window': (0.05, 'sim s: a channel message is re-sent once a message sent this much later to the same '
                             'robot was answered (fast retransmit); above the link delay spread', NON_NEGATIVE),
    'tail_timeout': (1.5, 'sim s: before a round trip to a robot is measured, a message with nothing later to prove '
                          'it lost is re-sent after this long without any answer from that robot (then the measured '
                          "timeout, >= 0.2 s; doubling up to 8 s); above a busy agent's processing lag", POSITIVE),
    'peer_timeout': (10.0, 'sim s: a robot that answers nothing for this long while it owes answers is given up '
                           '(its messages undelivered)', POSITIVE),
    'hold_seconds': (0.0, 'commitment hold time sent to helpers, s; 0 = until released', NON_NEGATIVE),
    'reading_timeout': (1.0, 'sim s a sensor report stays current', POSITIVE),
    'tick_period': (0.1, 'sim s between re-evaluations (sensor readings, deadlines, motor-schema commands); '
                         'dynamic', {'low': 0.0, 'low_open': True, 'high': 10.0}),
    'reasoning_slice': (0.01, 'wall s of reasoning per callback: the rest continues in the next one, so channel '
                              'messages, sensor reports and timers (of every agent in the process) run in between',
                        POSITIVE),
    'team_wait': (10.0, 'sim s to wait for every teammate on the channel before searching', POSITIVE),
    'stream_rate': (5.0, 'Hz (sim) at which a helper streams the information it serves; dynamic',
                    {'low': 0.0, 'low_open': True, 'high': 1000.0}),
    'stream_timeout': (1.0, 'sim s after which a streamed value is stale', POSITIVE),
    'reform_timeout': (0.0, 'sim s a coalition may stay infeasible before the leader re-forms it (0 = never: it '
                            'keeps the coalition)', NON_NEGATIVE),
    'max_reforms': (3, 'how often a leader re-forms before it reports failed', {'low': 0}),
    'drive': (False, 'run the motor schemas on cmd_vel (leader: the task MS; helper: maintain_relative_position)', {}),
    'goal_position': ([0.0, 0.0], 'x y (m) of the a-priori F_G(goal) the task MS uses', {'length': 2}),
    'max_speed': (0.4, 'm/s: navigate and follow speed limit; dynamic', {'low': 0.0, 'low_open': True, 'high': 5.0}),
    'box_standoff': (0.55, 'm: box centre to robot centre when pushing (half box depth + radius)', POSITIVE),
    'push_offset': (0.0, 'm: where along the box back face the leader pushes (+ = left)', {}),
    'goal_tolerance': (0.25, 'm: navigation / box distance to the goal that completes the task; dynamic', POSITIVE),
    'exit_after': ([''], "with exit_when_done: exit only once these robots' agents report their task completed or "
                         "failed too (an experiment's last leader)", {}),
    'task_time_limit': (0.0, 'sim s after the search start a driving leader gives up (0 = none)', NON_NEGATIVE),
    'exit_when_done': (False, 'exit once the coalition is set up (or failed) / the helper released', {}),
}


def declare_agent_parameters(params: NodeParameters, appliers: Mapping[str, Callable[[Any], None]]) -> dict:
    """Declare every parameter of :data:`PARAMETERS` (those of :data:`DYNAMIC` with their applier)
    and return the start-up values by name (ConfigurationError names a bad one)."""
    missing = [name for name in DYNAMIC if name not in appliers]
    if missing:
        raise ValueError(f'no applier for the dynamic parameter(s) {", ".join(missing)}')
    values = {}
    for name, (default, description, constraints) in PARAMETERS.items():
        values[name] = params.declare(name, default, description, **constraints,
                                      on_change=appliers[name] if name in DYNAMIC else None)
    values['exit_after'] = [robot for robot in values['exit_after'] if robot]
    return values


def capability_source(values: Mapping[str, Any]) -> str:
    """The parameter that gives the team's capabilities: capability_file or capabilities (exactly one)."""
    given = [name for name in CAPABILITY_SOURCES if values[name]]
    if len(given) != 1:
        raise ConfigurationError('parameter capability_file / capabilities: give exactly one of them (got '
                                 + ('both' if given else 'neither') + ')')
    return given[0]


def load_files(values: Mapping[str, Any]):
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


def task_named(tasks: Mapping, name: str, parameter: str):
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
