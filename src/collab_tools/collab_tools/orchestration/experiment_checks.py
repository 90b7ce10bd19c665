"""Everything an experiment file names, checked before any node starts (``scripts/orchestrate`` exits 2).

:func:`check_experiment` goes beyond :func:`~.experiment.load_experiment`'s structure: every node's
package and executable in the ament index (as ``ros2 run`` would find them), its parameter files,
every message/service type of ``until`` and ``after_start`` resolved by import (no node needed)
with the fields their ``equals``/``at_least``/``request`` name, ``stop``/``exit`` naming a node
of the file, and the numbers (timeouts, sleeps). Each error is an ExperimentError whose message
starts with the field's dotted path.
"""
from __future__ import annotations

import difflib
import importlib
from pathlib import Path
from typing import Any

from ..core.fields import read_yaml_file
from ..ros_interfaces import import_interface
from .experiment import ExperimentError, _MessageFields, _network, _substitute, load_experiment, parse_node
from .node_process import NodeSpec, find_executable

STEP_KINDS = ('wait_for_message', 'call', 'stop', 'sleep')


def _mapping(value: Any, path: str) -> dict:
    if not isinstance(value, dict):
        raise ExperimentError(f'{path}: must be a mapping (got {type(value).__name__})')
    return value


def _text(spec: dict, key: str, path: str) -> str:
    value = spec.get(key)
    if not isinstance(value, str) or not value:
        raise ExperimentError(f'{path}.{key}: missing required field (a non-empty string)')
    return value


def _positive(value: Any, path: str, allow_zero: bool = False) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0 or (value == 0 and not allow_zero):
        raise ExperimentError(f'{path}: must be a number of seconds {">= 0" if allow_zero else "> 0"} (got {value!r})')


def _interface(type_name: Any, path: str, kind: str):
    if not isinstance(type_name, str):
        raise ExperimentError(f'{path}: missing required field (a {kind} type such as std_msgs/msg/Bool)')
    try:
        interface = import_interface(type_name)
    except ValueError as error:
        raise ExperimentError(f'{path}: {error}{_close_names(type_name)}') from None
    if kind == 'service' and not hasattr(interface, 'Request'):
        raise ExperimentError(f"{path}: '{type_name}' is not a service type")
    if kind == 'message' and not hasattr(interface, 'get_fields_and_field_types'):
        raise ExperimentError(f"{path}: '{type_name}' is not a message type")
    return interface


def _close_names(type_name: str) -> str:
    """' (did you mean std_msgs/msg/Bool?)' when the package has a type of a similar name."""
    parts = type_name.split('/')
    if len(parts) != 3:
        return ''
    try:
        module = importlib.import_module(f'{parts[0]}.{parts[1]}')
    except ImportError:
        return ''
    close = difflib.get_close_matches(parts[2], [n for n in dir(module) if n[:1].isupper()], n=3)
    return f" (did you mean {' or '.join(f'{parts[0]}/{parts[1]}/{n}' for n in close)}?)" if close else ''


def _fields_exist(message_type, fields: Any, path: str) -> None:
    """Every dotted field of ``fields`` exists on ``message_type`` (nested messages followed)."""
    for dotted in _mapping(fields, path):
        current = message_type
        for part in str(dotted).split('.'):
            known = current.get_fields_and_field_types() if hasattr(current, 'get_fields_and_field_types') else {}
            if part not in known:
                raise ExperimentError(f"{path}.{dotted}: {message_type.__name__} has no field {part!r} "
                                      f"(fields: {', '.join(known) or 'none'})")
            current = type(getattr(current(), part))


def _check_message_wait(spec: Any, path: str, node_names: set[str]) -> None:
    spec = _mapping(spec, path)
    _text(spec, 'topic', path)
    message_type = _interface(spec.get('type'), f'{path}.type', 'message')
    for key in ('equals', 'at_least'):
        if key in spec:
            _fields_exist(message_type, spec[key], f'{path}.{key}')
    if 'timeout' in spec:
        _positive(spec['timeout'], f'{path}.timeout')


def _check_follow(entry: Any, path: str) -> None:
    entry = _mapping(entry, path)
    unknown = sorted(set(entry) - {'topic', 'type', 'say', 'when', 'latched'})
    if unknown:
        raise ExperimentError(f"{path}.{unknown[0]}: unknown field (allowed: topic, type, say, when, latched)")
    _text(entry, 'topic', path)
    message_type = _interface(entry.get('type'), f'{path}.type', 'message')
    if 'when' in entry:
        _fields_exist(message_type, entry['when'], f'{path}.when')
    say = _text(entry, 'say', path)
    try:
        say.format_map(_MessageFields(message_type()))
    except (AttributeError, KeyError, IndexError, ValueError) as error:
        raise ExperimentError(f'{path}.say: {say!r} does not fit {message_type.__name__} ({error})') from None


