"""One signature and one result schema for every experiment.

An experiment module (``<package>/experiments/<table_or_figure>.py``) has a function
``run(request: ExperimentRequest) -> ExperimentResult`` and is listed, with its paper reference and
its own command-line options, as an :class:`Experiment` in its package's ``experiments.EXPERIMENTS``.

``results.json`` (written by :func:`write_results`, never by the experiment itself) is one JSON
object whose first keys are the same for every experiment::

    {"schema": "collab-experiment/1", "experiment": "sgcm-table1",
     "paper": "SGCM (stackelberg_guidance_sgcm), Table I and Fig. 4",
     "passed": true, "outcome": "SGCM completed 10 of 10 cases ...",
     "options": {"mode": "core", ...}, "seed": 0, "wall_s": 12.3,
     "acceptance": {"passed": true, ...checks},
     ...the experiment's own keys (cases, rows, runs, ...)}

The experiment's own Markdown report (``ExperimentResult.report_file``: ``table1.md``, ``summary.md``)
is written beside it by the same function and opens with the outcome line ``scripts/report RUN``
prints first, so every report says what happened before its tables.
"""
from __future__ import annotations

import json
import math
import shutil
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import import_module
from pathlib import Path
from typing import Any

from ..core.errors import ConfigurationError
from ..core.run_outcome import experiment_outcome, outcome_markdown
from .checkpoint import Checkpoint
from .sweep import Steps

SCHEMA = 'collab-experiment/1'
#: Keys the schema owns; an experiment's data may not use them.
RESERVED_KEYS = ('schema', 'experiment', 'paper', 'passed', 'outcome', 'options', 'seed', 'wall_s', 'acceptance')

Log = Callable[[str], None]


@dataclass(frozen=True)
class Option:
    """A command-line option of one experiment (argparse ``add_argument`` keywords).

    only_when: (dest, values): the option means something only when option ``dest`` has one of
    ``values`` (``--loss`` only with ``--mode sim``); given otherwise, the command line refuses it
    instead of ignoring it (:func:`inapplicable_options`).
    """
    flag: str
    help: str
    type: Callable[[str], Any] | None = None
    default: Any = None
    choices: Sequence[Any] | None = None
    nargs: str | int | None = None
    metavar: str | None = None
    action: str | None = None
    only_when: tuple[str, tuple[Any, ...]] | None = None

    @property
    def dest(self) -> str:
        return self.flag.lstrip('-').replace('-', '_')

    def add_to(self, parser) -> None:
        # argparse formats help text: a literal '%' ("20 % loss") must be doubled.
        keywords = {'help': self.help.replace('%', '%%'), 'default': self.default}
        for key in ('type', 'choices', 'nargs', 'metavar', 'action'):
            value = getattr(self, key)
            if value is not None:
                keywords[key] = value
        parser.add_argument(self.flag, **keywords)


def inapplicable_options(options: Sequence[Option], values: Mapping[str, Any]) -> list[str]:
    """Messages for the options given a value (not their default) that their ``only_when`` rules out."""
    problems = []
    for option in options:
        if option.only_when is None or values.get(option.dest, option.default) == option.default:
            continue
        dest, allowed = option.only_when
        if values.get(dest) not in allowed:
            flag = '--' + dest.replace('_', '-')
            problems.append(f"{option.flag}: only with {flag} {' or '.join(map(str, allowed))} "
                            f'(got {flag} {values.get(dest)})')
    return problems


@dataclass(frozen=True)
class Experiment:
    """What ``scripts/experiment`` needs to list, parse and run one experiment.

    name: the command (``sgcm-table1``); paper: the reference (paper, table or figure);
    summary: one line for the help; module: where ``run`` lives (imported only when it runs,
    so listing experiments stays fast); options: the experiment's own flags.
    config_file: its main input file, relative to config/ -- what ``--config FILE`` replaces and
    ``--set key=value`` edits (None: ``--config`` takes a directory only, ``--set`` is refused);
    config_option: the experiment's own option naming that file (``--column``), exclusive with both.
    seeded: whether ``--seed`` means anything to it: True, False (no ``--seed`` option) or
    (dest, values) like :attr:`Option.only_when` (``--seed`` only in ``--mode sim``).
    starts_nodes: whether a run starts ROS nodes (so ``--live`` can show them): True, False (no
    ``--live`` option) or (dest, values) as for ``seeded``.
    """
    name: str
    paper: str
    summary: str
    module: str
    options: tuple[Option, ...] = ()
    function: str = 'run'
    config_file: str | None = None
    config_option: str | None = None
    seeded: bool | tuple[str, tuple[Any, ...]] = False
    starts_nodes: bool | tuple[str, tuple[Any, ...]] = False

    def runner(self) -> Callable[['ExperimentRequest'], 'ExperimentResult']:
        return getattr(import_module(self.module), self.function)


