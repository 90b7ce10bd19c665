"""An orchestration session: nodes started together in an isolated ROS domain.

    with Session('demo') as session:
        session.start(NodeSpec('pybullet_bridge', 'pybullet_bridge', parameters=[...]))
        session.wait_for_message('/clock', 'rosgraph_msgs/msg/Clock', timeout=20)
        ...
    # every node stopped (SIGINT, escalating), logs in session.run_dir/logs/

Exit codes for scripts built on a session (see exit_code()):
  0 success, 1 completion condition not met in time, 3 a node failed.
"""

import json
import os
import signal
import time
from collections.abc import Callable
from datetime import datetime
from pathlib import Path
from typing import Any

from .domain import acquire_domain
from .node_process import NodeProcess, NodeSpec, build_command

EXIT_OK = 0
EXIT_CONDITION_NOT_MET = 1
EXIT_USAGE = 2
EXIT_NODE_FAILED = 3


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
                 stop_timeout: float = 10.0, log: Callable[[str], None] | None = print):
        self.label = label
        self.run_dir = Path(run_dir) if run_dir else new_run_dir(label)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.stop_timeout = stop_timeout
        self._requested_domain = domain_id
        self._lease = None
        self._observer = None
        self._log = log or (lambda _text: None)
        self.nodes: dict[str, NodeProcess] = {}
        self.started = time.monotonic()
        self.condition_met: bool | None = None

    # --- lifecycle ----------------------------------------------------------------
    def __enter__(self) -> 'Session':
        self._lease = acquire_domain(self._requested_domain)
        self._previous_sigterm = signal.getsignal(signal.SIGTERM)
        # A terminated orchestrator still stops its nodes (via __exit__).
        signal.signal(signal.SIGTERM, _raise_keyboard_interrupt)
        self._log(f'[session] {self.label}: ROS_DOMAIN_ID={self.domain_id}, run dir {self.run_dir}')
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            self.stop_all()
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
        env.update({
            'ROS_DOMAIN_ID': str(self.domain_id),
            'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
            'ROS_LOG_DIR': str(self.run_dir / 'logs' / 'ros'),
            'PYTHONUNBUFFERED': '1',
            'RCUTILS_COLORIZED_OUTPUT': '0',
            'RCUTILS_LOGGING_BUFFERED_STREAM': '0',
        })
        env.pop('ROS_LOCALHOST_ONLY', None)  # deprecated in Jazzy; the range above replaces it
        env.update(extra or {})
        return env

    # --- nodes ------------------------------------------------------------------------
    def start(self, spec: NodeSpec) -> NodeProcess:
        if spec.label in self.nodes:
            raise ValueError(f"a node named '{spec.label}' is already part of this session")
        command = build_command(spec, self.run_dir / 'params')
        process = NodeProcess(spec, command, self.environment(spec.env),
                              self.run_dir / 'logs' / f'{spec.label}.log')
        self.nodes[spec.label] = process
        self._log(f'[session] started {spec.label} (pid {process.popen.pid})')
        return process

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

    # --- conditions -----------------------------------------------------------------
    @property
    def observer(self):
        if self._observer is None:
            from .observer import GraphObserver  # rclpy only when a condition needs it
            self._observer = GraphObserver(self.domain_id, f'orchestrator_{os.getpid()}')
        return self._observer

    def wait_for_message(self, topic: str, type_name: str,
                         predicate: Callable[[Any], bool] | None = None,
                         timeout: float = 30.0, latched: bool = False) -> Any:
        return self.observer.wait_for_message(topic, type_name, predicate, timeout, latched,
                                              check=self.check_alive)

    def call_service(self, service: str, type_name: str, request: Any = None,
                     timeout: float = 30.0) -> Any:
        return self.observer.call_service(service, type_name, request, timeout,
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
        if self.condition_met is False:
            return EXIT_CONDITION_NOT_MET
        return EXIT_OK

    def _write_summary(self, exc: BaseException | None) -> None:
        summary = {
            'label': self.label,
            'domain_id': self._lease.domain_id if self._lease else None,
            'duration_s': round(time.monotonic() - self.started, 3),
            'condition_met': self.condition_met,
            'error': None if exc is None else f'{type(exc).__name__}: {exc}',
            'nodes': {
                name: {
                    'command': process.command,
                    'log': str(process.log_path.relative_to(self.run_dir)),
                    'exit_code': process.poll(),
                    'outcome': process.outcome(),
                } for name, process in self.nodes.items()
            },
        }
        (self.run_dir / 'session.json').write_text(json.dumps(summary, indent=2))


def _raise_keyboard_interrupt(signum, frame):
    raise KeyboardInterrupt(f'signal {signum}')
