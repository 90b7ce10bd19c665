"""Experiments described in YAML, run by an orchestration session.

    name: demo_mobile
    timeout: 120                 # wall-clock seconds for the completion condition
    record: {bag: demo, topics: []}     # optional; empty topics = everything;
                                        # storage_preset: zstd_fast (rosbag2's MCAP presets)
                                        # rates: {/clock: 500} (Hz: the recorder's queue depths)
                                        # analysis_topics: [...] (lost messages fail the run, exit 5;
                                        # default: every recorded topic)
                                        # use_sim_time: false (stamp on the wall clock; default true)
    nodes:
      - {package: pybullet_bridge, executable: pybullet_bridge, use_sim_time: false,
         parameters: ['{config}/params/pybullet_bridge.yaml', {scenario: '{config}/scenarios/demo_mobile.yaml'}]}
    after_start:                 # optional steps once every node is up
      - {wait_for_message: {topic: /clock, type: rosgraph_msgs/msg/Clock}}
      - {call: {service: /pybullet_bridge/pause, type: std_srvs/srv/SetBool, request: {data: false}}}
      # a message whose fields equal / are at least the given values, then stop a node (by name):
      # - {wait_for_message: {topic: /roles/channel, type: role_interfaces/msg/ProcessRole,
      #                       equals: {robot: burger_1}, at_least: {version: 5}}}
      # - {stop: role_player_burger_1}
    follow:                      # optional: a console line per message as the run goes (rounds, arrivals)
      - {topic: /guidance, type: sgcm_interfaces/msg/Guidance, say: 'round {round}: {status}'}
      #  say: str.format with the message's fields ({leader_move.colour}); when: {field: value} filters;
      #  a line is printed once (repeats of the same text are dropped)
    until:                       # one of:
      message: {topic: /scripted_driver/done, type: std_msgs/msg/Bool, latched: true, equals: {data: true}}
      # exit: node_name
      # seconds: 10.0

Strings may use {config} (the config/ directory) and {run_dir}.

Where nodes run and how they find each other (all optional; see orchestration.network):

    namespace: /sim1             # every node under /sim1; /clock, /tf, /tf_static remapped into it;
                                 # topics in after_start/until resolve against it
    discovery: {range: SUBNET}   # LOCALHOST (default) | SUBNET | OFF, static_peers, or server: HOST:PORT
    domain_id: 42                # fixed ROS_DOMAIN_ID, shared with the experiment's other parts (and any
                                 # other session that fixes it); default: an exclusive free one
    discovery_timeout: 30        # s for every node to appear in the graph (else exit 4)
    hosts: {arm_b: {netns: sgcm_b}, robot2: remote}
    nodes:
      - {package: sgcm, executable: follower_executor, namespace: /follower_arm, host: arm_b, ...}

`scripts/orchestrate FILE --host robot2` on robot2 starts only robot2's nodes (same file,
same domain_id) and runs until they exit or Ctrl-C.

SROS2 (optional; see orchestration.security): every node with its enclave from the keystore

    security: {keystore: /path/to/keystore, strategy: Enforce}   # or Permissive
"""

import re
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..core.errors import ConfigurationError
from ..core.fields import Fields, read_yaml_file, require_list, require_mapping
from ..names import check_namespace
from .network import Discovery, NetworkConfigError, parse_hosts
from .node_process import NodeSpec
from .security import ORCHESTRATOR_ENCLAVE, Security, SecurityConfigError
from .session import NodeExitedError, NodesNotDiscovered, Session

NODE_FIELDS = {'package', 'executable', 'name', 'namespace', 'parameters', 'remappings',
               'arguments', 'use_sim_time', 'log_level', 'required', 'host'}
TOP_FIELDS = {'name', 'description', 'timeout', 'record', 'nodes', 'after_start', 'until',
              'namespace', 'discovery', 'domain_id', 'discovery_timeout', 'hosts', 'follow', 'security'}
DEFAULT_DISCOVERY_TIMEOUT = 30.0
RECORDER = NodeSpec('collab_tools', 'bag_recorder', name='bag_recorder')


class ExperimentError(ConfigurationError):
    """An experiment file field that cannot work; the message starts with its dotted path."""


@dataclass
class SessionRunResult:
    run_dir: Path
    exit_code: int
    condition_met: bool
    bag: Path | None
    message: str


def _substitute(value: Any, names: dict[str, str]) -> Any:
    if isinstance(value, str):
        for key, replacement in names.items():
            value = value.replace('{' + key + '}', replacement)
        return value
    if isinstance(value, list):
        return [_substitute(v, names) for v in value]
    if isinstance(value, dict):
        return {k: _substitute(v, names) for k, v in value.items()}
    return value