def _check_step(step: Any, path: str, node_names: set[str]) -> None:
    step = _mapping(step, path)
    kinds = [k for k in step if k in STEP_KINDS]
    if len(step) != 1 or len(kinds) != 1:
        raise ExperimentError(f"{path}: expected exactly one of {', '.join(STEP_KINDS)} (got {', '.join(step)})")
    kind, spec = kinds[0], step[kinds[0]]
    where = f'{path}.{kind}'
    if kind == 'wait_for_message':
        _check_message_wait(spec, where, node_names)
    elif kind == 'call':
        spec = _mapping(spec, where)
        _text(spec, 'service', where)
        service = _interface(spec.get('type'), f'{where}.type', 'service')
        if 'request' in spec:
            _fields_exist(service.Request, spec['request'], f'{where}.request')
        if 'timeout' in spec:
            _positive(spec['timeout'], f'{where}.timeout')
    elif kind == 'stop':
        if str(spec) not in node_names:
            raise ExperimentError(f"{where}: no node named '{spec}' (nodes: {', '.join(sorted(node_names))})")
    else:
        _positive(spec, where, allow_zero=True)


def _check_node(spec: NodeSpec, path: str, experiment_dir: Path) -> None:
    try:
        find_executable(spec.package, spec.executable)
    except FileNotFoundError as error:
        raise ExperimentError(f'{path}: {error}') from None
    for index, entry in enumerate(spec.parameters):
        if isinstance(entry, str) and '{run_dir}' not in entry:
            file = Path(entry) if Path(entry).is_absolute() else experiment_dir / entry
            # read as every input file is (rcl would block on a FIFO, or end the node on a bad file)
            read_yaml_file(file, f'{path}.parameters[{index}]: parameter file', ExperimentError)


def check_experiment(path: str | Path, config_dir: str | Path, host: str | None = None) -> dict:
    """The experiment file's data once every check passed (ExperimentError naming the field otherwise).
    Only the nodes this machine starts are looked up (``host``: that host's; else all but remote ones)."""
    path = Path(path)
    data = load_experiment(path)
    _, hosts = _network(data)
    if host is not None and host not in hosts:
        raise ExperimentError(f"--host {host}: the experiment defines no such host (hosts: {', '.join(hosts) or 'none'})")
    if 'timeout' in data:
        _positive(data['timeout'], 'experiment.timeout')
    names = {'config': str(config_dir)}
    nodes = [_substitute(entry, names) for entry in data['nodes']]
    specs = [parse_node(entry, f'experiment.nodes[{i}]') for i, entry in enumerate(nodes)]
    remote = {name for name, h in hosts.items() if h.remote}
    for index, spec in enumerate(specs):
        if spec.host is not None and spec.host not in hosts:
            raise ExperimentError(f"experiment.nodes[{index}].host: '{spec.host}' is not defined "
                                  f"(hosts: {', '.join(hosts) or 'none'})")
        here = spec.host == host if host is not None else spec.host not in remote
        if here:
            _check_node(spec, f'experiment.nodes[{index}] ({spec.label})', path.parent)
    node_names = {spec.label for spec in specs}
    steps = data.get('after_start') or []
    if not isinstance(steps, list):
        raise ExperimentError('experiment.after_start: must be a list of steps')
    for index, step in enumerate(steps):
        _check_step(step, f'experiment.after_start[{index}]', node_names)
    follow = data.get('follow') or []
    if not isinstance(follow, list):
        raise ExperimentError('experiment.follow: must be a list of {topic, type, say[, when, latched]}')
    for index, entry in enumerate(follow):
        _check_follow(entry, f'experiment.follow[{index}]')
    kind, spec = next(iter(data['until'].items()))
    if kind == 'message':
        _check_message_wait(spec, 'experiment.until.message', node_names)
    elif kind == 'exit':
        if str(spec) not in node_names:
            raise ExperimentError(f"experiment.until.exit: no node named '{spec}' "
                                  f"(nodes: {', '.join(sorted(node_names))})")
    else:
        _positive(spec, 'experiment.until.seconds')
    return data
