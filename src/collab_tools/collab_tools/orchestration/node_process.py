"""One ROS node run as a subprocess: its command line, log file and shutdown."""

import os
import signal
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import yaml


@dataclass
class NodeSpec:
    """What to start: `ros2 run <package> <executable>` with ROS arguments.

    parameters: dicts (written to a params file in the run dir, for every node name: ``/**``),
    whole parameter-file mappings (``{'/**/robot_2/schema_agent': {'ros__parameters': {...}}}``,
    written as they are) and/or paths to ROS parameter YAML files, applied in order (later wins).
    """

    package: str
    executable: str
    name: str | None = None
    namespace: str | None = None
    parameters: list = field(default_factory=list)
    remappings: dict[str, str] = field(default_factory=dict)
    arguments: list[str] = field(default_factory=list)
    use_sim_time: bool = True
    log_level: str | None = None
    env: dict[str, str] = field(default_factory=dict)
    # A required node that exits before the session ends fails the session.
    required: bool = True
    # The session host the node runs on (orchestration.network); None: where the orchestrator runs.
    host: str | None = None

    @property
    def label(self) -> str:
        """The session's name for the process (logs, stop, until: exit): its node name, under its
        namespace when it has one (``burger1/role_player``), so per-robot nodes stay apart."""
        node = self.name or self.executable
        namespace = (self.namespace or '').strip('/')
        return f'{namespace}/{node}' if namespace else node


def find_executable(package: str, executable: str) -> Path:
    """Where `ros2 run package executable` would look: <prefix>/lib/<package>/<exe>."""
    from ament_index_python.packages import PackageNotFoundError, get_package_prefix

    try:
        prefix = Path(get_package_prefix(package))
    except PackageNotFoundError:
        raise FileNotFoundError(
            f"package '{package}' is not in the ament index (AMENT_PREFIX_PATH); "
            'is the workspace built and sourced (scripts/setup, source scripts/env.sh)?') from None
    path = prefix / 'lib' / package / executable
    if not (path.is_file() and os.access(path, os.X_OK)):
        available = sorted(p.name for p in (prefix / 'lib' / package).glob('*')
                           if p.is_file() and os.access(p, os.X_OK))
        raise FileNotFoundError(
            f"package '{package}' has no executable '{executable}' "
            f"(available: {', '.join(available) or 'none'})")
    return path


def is_parameter_file_content(params: dict) -> bool:
    """A mapping written as a whole ROS parameter file: node-name keys (``/**``, ``/**/robot_2/schema_agent``)
    each holding ``ros__parameters`` -- so per-node values travel in the experiment, not in a side file."""
    return bool(params) and all(isinstance(key, str) and key.startswith('/') and isinstance(value, dict)
                                and set(value) == {'ros__parameters'} for key, value in params.items())


def build_command(spec: NodeSpec, params_dir: Path, label: str | None = None) -> list[str]:
    command = [str(find_executable(spec.package, spec.executable)), *spec.arguments, '--ros-args']
    if spec.name:
        command += ['-r', f'__node:={spec.name}']
    if spec.namespace:
        command += ['-r', f'__ns:={spec.namespace}']
    for index, params in enumerate(spec.parameters):
        if isinstance(params, dict):
            path = params_dir / f'{label or spec.label}.{index}.yaml'
            path.parent.mkdir(parents=True, exist_ok=True)
            content = params if is_parameter_file_content(params) else {'/**': {'ros__parameters': params}}
            path.write_text(yaml.safe_dump(content, sort_keys=False))
        else:
            path = Path(params)
            if not path.is_file():
                raise FileNotFoundError(f'{spec.label}: parameter file {path} does not exist')
        command += ['--params-file', str(path)]
    command += ['-p', f'use_sim_time:={str(spec.use_sim_time).lower()}']
    for source, target in spec.remappings.items():
        command += ['-r', f'{source}:={target}']
    if spec.log_level:
        command += ['--log-level', spec.log_level]
    return command


class NodeProcess:
    """A started node; stop() interrupts it like Ctrl-C, escalating if it hangs."""

    def __init__(self, spec: NodeSpec, command: list[str], env: dict[str, str], log_path: Path,
                 label: str | None = None):
        self.spec = spec
        self.label = label or spec.label
        self.command = command
        self.log_path = log_path
        log_path.parent.mkdir(parents=True, exist_ok=True)
        self._log = open(log_path, 'wb')
        self._log.write(('$ ' + ' '.join(command) + '\n').encode())
        self._log.flush()
        # Own session: signals reach the node and anything it spawns, not us.
        self.popen = subprocess.Popen(command, env=env, stdout=self._log,
                                      stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                      start_new_session=True)
        self.started_at = time.monotonic()
        self.stopped_by: str | None = None

    @property
    def name(self) -> str:
        return self.label

    def poll(self) -> int | None:
        return self.popen.poll()

    def _signal(self, sig: int) -> None:
        try:
            os.killpg(self.popen.pid, sig)
        except ProcessLookupError:
            pass

    def stop(self, interrupt_timeout: float = 10.0, terminate_timeout: float = 5.0) -> int:
        """SIGINT, then SIGTERM, then SIGKILL; returns the exit code."""
        for sig, timeout, how in ((signal.SIGINT, interrupt_timeout, 'interrupted'),
                                  (signal.SIGTERM, terminate_timeout, 'terminated'),
                                  (signal.SIGKILL, 5.0, 'killed')):
            if self.popen.poll() is not None:
                break
            self.stopped_by = how
            self._signal(sig)
            try:
                self.popen.wait(timeout)
            except subprocess.TimeoutExpired:
                continue
        self._log.close()
        return self.popen.returncode

    def outcome(self) -> str:
        """How the process ended, in words, for the session summary."""
        code = self.popen.poll()
        if code is None:
            return 'running'
        if self.stopped_by in ('terminated', 'killed'):
            return f'{self.stopped_by} after ignoring SIGINT (exit {code})'
        if self.stopped_by == 'interrupted' and code in (0, -signal.SIGINT, 128 + signal.SIGINT):
            return 'stopped cleanly'
        return 'exited 0' if code == 0 else f'failed (exit {code})'

    def ended_badly(self) -> bool:
        code = self.popen.poll()
        if code is None:
            return False
        if self.stopped_by == 'interrupted':
            return code not in (0, -signal.SIGINT, 128 + signal.SIGINT)
        return self.stopped_by is not None or code != 0

    def log_tail(self, lines: int = 30) -> str:
        try:
            text = self.log_path.read_text(errors='replace')
        except OSError:
            return ''
        return '\n'.join(text.splitlines()[-lines:])