def _require_mapping(value, path: str) -> dict:
    return dict(require_mapping(value, path, ExperimentError))


def _check_fields(mapping: dict, allowed: set[str], path: str) -> None:
    Fields(mapping, path, sorted(allowed), ExperimentError)


def parse_node(entry, path: str) -> NodeSpec:
    entry = _require_mapping(entry, path)
    _check_fields(entry, NODE_FIELDS, path)
    for field in ('package', 'executable'):
        if not isinstance(entry.get(field), str) or not entry[field]:
            raise ExperimentError(f'{path}.{field}: missing required field')
    parameters = entry.get('parameters', [])
    if not isinstance(parameters, list) or not all(isinstance(p, (str, dict)) for p in parameters):
        raise ExperimentError(f'{path}.parameters: must be a list of files and mappings')
    return NodeSpec(package=entry['package'], executable=entry['executable'],
                    name=entry.get('name'), namespace=entry.get('namespace'),
                    parameters=parameters, remappings=entry.get('remappings', {}),
                    arguments=entry.get('arguments', []),
                    use_sim_time=bool(entry.get('use_sim_time', True)),
                    log_level=entry.get('log_level'), required=bool(entry.get('required', True)),
                    host=entry.get('host'))


def _field(msg, dotted: str):
    for part in dotted.split('.'):
        msg = getattr(msg, part)
    return msg


def _matches(msg, expected: dict, at_least: dict | None = None) -> bool:
    """Every field in ``expected`` equals its value and every field in ``at_least`` is >= its value."""
    return (all(_field(msg, name) == value for name, value in expected.items())
            and all(_field(msg, name) >= value for name, value in (at_least or {}).items()))


def load_experiment(path: Path) -> dict:
    data = read_yaml_file(path, 'experiment file', ExperimentError)
    data = _require_mapping(data, 'experiment')
    _check_fields(data, TOP_FIELDS, 'experiment')
    if not isinstance(data.get('name'), str):
        raise ExperimentError('experiment.name: missing required field')
    if not isinstance(data.get('nodes'), list) or not data['nodes']:
        raise ExperimentError('experiment.nodes: must list at least one node')
    until = _require_mapping(data.get('until', {}), 'experiment.until')
    if len(until) != 1 or next(iter(until)) not in ('message', 'exit', 'seconds'):
        raise ExperimentError('experiment.until: exactly one of message, exit, seconds')
    problem = check_namespace(data.get('namespace', '/'))
    if problem:
        raise ExperimentError(f'experiment.namespace: {problem}')
    domain_id = data.get('domain_id')
    if domain_id is not None and (isinstance(domain_id, bool) or not isinstance(domain_id, int)
                                  or not 0 <= domain_id <= 232):
        raise ExperimentError(f'experiment.domain_id: must be an integer in [0, 232] (got {domain_id!r})')
    timeout = data.get('discovery_timeout', DEFAULT_DISCOVERY_TIMEOUT)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not 0 < timeout <= 3600:
        raise ExperimentError('experiment.discovery_timeout: must be a number of seconds in (0, 3600]')
    _network(data)  # checked here; the file's data stays plain (callers edit and re-dump it)
    _security(data)
    return data


def _security(data: dict) -> Security | None:
    try:
        return Security.parse(data.get('security'), 'experiment.security')
    except SecurityConfigError as error:
        raise ExperimentError(str(error)) from None


def _network(data: dict) -> tuple[Discovery, dict]:
    try:
        return (Discovery.parse(data.get('discovery'), 'experiment.discovery'),
                parse_hosts(data.get('hosts'), 'experiment.hosts'))
    except NetworkConfigError as error:
        raise ExperimentError(str(error)) from None


