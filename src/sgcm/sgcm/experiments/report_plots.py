"""scripts/report plug-in for SGCM bags: the task's outcome and the rounds as the leader saw and announced them.

For a bag with /sgcm/guidance: the outcome (goal reached or why the task ended, in how many
rounds, how many follower deviations and failed moves), and a plot of, per round, the leader's
predicted values v_0^A, v_0^B and her planning time, and a timeline of both arms' moves (failed
moves and deviations from the recommendation marked). Registered through the ament index
resource ``collab_report_plots`` (see collab_tools.report_cli).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use('Agg')

import matplotlib.pyplot as plt  # noqa: E402
from collab_tools.core.bag_analysis import BagSummary, read_messages  # noqa: E402
from collab_tools.core.report_plots import register_plot  # noqa: E402
from collab_tools.core.run_outcome import Outcome, register_outcome  # noqa: E402

from ..core.round_log import rounds_in_order  # noqa: E402

GUIDANCE_TYPE = 'sgcm_interfaces/msg/Guidance'


def _move_text(move) -> str:
    return '-' if move.empty else f'{move.colour} {move.source_cell}->{move.target_cell}'


def _read_rounds(bag: Path):
    """(guidance of every round in the order played, follower reports by position in it, the final guidance
    or None); a restarted leader's rounds follow her earlier ones (sgcm.core.round_log.rounds_in_order)."""
    guidance, reports = [], []
    for topic, _, msg in read_messages(bag, ['/sgcm/guidance', '/sgcm/follower_report']):
        (guidance if topic == '/sgcm/guidance' else reports).append(msg)
    played, final = rounds_in_order(guidance, reports)
    return [g for g, _ in played], {index: r for index, (_, r) in enumerate(played, start=1) if r is not None}, \
        final


def sgcm_outcome(bag: Path, summary: BagSummary) -> Outcome | None:
    """completed (goal reached) or why the leader ended the task, with rounds, deviations and failed moves."""
    guidance, reports, final = _read_rounds(bag)
    if not guidance and final is None:
        return None
    rounds = len(guidance)
    deviations = sum(1 for r in reports.values() if r.deviated)
    failed = sum(1 for g in guidance if not g.leader_move.empty and not g.leader_move_succeeded)
    failed += sum(1 for r in reports.values() if not r.move.empty and not r.succeeded)
    strategy = f'{guidance[0].strategy}, T={guidance[0].horizon}' if guidance else 'no rounds'
    if final is None:
        status, ending = 'incomplete', 'the leader never ended the task (no final guidance)'
    elif final.task_complete:
        status, ending = 'completed', 'goal reached'
    else:
        status, ending = 'ended', final.status
    return Outcome('sgcm', status, f'{ending} in {rounds} round{"s" * (rounds != 1)} ({strategy}); '
                   f'{deviations} follower deviation{"s" * (deviations != 1)}, {failed} failed move{"s" * (failed != 1)}',
                   passed=final is not None and bool(final.task_complete),
                   figures={'rounds': rounds, 'deviations': deviations, 'failed_moves': failed,
                            'ending': ending},
                   checks={'goal_reached': final is not None and bool(final.task_complete)})


def plot_sgcm_rounds(bag: Path, summary: BagSummary, out_dir: Path) -> list[Path]:
    guidance, reports, final = _read_rounds(bag)
    if not guidance:
        return []
    rounds = list(range(1, len(guidance) + 1))     # in the order played (a restarted leader counts again)
    fig, (values, timing, timeline) = plt.subplots(3, 1, figsize=(9, 9), sharex=True,
                                                   gridspec_kw={'height_ratios': [2, 1, 2]})
    if any(g.strategy == 'sgcm' for g in guidance):
        values.plot(rounds, [g.predicted_leader_value for g in guidance], 'o-', label='v_0^A (leader)')
        values.plot(rounds, [g.predicted_follower_value for g in guidance], 's--', label='v_0^B (follower)')
        values.legend(fontsize=8, loc='upper left', bbox_to_anchor=(1.01, 1.0))  # beside the values, over none
    values.set_ylabel('predicted value')
    ending = (final.status or 'goal reached') if final else 'no end recorded'
    values.set_title(f'{guidance[0].strategy}, T={guidance[0].horizon}: {len(rounds)} rounds, {ending}')
    values.grid(alpha=0.3)
    timing.bar(rounds, [g.planning_seconds * 1e3 for g in guidance])
    timing.set_ylabel('planning (ms)')
    timing.grid(alpha=0.3)
    for number, g in zip(rounds, guidance):
        leader = _move_text(g.leader_move) + ('' if g.leader_move_succeeded else ' (failed)')
        report = reports.get(number)
        if report is None:
            follower = 'no report'
        else:
            follower = _move_text(report.move) + ('' if report.succeeded or report.move.empty else ' (no effect)')
            if report.deviated:
                follower += f' [deviated; advised {_move_text(g.recommended_follower_move)}]'
        timeline.text(number, 1.0, leader, ha='center', va='center', fontsize=7, rotation=20)
        timeline.text(number, 0.0, follower, ha='center', va='center', fontsize=7, rotation=20,
                      color='tab:red' if report is not None and report.deviated else 'black')
    timeline.set_yticks([0.0, 1.0], ['follower', 'leader'])
    timeline.set_ylim(-0.7, 1.7)
    timeline.set_xlabel('round')
    timeline.set_xticks(rounds)
    timeline.set_xlim(min(rounds) - 0.8, max(rounds) + 0.8)
    fig.tight_layout()
    path = Path(out_dir) / 'sgcm_rounds.png'
    fig.savefig(path, dpi=110, bbox_inches='tight')
    plt.close(fig)
    return [path]


register_plot('sgcm_rounds', {GUIDANCE_TYPE}, plot_sgcm_rounds)
register_outcome('sgcm', {GUIDANCE_TYPE}, sgcm_outcome)
