"""An orchestration session: nodes started together in an isolated ROS domain.

    with Session('demo') as session:
        session.start(NodeSpec('pybullet_bridge', 'pybullet_bridge', parameters=[...]))
        session.wait_for_message('/clock', 'rosgraph_msgs/msg/Clock', timeout=20)
        ...
    # every node stopped (SIGINT, escalating), logs in session.run_dir/logs/

Exit codes for scripts built on a session (see exit_code()):
  0 success, 1 completion condition not met in time, 3 a node failed, 4 a node was never
  discovered (a discovery setting that does not reach it), 5 a recording lost messages on the
  experiment's analysis topics (see add_recording; a dead recorder's bag is repaired first).

A session may have a namespace (``Session('sim1', namespace='/sim1')``): every node starts
under it (a node's own namespace is joined below it), ``/clock``, ``/tf`` and ``/tf_static`` are
remapped into it, and the names a script waits for or calls are resolved against it, so two
simulations share one ROS domain without hearing each other. ``discovery`` and ``hosts`` (see
:mod:`.network`) say how nodes find each other and where they run. ``security`` (opt-in, see
:mod:`.security`) starts every node with its SROS2 enclave, or refuses plainly at the start
(Enforce on a middleware without DDS security: SecurityUnavailable, scripts exit 6).
"""

import json
import os
import signal
import time
from collections.abc import Callable
from datetime import datetime
from pathlib import Path
from typing import Any

from ..names import join
from .domain import acquire_domain
from .live import LiveView, from_environment as live_from_environment
from .network import Discovery, Host, NetworkConfigError
from .node_process import NodeProcess, NodeSpec, build_command
from .recordings import Recording, finish_recording
from .security import ORCHESTRATOR_ENCLAVE, SECURITY_VARIABLES, Security, resolve as resolve_security

EXIT_OK = 0
EXIT_CONDITION_NOT_MET = 1
EXIT_USAGE = 2
EXIT_NODE_FAILED = 3
EXIT_NOT_DISCOVERED = 4
EXIT_MESSAGES_LOST = 5

_OBSERVED_WITH_SERVER = False

#: Absolute names every node of a namespaced session has remapped into the session's namespace.
GLOBAL_TOPICS = ('/clock', '/tf', '/tf_static')


class NodesNotDiscovered(RuntimeError):
    """Nodes that were started (here or on another host) never appeared in the ROS graph."""

    def __init__(self, missing: list[str], timeout: float, discovery: Discovery):
        self.missing = missing
        super().__init__(f"{len(missing)} node(s) never discovered within {timeout:g} s with discovery "
                         f"{discovery.describe()}: {', '.join(missing)} (check the discovery setting and "
                         'that every host runs its part)')


class NodeExitedError(RuntimeError):
    """A required node ended while the session still needed it."""

    def __init__(self, node: NodeProcess):
        self.node = node
        super().__init__(
            f"node '{node.name}' exited early with code {node.poll()}; "
            f'last lines of {node.log_path}:\n{node.log_tail(20)}')


def workspace_root() -> Path:
    env_root = os.environ.get('COLLAB_WS_ENV')
    if env_root:
        return Path(env_root)
    return Path(__file__).resolve().parents[4]  # src/collab_tools/collab_tools/orchestration


def new_run_dir(label: str, root: Path | None = None) -> Path:
    """runs/<timestamp>-<label>/, unique even when two start in the same second."""
    root = Path(root or os.environ.get('COLLAB_RUNS_DIR') or workspace_root() / 'runs')
    stamp = datetime.now().strftime('%Y%m%d-%H%M%S')
    for attempt in range(1000):
        suffix = f'-{attempt}' if attempt else ''
        path = root / f'{stamp}-{label}{suffix}'
        try:
            path.mkdir(parents=True)
            return path
        except FileExistsError:
            continue
    raise RuntimeError(f'could not create a run directory under {root}')


