"""What a run achieved, in one line each: the first thing a report says.

An :class:`Outcome` names its subject (a demo, an experiment, a bag), a status word
(``completed``, ``formed``, ``passed``, ``FAILED``, ...), one line of what happened with the key
figures, the figures themselves and the acceptance checks. Outcomes come from three places:

* an experiment's ``results.json`` (:func:`experiment_outcome`: its ``outcome`` and ``acceptance``);
* ``outcomes.json`` in a run directory (a list of outcomes, written by ``scripts/demo``);
* the bag itself, through outcome readers the subsystems register like plots
  (``register_outcome('sgcm', {'sgcm_interfaces/msg/Guidance'}, fn)``; ``fn(bag, summary)``
  returns an Outcome or None), so ``scripts/report`` on any bag states what happened in it.
"""
from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .bag_types import normalize_type_name

if TYPE_CHECKING:  # reading bags needs rosbags; registering a reader does not
    from .bag_analysis import BagSummary

__all__ = ['OUTCOMES_FILE', 'Outcome', 'bag_outcomes', 'experiment_outcome', 'markdown_escape', 'outcome_markdown',
           'read_outcomes', 'register_outcome', 'run_outcomes', 'unregister_outcome', 'write_outcomes']

#: A run directory's outcomes (scripts/demo writes one per demo).
OUTCOMES_FILE = 'outcomes.json'
#: An experiment's results (collab_tools.experiments.api).
RESULTS_FILE = 'results.json'


