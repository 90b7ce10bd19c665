"""One outcome line for an orchestrated run (a demo): how the session ended and what its bag shows.

The session's result says whether the nodes ran and stopped as planned (exit code, completion
condition, message); the outcome readers of the bag's subsystems
(:mod:`collab_tools.core.run_outcome`, registered as report plug-ins) say what happened: goal
reached in 4 rounds, formation formed, coalition set up. ``scripts/demo`` writes one per demo into
``outcomes.json``, which ``scripts/report`` puts first.
"""
from __future__ import annotations

from pathlib import Path

from ..core.run_outcome import Outcome, bag_outcomes

__all__ = ['session_outcome']


def session_outcome(subject: str, result, what: str = '') -> Outcome:
    """``result``: an orchestration SessionRunResult (exit_code, condition_met, bag, message)."""
    from ..core.bag_analysis import summarize_bag
    from ..report_cli import load_plot_plugins   # the subsystems' outcome readers
    load_plot_plugins()
    found: list[Outcome] = []
    problem = ''
    bag = getattr(result, 'bag', None)
    if bag is not None and Path(bag).exists():
        try:
            found = bag_outcomes(Path(bag), summarize_bag(Path(bag)))
        except Exception as error:  # noqa: BLE001 - an unreadable bag is part of the outcome
            problem = f'bag unreadable: {type(error).__name__}: {error}'
    else:
        problem = 'no bag recorded'
    checks = {'session_exit_0': result.exit_code == 0}
    figures = {'exit_code': result.exit_code, 'condition_met': bool(result.condition_met),
               'run_dir': str(result.run_dir)}
    for outcome in found:
        checks.update({f'{outcome.subject}.{k}' if k in checks else k: v for k, v in outcome.checks.items()})
        figures.update({outcome.subject: outcome.figures})
    summary = '; '.join(o.summary for o in found) or problem or result.message
    if result.exit_code != 0:
        return Outcome(subject, 'FAILED', f'exit {result.exit_code} ({result.message})'
                       + (f'; {summary}' if summary != result.message else ''), False, figures, checks)
    status = found[0].status if len(found) == 1 else ('completed' if result.condition_met else 'ended')
    if problem:   # the session ended as planned, but nothing shows what happened
        status = 'unverified'
    passed = all(o.passed is not False for o in found) and not problem
    if what:
        figures['what'] = what
    return Outcome(subject, status, summary, passed, figures, checks)