class Session:

    def __init__(self, label: str, run_dir: Path | None = None, domain_id: int | None = None,
                 stop_timeout: float = 10.0, log: Callable[[str], None] | None = print,
                 namespace: str = '/', discovery: Discovery | None = None,
                 hosts: dict[str, Host] | None = None, share_domain: bool = False,
                 live: 'LiveView | None | str' = 'environment', security: Security | None = None):
        self.label = label
        self.security = security   # None after __enter__ when the middleware cannot secure (Permissive)
        # The live view (orchestration.live): started first, in this session's domain and namespace.
        self.live = live_from_environment() if live == 'environment' else live
        self.namespace = join(namespace)
        self.discovery = discovery or Discovery()
        self.hosts = dict(hosts or {})
        self.run_dir = Path(run_dir) if run_dir else new_run_dir(label)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.stop_timeout = stop_timeout
        self._requested_domain = domain_id
        self._share_domain = share_domain
        self._lease = None
        self._observer = None
        self._log = log or (lambda _text: None)
        self.nodes: dict[str, NodeProcess] = {}
        self.started = time.monotonic()
        self.condition_met: bool | None = None
        self.not_discovered: list[str] = []
        self._servers: list[NodeProcess] = []
        self.recordings: dict[str, Recording] = {}

    # --- lifecycle ----------------------------------------------------------------
    def __enter__(self) -> 'Session':
        self._lease = acquire_domain(self._requested_domain, shared=self._share_domain)
        self._previous_sigterm = signal.getsignal(signal.SIGTERM)
        # A terminated orchestrator still stops its nodes (via __exit__).
        signal.signal(signal.SIGTERM, _raise_keyboard_interrupt)
        self._log(f'[session] {self.label}: ROS_DOMAIN_ID={self.domain_id}, discovery '
                  f'{self.discovery.describe()}, run dir {self.run_dir}')
        try:
            self.security = resolve_security(self.security, self.domain_id, self._log)
            self._start_discovery_servers()
            for spec in self.live.specs() if self.live is not None else ():
                self.start(spec)
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            self.stop_all()
            for server in self._servers:
                server.stop(self.stop_timeout)
            self.finish_recordings()
        finally:
            if self._observer is not None:
                self._observer.close()
                self._observer = None
            self._write_summary(exc)
            if self._lease is not None:
                self._lease.release()
            signal.signal(signal.SIGTERM, self._previous_sigterm)

    @property
    def domain_id(self) -> int:
        if self._lease is None:
            raise RuntimeError('the session is not entered (use it in a with statement)')
        return self._lease.domain_id

    def environment(self, extra: dict[str, str] | None = None) -> dict[str, str]:
        env = dict(os.environ)
        for name in self.discovery.unset:
            env.pop(name, None)
        env.update(self.discovery.environment())
        env.update({
            'ROS_DOMAIN_ID': str(self.domain_id),
            'ROS_LOG_DIR': str(self.run_dir / 'logs' / 'ros'),
            'PYTHONUNBUFFERED': '1',
            'RCUTILS_COLORIZED_OUTPUT': '0',
            'RCUTILS_LOGGING_BUFFERED_STREAM': '0',
        })
        env.pop('ROS_LOCALHOST_ONLY', None)  # deprecated in Jazzy; the range above replaces it
        for name in SECURITY_VARIABLES:
            env.pop(name, None)   # secured only when this session asks (an inherited setting would half-apply)
        if self.security is not None:
            env.update(self.security.environment())
        env.update(extra or {})
        return env

    # --- nodes ------------------------------------------------------------------------
    def _start_discovery_servers(self) -> None:
        from .observer import ConditionTimeout
        for index, command in enumerate(self.discovery.server_commands()):
            spec = NodeSpec('fastdds', 'discovery', name=f'discovery_server_{index}', use_sim_time=False)
            server = NodeProcess(spec, command, self.environment(), self.run_dir / 'logs' / f'{spec.name}.log')
            self._servers.append(server)
            # The server prints its GUID prefix once it listens; clients that start earlier retry anyway.
            deadline = time.monotonic() + 10.0
            while 'Server is running' not in server.log_path.read_text(errors='replace'):
                if server.poll() is not None:
                    raise NodeExitedError(server)
                if time.monotonic() > deadline:
                    raise ConditionTimeout(f'discovery server {self.discovery.servers[index]} did not start')
                time.sleep(0.05)
            self._log(f'[session] discovery server {self.discovery.servers[index]} running (pid {server.popen.pid})')

    def resolve(self, name: str) -> str:
        """A topic or service name of the experiment as it is in this session's namespace."""
        return join(self.namespace, name)

    def node_namespace(self, spec: NodeSpec) -> str:
        return join(self.namespace, spec.namespace or '/')

    def enclave(self, spec: NodeSpec) -> str:
        """The node's SROS2 enclave: its fully qualified name in this session (``/sim1/burger1/role_player``)."""
        return join(self.node_namespace(spec), spec.name or spec.executable)

    def start(self, spec: NodeSpec) -> NodeProcess:
        label = spec.label  # as the experiment names it, whatever the session's namespace
        if label in self.nodes:
            raise ValueError(f"a node named '{label}' is already part of this session")
        host = None
        if spec.host is not None:
            host = self.hosts.get(spec.host)
            if host is None:
                raise NetworkConfigError(f"node {label}: host '{spec.host}' is not defined "
                                         f"(hosts: {', '.join(self.hosts) or 'none'})")
        if self.namespace != '/':
            spec = _in_namespace(spec, self.namespace)
        command = build_command(spec, self.run_dir / 'params', label)
        if self.security is not None:
            self.security.check_keystore([self.enclave(spec)])   # exit 2 naming it, not an rcl traceback
            command += ['--enclave', self.enclave(spec)]   # the node's identity (still inside --ros-args)
        if host is not None:
            command = host.wrap(command)
        process = NodeProcess(spec, command, self.environment(spec.env),
                              self.run_dir / 'logs' / f'{label}.log', label=label)
        self.nodes[label] = process
        where = f' on {host.name}' if host is not None else ''
        self._log(f'[session] started {label}{where} (pid {process.popen.pid})')
        return process

    def wait_for_nodes(self, names: list[str], timeout: float) -> None:
        """Wait until every node full name in `names` is in the graph; NodesNotDiscovered if not."""
        from .observer import ConditionTimeout
        try:
            self.observer._wait(lambda: set(names) <= self.observer.node_names(), timeout,
                                'nodes to be discovered', self.check_alive)
        except ConditionTimeout:
            missing = sorted(set(names) - self.observer.node_names())
            raise NodesNotDiscovered(missing, timeout, self.discovery) from None

    def check_alive(self) -> None:
        """Raise NodeExitedError if a required node has ended."""
        for process in self.nodes.values():
            if process.spec.required and process.stopped_by is None and process.poll() is not None:
                raise NodeExitedError(process)

    def stop(self, name: str) -> int:
        process = self.nodes[name]
        code = process.stop(self.stop_timeout)
        self._log(f'[session] {name}: {process.outcome()}')
        return code

    def stop_all(self) -> None:
        for name in reversed(list(self.nodes)):
            if self.nodes[name].stopped_by is None:
                self.stop(name)

    def failed_nodes(self) -> list[NodeProcess]:
        return [p for p in self.nodes.values() if p.ended_badly()]

    # --- recordings -------------------------------------------------------------------
    def add_recording(self, label: str, bag: Path, analysis_topics: list[str] | None = None) -> Recording:
        """The bag the recorder node ``label`` writes: when the nodes have stopped, it is repaired if
        the recorder died, and lost messages on ``analysis_topics`` (None: all) fail the session."""
        self.recordings[label] = Recording(Path(bag), analysis_topics)
        return self.recordings[label]

    def finish_recordings(self) -> None:
        for recording in self.recordings.values():
            finish_recording(recording, self._log)

    # --- conditions -----------------------------------------------------------------
    @property
    def observer(self):
        global _OBSERVED_WITH_SERVER
        if self._observer is None:
            from .observer import GraphObserver  # rclpy only when a condition needs it
            if self.discovery.servers:
                _OBSERVED_WITH_SERVER = True
            elif _OBSERVED_WITH_SERVER:
                # Seen here: after a participant of this process was a discovery-server client, Fast DDS
                # participants created later in it discover nothing, whatever the environment says.
                raise RuntimeError('this process already observed a session under a discovery server; Fast '
                                   'DDS keeps that process-wide, so this session would discover nothing: run '
                                   'each discovery-server session in its own process (scripts/orchestrate)')
            # The observer discovers like the nodes do (rcl reads these at init).
            security = self.security.environment() if self.security is not None else {}
            saved = {name: os.environ.get(name) for name in
                     (*self.discovery.environment(), *self.discovery.unset, *SECURITY_VARIABLES)}
            for name in (*self.discovery.unset, *SECURITY_VARIABLES):
                os.environ.pop(name, None)
            os.environ.update(self.discovery.environment())
            os.environ.update(security)
            try:
                self._observer = GraphObserver(self.domain_id, f'orchestrator_{os.getpid()}',
                                               enclave=ORCHESTRATOR_ENCLAVE if security else None)
            finally:
                for name, value in saved.items():
                    if value is None:
                        os.environ.pop(name, None)
                    else:
                        os.environ[name] = value
        return self._observer

    def wait_for_message(self, topic: str, type_name: str,
                         predicate: Callable[[Any], bool] | None = None,
                         timeout: float = 30.0, latched: bool = False) -> Any:
        return self.observer.wait_for_message(self.resolve(topic), type_name, predicate, timeout, latched,
                                              check=self.check_alive)

    def call_service(self, service: str, type_name: str, request: Any = None,
                     timeout: float = 30.0) -> Any:
        return self.observer.call_service(self.resolve(service), type_name, request, timeout,
                                          check=self.check_alive)

    def wait_for_exit(self, name: str, timeout: float) -> int:
        """Wait for node `name` to finish on its own; other required nodes must stay up."""
        from .observer import ConditionTimeout

        process = self.nodes[name]
        deadline = time.monotonic() + timeout
        while process.poll() is None:
            for other in self.nodes.values():
                if other is not process and other.spec.required and other.poll() is not None \
                        and other.stopped_by is None:
                    raise NodeExitedError(other)
            if time.monotonic() > deadline:
                raise ConditionTimeout(f"timed out after {timeout:.1f} s waiting for '{name}' to exit")
            time.sleep(0.05)
        return process.popen.returncode

    # --- results --------------------------------------------------------------------
    def exit_code(self) -> int:
        if self.failed_nodes():
            return EXIT_NODE_FAILED
        if self.not_discovered:
            return EXIT_NOT_DISCOVERED
        if any(r.lost for r in self.recordings.values()):
            return EXIT_MESSAGES_LOST
        if self.condition_met is False:
            return EXIT_CONDITION_NOT_MET
        return EXIT_OK

    def _write_summary(self, exc: BaseException | None) -> None:
        summary = {
            'label': self.label,
            'domain_id': self._lease.domain_id if self._lease else None,
            'duration_s': round(time.monotonic() - self.started, 3),
            'condition_met': self.condition_met,
            'namespace': self.namespace,
            'discovery': self.discovery.describe(),
            'not_discovered': self.not_discovered,
            'error': None if exc is None else f'{type(exc).__name__}: {exc}',
            'nodes': {
                name: {
                    'command': process.command,
                    'log': str(process.log_path.relative_to(self.run_dir)),
                    'exit_code': process.poll(),
                    'outcome': process.outcome(),
                } for name, process in self.nodes.items()
            },
            'recordings': {name: recording.summary() for name, recording in self.recordings.items()},
        }
        (self.run_dir / 'session.json').write_text(json.dumps(summary, indent=2))


def _in_namespace(spec: NodeSpec, namespace: str) -> NodeSpec:
    """`spec` moved below `namespace`, with the absolute ROS-wide topics remapped into it."""
    from dataclasses import replace
    remappings = {name: join(namespace, name) for name in GLOBAL_TOPICS}
    remappings.update(spec.remappings)
    return replace(spec, namespace=join(namespace, spec.namespace or '/'), remappings=remappings)


def _raise_keyboard_interrupt(signum, frame):
    raise KeyboardInterrupt(f'signal {signum}')