def run_experiment(path: Path, config_dir: Path, run_dir: Path | None = None,
                   overrides: dict[str, dict] | None = None, log=print,
                   host: str | None = None, security: Security | None = None,
                   on_running=None) -> SessionRunResult:
    """Run the experiment; every node's log and the bag end up in the run dir.

    host: run only that host's part (its nodes, until they exit or Ctrl-C) -- on a remote host.
    security: SROS2 for every node (replaces the file's ``security``). on_running: called with the
    session once every node is discovered (scripts/tools/sros2_keystore.py watches the graph).
    """
    from .experiment_checks import check_experiment  # every field, before anything starts (exit 2)

    data = check_experiment(path, config_dir, host)
    discovery, hosts = _network(data)
    if host is not None and host not in hosts:
        raise ExperimentError(f"--host {host}: the experiment defines no such host "
                              f"(hosts: {', '.join(hosts) or 'none'})")
    log = log or (lambda _text: None)
    specs = [parse_node(entry, f'experiment.nodes[{i}]') for i, entry in enumerate(data['nodes'])]
    for spec in specs:
        if spec.host is not None and spec.host not in hosts:
            raise ExperimentError(f"experiment.nodes: {spec.label}: host '{spec.host}' is not defined "
                                  f"(hosts: {', '.join(hosts) or 'none'})")
    session = Session(data['name'] + (f'-{host}' if host else ''), run_dir=run_dir, log=log,
                      domain_id=data.get('domain_id'), namespace=data.get('namespace', '/'),
                      discovery=discovery, hosts=hosts,
                      # A fixed domain is where the experiment's parts (and other runs) meet.
                      share_domain=data.get('domain_id') is not None,
                      security=security or _security(data))
    names = {'config': str(config_dir), 'run_dir': str(session.run_dir)}
    for key in ('nodes', 'record', 'after_start', 'until'):
        if key in data:
            data[key] = _substitute(data[key], names)
    specs = [parse_node(entry, f'experiment.nodes[{i}]') for i, entry in enumerate(data['nodes'])]
    if host is not None:
        return _run_host_part(session, [s for s in specs if s.host == host], path, overrides, log)
    remote = {name for name, h in hosts.items() if h.remote}
    specs = _resolve_parameter_files(specs, path, overrides)
    timeout = float(data.get('timeout', 60.0))
    bag = None
    condition_met = False
    message = ''
    with session:
        if session.security is not None:   # every enclave, before any node starts (exit 2 naming them)
            session.security.check_keystore(
                [ORCHESTRATOR_ENCLAVE, *(session.enclave(spec) for spec in specs if spec.host not in remote),
                 *([session.enclave(RECORDER)] if data.get('record') is not None else [])])
        record = data.get('record')
        if record is not None:
            record = _require_mapping(record, 'experiment.record')
            bag = session.run_dir / 'bags' / str(record.get('bag', data['name']))
            bag.parent.mkdir(parents=True, exist_ok=True)
            recorder = {'output': str(bag),
                        'topics': [session.resolve(t) for t in record.get('topics') or []] or ['']}
            if 'storage_preset' in record:  # none | fastwrite | zstd_fast | zstd_small (rosbag2's presets)
                recorder['storage_preset'] = str(record['storage_preset'])
            rates = _require_mapping(record.get('rates') or {}, 'experiment.record.rates')
            recorder['topic_rates'] = [f'{session.resolve(t)}={hz}' for t, hz in rates.items()] or ['']
            analysis = record.get('analysis_topics')
            if analysis is not None:
                analysis = [session.resolve(str(t)) for t in
                            require_list(analysis, 'experiment.record.analysis_topics', ExperimentError)]
            session.add_recording('bag_recorder', bag, analysis)
            if session.namespace != '/' and not record.get('topics'):
                # "Everything" of a namespaced session: its own topics, not a neighbour's.
                recorder['exclude'] = ['/rosout', '/parameter_events', f'(?!{re.escape(session.namespace)}/).*']
            # The recorder's clock stamps the bag: simulated time by default; a run whose nodes are on
            # the wall clock records on it too (record.use_sim_time: false), and the recorder then
            # does not take /clock at all (each tick woke its executor: a quarter of a core at 100 Hz).
            use_sim_time = record.get('use_sim_time', True)
            if not isinstance(use_sim_time, bool):
                raise ExperimentError(f'experiment.record.use_sim_time: must be true or false (got {use_sim_time!r:.40})')
            session.start(replace(RECORDER, parameters=[recorder], use_sim_time=use_sim_time))
        for spec in specs:
            if spec.host not in remote:
                session.start(spec)
        try:
            expected = [session.node_namespace(spec).rstrip('/') + '/' + (spec.name or spec.executable)
                         for spec in specs]
            try:
                session.wait_for_nodes(expected, float(data.get('discovery_timeout', DEFAULT_DISCOVERY_TIMEOUT)))
            except NodesNotDiscovered as error:
                session.not_discovered = error.missing
                raise
            if on_running is not None:
                on_running(session)
            _follow(session, data.get('follow') or [], log)
            for index, step in enumerate(data.get('after_start') or []):
                _run_step(session, step, f'experiment.after_start[{index}]')
            condition_met = _wait_until(session, data['until'], timeout)
            message = 'completion condition met' if condition_met else 'timed out'
        except NodeExitedError as error:
            if _finished_as_awaited(data['until'], error.node):
                # The awaited node finished while an after_start step was still waiting (a fast run).
                condition_met, message = True, 'completion condition met'
            else:
                message = str(error)
        except (TimeoutError, NodesNotDiscovered) as error:
            message = str(error)
        session.condition_met = condition_met
        log(f'[experiment] {data["name"]}: {message}')
    return SessionRunResult(session.run_dir, session.exit_code(), condition_met, bag, message)