@dataclass
class Outcome:
    """subject: what it is about; status: one word; summary: what happened, with the key figures;
    passed: the acceptance verdict (None: nothing to judge); checks: name -> passed."""
    subject: str
    status: str
    summary: str
    passed: bool | None = None
    figures: dict[str, Any] = field(default_factory=dict)
    checks: dict[str, bool] = field(default_factory=dict)

    def line(self) -> str:
        """``subject: status -- summary`` and the failed checks, if any."""
        failed = [name for name, ok in self.checks.items() if ok is False]
        text = f'{self.subject}: {self.status}'
        if self.summary:
            text += f' — {self.summary}'
        if failed:
            text += f' [failed: {", ".join(failed)}]'
        return text

    def to_dict(self) -> dict[str, Any]:
        return {'line': self.line(), **asdict(self)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Outcome:
        return cls(str(data.get('subject', '?')), str(data.get('status', '?')), str(data.get('summary', '')),
                   data.get('passed'), dict(data.get('figures') or {}), dict(data.get('checks') or {}))


OutcomeFn = Callable[[Path, 'BagSummary'], 'Outcome | None']
_READERS: dict[str, tuple[frozenset[str], OutcomeFn]] = {}


def register_outcome(name: str, type_names: set[str], fn: OutcomeFn) -> None:
    """Register (or replace) outcome reader ``name``, run for a bag with a topic of one of ``type_names``."""
    if isinstance(type_names, str):
        type_names = {type_names}
    _READERS[name] = (frozenset(normalize_type_name(t) for t in type_names), fn)


def unregister_outcome(name: str) -> None:
    _READERS.pop(name, None)


def bag_outcomes(bag: Path, summary: BagSummary) -> list[Outcome]:
    """Every applicable reader's outcome of ``bag`` (a failing reader is reported on stderr and skipped)."""
    outcomes = []
    for name, (types, fn) in list(_READERS.items()):
        if types and not (types & summary.type_names):
            continue
        try:
            outcome = fn(Path(bag), summary)
        except Exception as error:  # noqa: BLE001 - one broken reader must not sink the report
            print(f'report: outcome {name!r} failed for {bag}: {type(error).__name__}: {error}', file=sys.stderr)
            continue
        if outcome is not None:
            outcomes.append(outcome)
    return outcomes


def experiment_outcome(document: Mapping[str, Any]) -> Outcome:
    """The outcome a ``results.json`` states (its acceptance's boolean checks as checks)."""
    acceptance = dict(document.get('acceptance') or {})
    checks = acceptance.get('checks') if isinstance(acceptance.get('checks'), Mapping) else acceptance
    checks = {k: v for k, v in checks.items() if isinstance(v, bool) and k != 'passed'}
    passed = document.get('passed')
    return Outcome(str(document.get('experiment', 'experiment')), 'passed' if passed else 'FAILED',
                   str(document.get('outcome', '')), None if passed is None else bool(passed), {}, checks)


def markdown_escape(text: str) -> str:
    """``text`` safe inside a Markdown table cell or bold run (``|`` escaped)."""
    return text.replace('|', '\\|')


def outcome_markdown(outcomes) -> list[str]:
    """One Markdown line per outcome (an :class:`Outcome` or its ``to_dict()``), as every report opens:
    ``- **subject: status** — summary (failed: checks)``."""
    lines = []
    for outcome in outcomes:
        o = outcome if isinstance(outcome, Outcome) else Outcome.from_dict(outcome)
        failed = [name for name, ok in o.checks.items() if ok is False]
        lines.append(f'- **{markdown_escape(o.subject)}: {markdown_escape(o.status)}**'
                     + (f' — {markdown_escape(o.summary)}' if o.summary else '')
                     + (f' (failed: {", ".join(failed)})' if failed else ''))
    return lines


def read_outcomes(path: Path) -> list[Outcome]:
    data = json.loads(Path(path).read_text(encoding='utf-8'))
    return [Outcome.from_dict(entry) for entry in data.get('outcomes', [])]


def write_outcomes(path: Path, outcomes: list[Outcome]) -> Path:
    path = Path(path)
    path.write_text(json.dumps({'outcomes': [o.to_dict() for o in outcomes]}, indent=2) + '\n', encoding='utf-8')
    return path


def run_outcomes(run_dir: Path) -> list[Outcome]:
    """The outcomes a run directory states of itself: outcomes.json, else results.json; [] for neither."""
    run_dir = Path(run_dir)
    if (run_dir / OUTCOMES_FILE).is_file():
        return read_outcomes(run_dir / OUTCOMES_FILE)
    if (run_dir / RESULTS_FILE).is_file():
        document = json.loads((run_dir / RESULTS_FILE).read_text(encoding='utf-8'))
        if isinstance(document, Mapping) and 'outcome' in document:
            return [experiment_outcome(document)]
    return []


# ---------------------------------------------------------------- built-in: the scripted driver's demo
DRIVER_DONE_SUFFIX = 'scripted_driver/done'


def scripted_drive_outcome(bag: Path, summary: BagSummary) -> Outcome | None:
    """completed when the scripted driver announced its plan done; how far each mobile robot drove."""
    from .bag_analysis import read_messages
    done_topics = [t.topic for t in summary.topics if t.topic.endswith(DRIVER_DONE_SUFFIX)]
    if not done_topics:
        return None
    done = any(bool(msg.data) for _, _, msg in read_messages(bag, done_topics))
    last: dict[str, tuple[float, float]] = {}
    driven: dict[str, float] = {}
    for _, _, msg in read_messages(bag, summary.topics_of_type('bridge_interfaces/msg/BodyStates')):
        for body in msg.bodies:
            if body.kind != 'mobile_robot':
                continue
            here = (body.pose.position.x, body.pose.position.y)
            if body.name in last:
                driven[body.name] = driven.get(body.name, 0.0) + math.dist(last[body.name], here)
            last[body.name] = here
    distances = ', '.join(f'{name} {metres:.1f} m' for name, metres in sorted(driven.items()))
    return Outcome('mobile', 'completed' if done else 'incomplete',
                   ('the driver finished its plan' if done else 'the driver never announced its plan done')
                   + (f'; driven: {distances}' if distances else ''),
                   passed=done, figures={'driven_m': {k: round(v, 3) for k, v in driven.items()}},
                   checks={'plan_done': done})


register_outcome('scripted_drive', {'std_msgs/msg/Bool'}, scripted_drive_outcome)
