"""What a run keeps while it runs, so that an interrupted run loses nothing and can be resumed.

``RUN_DIR/run.json`` (:class:`RunRecord`): the experiment, its options, seed and inputs (``--config``,
``--set``) and its status (running, interrupted, failed, done); ``--resume RUN_DIR`` checks the
command line against it.

``RUN_DIR/partial/<loop>.jsonl`` (:class:`Checkpoint`): one JSON line per finished step of a loop
(``{"key": ..., "value": ...}``), appended and flushed to disk as the step ends. A line cut short by
a crash is ignored; a resumed run reads the finished steps back instead of running them again.
Values keep NaN and infinities (Python's JSON extension) so a restored step equals the computed one.
"""
from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..core.errors import ConfigurationError

RUN_SCHEMA = 'collab-experiment-run/1'
RUN_FILE = 'run.json'
PARTIAL_DIR = 'partial'


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as Python numbers and lists; anything else JSON cannot take is an error."""
    if hasattr(value, 'tolist'):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f'a checkpointed step value holds a {type(value).__name__}, which JSON cannot keep')


class Checkpoint:
    """The finished steps of one run's loops (files under ``RUN_DIR/partial/``)."""

    def __init__(self, run_dir: str | Path):
        self.directory = Path(run_dir) / PARTIAL_DIR

    def _path(self, loop: str) -> Path:
        safe = ''.join(c if c.isalnum() or c in '-_.' else '_' for c in loop)
        return self.directory / f'{safe}.jsonl'

    def load(self, loop: str) -> dict[str, Any]:
        """key -> value of every step of ``loop`` saved so far (the last line may be cut short: ignored)."""
        path = self._path(loop)
        if not path.is_file():
            return {}
        steps = {}
        lines = path.read_text().splitlines()
        for number, line in enumerate(lines, 1):
            try:
                entry = json.loads(line)
            except json.JSONDecodeError:
                if number == len(lines):
                    break   # the step being written when the run stopped
                raise ConfigurationError(f"checkpoint '{path}': line {number} is not JSON") from None
            steps[str(entry['key'])] = entry['value']
        return steps

    def save(self, loop: str, key: str, value: Any) -> None:
        """Append one finished step, on disk before this returns."""
        self.directory.mkdir(parents=True, exist_ok=True)
        line = json.dumps({'key': str(key), 'value': value}, default=_plain)
        with self._path(loop).open('a') as stream:
            stream.write(line + '\n')
            stream.flush()
            os.fsync(stream.fileno())

    def count(self) -> int:
        """Steps saved over every loop (0 when nothing finished)."""
        if not self.directory.is_dir():
            return 0
        return sum(len(self.load(path.stem)) for path in self.directory.glob('*.jsonl'))


def fresh_step_dir(run_dir: str | Path, step_dir: str | Path) -> Path:
    """``step_dir`` (inside ``run_dir``) made ready for a step that runs again: what an interrupted attempt
    left there (a partial bag, logs) is moved to ``RUN_DIR/partial/interrupted/`` -- kept, out of the results."""
    step_dir = Path(step_dir)
    if step_dir.exists():
        relative = step_dir.resolve().relative_to(Path(run_dir).resolve())
        target = Path(run_dir) / PARTIAL_DIR / 'interrupted' / relative
        for attempt in range(1, 1000):
            if not target.exists():
                break
            target = target.with_name(f'{relative.name}-{attempt}')
        target.parent.mkdir(parents=True, exist_ok=True)
        step_dir.rename(target)
    return step_dir


class RunRecord:
    """``RUN_DIR/run.json``: what the run was started with, and how far it got."""

    def __init__(self, run_dir: str | Path):
        self.path = Path(run_dir) / RUN_FILE

    def write(self, experiment: str, options: Mapping[str, Any], seed: int, inputs: Mapping[str, Any],
              status: str, command: str = '') -> None:
        document = {'schema': RUN_SCHEMA, 'experiment': experiment, 'options': dict(options), 'seed': seed,
                    'inputs': dict(inputs), 'status': status, 'command': command}
        temporary = self.path.with_suffix('.json.tmp')
        temporary.write_text(json.dumps(document, indent=2, default=_plain) + '\n')
        temporary.replace(self.path)

    def read(self) -> dict[str, Any]:
        try:
            document = json.loads(self.path.read_text())
        except (OSError, json.JSONDecodeError) as error:
            raise ConfigurationError(f"--resume: '{self.path.parent}' holds no readable {RUN_FILE} ({error}); "
                                     'only a run started by scripts/experiment can be resumed') from None
        if document.get('schema') != RUN_SCHEMA:
            raise ConfigurationError(f"--resume: '{self.path}' is not a {RUN_SCHEMA} record")
        return document

    def set_status(self, status: str) -> None:
        document = self.read()
        document['status'] = status
        temporary = self.path.with_suffix('.json.tmp')
        temporary.write_text(json.dumps(document, indent=2) + '\n')
        temporary.replace(self.path)