@dataclass(frozen=True)
class ExperimentRequest:
    """The inputs of one run: where configuration lives, where results go, the seed, the options.

    inputs: ``--config``/``--set`` as given (recorded in results.json's options); checkpoint: where
    finished steps are kept (None: nowhere, e.g. a test's or a benchmark's run); on_step: called with
    each finished step's key once it is saved (a test interrupts a run there).
    """
    config_dir: Path
    run_dir: Path
    seed: int = 0
    options: Mapping[str, Any] = field(default_factory=dict)
    log: Log = print
    inputs: Mapping[str, Any] = field(default_factory=dict)
    checkpoint: Checkpoint | None = None
    on_step: Callable[[str], None] | None = None

    def option(self, name: str, default: Any = None) -> Any:
        value = self.options.get(name)
        return default if value is None else value

    def progress(self, label: str, total: int) -> Steps:
        """The shared loop helper: a progress bar or lines with elapsed time and ETA, every finished step
        checkpointed, restored steps skipped (see :class:`~.sweep.Steps`)."""
        return Steps(label, total, checkpoint=self.checkpoint, log=self.log, on_step=self.on_step)


@dataclass
class ExperimentResult:
    """What an experiment found.

    passed: its acceptance check; outcome: one line saying what happened (the report's first
    line); report: the Markdown shown on screen (the main table); acceptance: the individual
    checks; data: the experiment's own results (JSON-serialisable), saved beside the schema keys;
    report_file: the run directory's file for ``report`` (``table1.md``), written by
    :func:`write_results` opening with the outcome line as ``scripts/report RUN`` states it.
    """
    passed: bool
    outcome: str
    report: str = ''
    acceptance: dict[str, Any] = field(default_factory=dict)
    data: dict[str, Any] = field(default_factory=dict)
    report_file: str | None = None

    def __post_init__(self):
        clash = sorted(set(self.data) & set(RESERVED_KEYS))
        if clash:
            raise ValueError(f'experiment data may not use the schema keys {clash}')


def _json_safe(value: Any) -> Any:
    """JSON without NaN/inf literals (json.dumps would write invalid JSON): they become null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Mapping):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, 'item') and callable(value.item):  # numpy scalars
        return _json_safe(value.item())
    return value


def results_document(experiment: Experiment, request: ExperimentRequest, result: ExperimentResult,
                     wall_s: float) -> dict[str, Any]:
    """The results.json object: the schema keys first, then the experiment's data."""
    acceptance = {'passed': bool(result.passed), **{k: v for k, v in result.acceptance.items() if k != 'passed'}}
    document = {'schema': SCHEMA, 'experiment': experiment.name, 'paper': experiment.paper,
                'passed': bool(result.passed), 'outcome': result.outcome,
                'options': {**request.options, **request.inputs}, 'seed': request.seed, 'wall_s': round(wall_s, 3),
                'acceptance': acceptance}
    document.update(result.data)
    return _json_safe(document)


def write_results(experiment: Experiment, request: ExperimentRequest, result: ExperimentResult,
                  wall_s: float) -> Path:
    """results.json, and the experiment's report (``result.report_file``) with its outcome first."""
    path = Path(request.run_dir) / 'results.json'
    document = results_document(experiment, request, result, wall_s)
    path.write_text(json.dumps(document, indent=2) + '\n')
    if result.report_file:
        write_report(Path(request.run_dir) / result.report_file, document, result.report)
    return path


def write_report(path: Path, document: Mapping[str, Any], report: str) -> Path:
    """``report`` (Markdown) under the outcome line(s) of results ``document``: the same lines
    ``scripts/report RUN`` puts first (:func:`~collab_tools.core.run_outcome.outcome_markdown`)."""
    lines = outcome_markdown([experiment_outcome(document)])
    path.write_text('\n'.join(lines) + '\n\n' + report.lstrip('\n'))
    return path


def run_experiment(experiment: Experiment, request: ExperimentRequest,
                   remove_on_bad_input: bool = False) -> ExperimentResult:
    """Run ``experiment`` and write its results.json; ConfigurationError (or ValueError) for bad input
    propagates before anything is written. ``remove_on_bad_input``: the caller made the run directory for
    this run; bad input found before any step finished removes it again (a refused run leaves nothing)."""
    run_dir = Path(request.run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    start = time.monotonic()
    try:
        result = experiment.runner()(request)
    except (ConfigurationError, ValueError):
        if remove_on_bad_input and (request.checkpoint is None or request.checkpoint.count() == 0):
            shutil.rmtree(run_dir, ignore_errors=True)
        raise
    if not isinstance(result, ExperimentResult):
        raise TypeError(f'{experiment.module}.{experiment.function} returned {type(result).__name__}, '
                        'not an ExperimentResult')
    write_results(experiment, request, result, time.monotonic() - start)
    return result


def load_results(run_dir: str | Path) -> dict[str, Any]:
    """A run's results.json, checked against the schema (ConfigurationError naming what is missing)."""
    path = Path(run_dir) / 'results.json'
    try:
        document = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ConfigurationError(f"results '{path}': cannot read ({error})") from None
    missing = [key for key in RESERVED_KEYS if key not in document]
    if document.get('schema') != SCHEMA or missing:
        raise ConfigurationError(f"results '{path}': not a {SCHEMA} document (missing: {missing or ['schema']})")
    return document