def _resolve_parameter_files(specs: list[NodeSpec], path: Path, overrides) -> list[NodeSpec]:
    for spec in specs:
        # Parameter files are relative to the experiment file unless absolute.
        spec.parameters = [p if isinstance(p, dict) or Path(p).is_absolute()
                           else str(Path(path).parent / p) for p in spec.parameters]
        if overrides and spec.label in overrides:
            spec.parameters.append(overrides[spec.label])
    return specs


def _run_host_part(session: Session, specs: list[NodeSpec], path: Path, overrides, log) -> SessionRunResult:
    """One remote host's nodes: started here, kept until they all exit (or Ctrl-C)."""
    with session:
        for spec in _resolve_parameter_files(specs, path, overrides):
            session.start(spec)
        try:
            while any(p.poll() is None for p in session.nodes.values()):
                session.check_alive()
                time.sleep(0.2)
            session.condition_met = True
            message = 'every node of this host exited'
        except NodeExitedError as error:
            message = str(error)
        log(f'[experiment] {session.label}: {message}')
    return SessionRunResult(session.run_dir, session.exit_code(), bool(session.condition_met), None, message)


def _run_step(session: Session, step, path: str) -> None:
    step = _require_mapping(step, path)
    if 'wait_for_message' in step:
        spec = step['wait_for_message']
        expected, at_least = spec.get('equals', {}), spec.get('at_least', {})
        session.wait_for_message(spec['topic'], spec['type'], timeout=float(spec.get('timeout', 30)),
                                 predicate=lambda msg: _matches(msg, expected, at_least),
                                 latched=bool(spec.get('latched', False)))
    elif 'stop' in step:
        name = str(step['stop'])
        if name not in session.nodes:
            raise ExperimentError(f"{path}.stop: no node named '{name}' (nodes: {', '.join(session.nodes)})")
        session.stop(name)
    elif 'call' in step:
        from ..ros_interfaces import import_interface
        spec = step['call']
        srv_type = import_interface(spec['type'])
        request = srv_type.Request(**spec.get('request', {}))
        session.call_service(spec['service'], spec['type'], request,
                             timeout=float(spec.get('timeout', 30)))
    elif 'sleep' in step:
        time.sleep(float(step['sleep']))
    else:
        raise ExperimentError(f'{path}: expected one of wait_for_message, call, stop, sleep')


class _MessageFields(dict):
    """A message's fields for str.format (``{round}``, ``{leader_move.colour}``)."""

    def __init__(self, msg):
        super().__init__()
        self.msg = msg

    def __missing__(self, key):
        return getattr(self.msg, key)


def _follow(session: Session, entries: list, log) -> None:
    """One console line per message of each ``follow`` entry (checked by experiment_checks), repeats dropped."""
    for entry in entries:
        said: set[str] = set()
        expected = entry.get('when', {})

        def on_message(msg, entry=entry, said=said, expected=expected):
            if not _matches(msg, expected):
                return
            text = entry['say'].format_map(_MessageFields(msg))
            if text not in said:
                said.add(text)
                log(f"[{session.label}] {text}")
        session.observer.follow(session.resolve(entry['topic']), entry['type'], on_message,
                                latched=bool(entry.get('latched', False)))


def _finished_as_awaited(until: dict, node) -> bool:
    """True when ``node`` is the one ``until: {exit: ...}`` waits for and it exited with code 0."""
    kind, spec = next(iter(until.items()))
    return kind == 'exit' and str(spec) == node.name and node.poll() == 0


def _wait_until(session: Session, until: dict, timeout: float) -> bool:
    kind, spec = next(iter(until.items()))
    if kind == 'seconds':
        deadline = time.monotonic() + float(spec)
        while time.monotonic() < deadline:
            session.check_alive()
            time.sleep(0.1)
        return True
    if kind == 'exit':
        return session.wait_for_exit(str(spec), timeout) == 0
    spec = _require_mapping(spec, 'experiment.until.message')
    expected = spec.get('equals', {})
    session.wait_for_message(spec['topic'], spec['type'],
                             predicate=lambda msg: _matches(msg, expected),
                             timeout=timeout, latched=bool(spec.get('latched', False)))
    return True

