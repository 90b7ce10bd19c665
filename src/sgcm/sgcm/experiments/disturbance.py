"""Fig. 5 of the SGCM paper (stackelberg_guidance_sgcm, Section V-B): SGCM's resilience.

Every case is played by SGCM with five followers: ``perfect`` (obedient, no execution failures),
``disturbed`` (random moves in some rounds, executions failing with p_fail), ``zero_trust``
(greedy, ignoring the guidance; with failures) -- the paper's three -- plus a ``random`` follower
(a random move every round) and an ``adversarial`` one (undoes the team's progress). Utilities
are summed over the perfect run's rounds, as Table I sums greedy over SGCM's rounds.

Writes ``disturbance.md`` and ``disturbance.png`` (stage-wise utility per round, every case). The
acceptance: the paper's three settings complete every case.
"""
from __future__ import annotations

from pathlib import Path

from collab_tools.experiments import plots
from collab_tools.experiments.api import ExperimentRequest, ExperimentResult, Log

from ..core.episode import run_sgcm
from ..core.follower_behaviour import FollowerSettings
from ..core.task_config import Case, TaskConfig
from .case_plots import case_grid
from .inputs import CaseModels, planner_path, task_and_cases
from .table1 import final_reward

#: name -> (the follower, executions fail with p_fail)
DISTURBANCE_SETTINGS = {
    'perfect': (FollowerSettings('obedient'), False),
    'disturbed': (FollowerSettings('random', deviation_probability=0.2), True),
    'zero_trust': (FollowerSettings('zero_trust'), True),
    'random': (FollowerSettings('random', deviation_probability=1.0), True),
    'adversarial': (FollowerSettings('adversarial'), True),
}
#: The paper's settings (Fig. 5): each must complete every case.
RESILIENT = ('perfect', 'disturbed', 'zero_trust')
ROUND_LIMIT = 40


def run(request: ExperimentRequest) -> ExperimentResult:
    task, cases = task_and_cases(request)
    data = run_disturbance(task, cases, request.log, request.seed, path=planner_path(request))
    run_dir = Path(request.run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    report = _disturbance_table(data)
    _plot_disturbance(data, run_dir / 'disturbance.png')
    completed = {name: sum(per[name]['completed'] for per in data['cases'].values()) for name in DISTURBANCE_SETTINGS}
    passed = all(completed[name] == len(cases) for name in RESILIENT)
    return ExperimentResult(
        passed=passed, report=report, data=data, report_file='disturbance.md',
        acceptance={'perfect_disturbed_zero_trust_complete_every_case': passed},
        outcome='cases completed per follower: ' + ', '.join(f'{n} {c}/{len(cases)}' for n, c in completed.items()))


def run_disturbance(task: TaskConfig, cases: list[Case], log: Log = print, seed: int = 0,
                    round_limit: int = ROUND_LIMIT, path: str = 'kernel') -> dict:
    """The results (results.json's data): every case under every follower setting (``path``: the FSE path)."""
    games = CaseModels(task, path)   # each case on its own task (grid, goals)
    results = {'round_limit': round_limit,
               'failure_probability': {'leader': task.leader.failure_probability,
                                       'follower': task.follower.failure_probability},
               'settings': {name: {'behaviour': s.behaviour, 'deviation_probability': s.deviation_probability,
                                   'execution_failures': failures}
                            for name, (s, failures) in DISTURBANCE_SETTINGS.items()},
               'cases': {}}
    total = len(cases) * len(DISTURBANCE_SETTINGS)
    done = 0
    for index, case in enumerate(cases, start=1):
        model, planner = games.model(case), games.planner(case)
        state = model.state_of(case)
        per_case = {}
        common_rounds = None  # the perfect follower's rounds: utilities are summed over them
        for name, (settings, failures) in DISTURBANCE_SETTINGS.items():
            episode = run_sgcm(model, state, follower=settings, planner=planner, simulate_failures=failures,
                               seed=seed + 100 * index, round_limit=round_limit)
            common_rounds = common_rounds or episode.rounds
            per_case[name] = {
                'completed': episode.completed, 'rounds': episode.rounds,
                'utility': episode.utility_over(common_rounds, final_reward(model, episode)),
                'utility_all_rounds': float(sum(episode.stage_utilities)),
                'stage_utilities': episode.stage_utilities,
                'deviations': sum(r.follower_deviated for r in episode.records),
                'failed_moves': sum((not r.leader_succeeded) + (not r.follower_succeeded)
                                    for r in episode.records),
            }
            done += 1
            log(f'[sgcm-disturbance {done}/{total}] {case.name} {name}: '
                f'{"completed" if episode.completed else "NOT completed"} in {episode.rounds} rounds, '
                f'utility {per_case[name]["utility"]:.1f} over {common_rounds} rounds, '
                f'{per_case[name]["deviations"]} deviations')
        results['cases'][case.name] = per_case
    return results


def _disturbance_table(results: dict) -> str:
    names = list(DISTURBANCE_SETTINGS)
    lines = ['| case | ' + ' | '.join(names) + ' |', '|---|' + '---|' * len(names)]
    for case, per_case in results['cases'].items():
        cells = [f'{"Yes" if r["completed"] else "No"}, {r["rounds"]} r, {r["utility"]:.1f}'
                 for r in (per_case[n] for n in names)]
        lines.append(f'| {case} | ' + ' | '.join(cells) + ' |')
    text = ('completed, rounds, utility (sum of stage-wise utilities over the perfect run\'s rounds, '
            'as Table I sums greedy over SGCM\'s rounds) per follower setting\n\n' + '\n'.join(lines) + '\n')
    return text


def _plot_disturbance(results: dict, path: Path) -> None:
    cases = list(results['cases'])
    fig, axes = case_grid(len(cases))
    styles = {'perfect': 'o-', 'disturbed': 's--', 'zero_trust': '^-.', 'random': 'x:', 'adversarial': 'v:'}
    for ax, case in zip(axes.flat, cases):
        for name, record in results['cases'][case].items():
            values = record['stage_utilities']
            ax.plot(range(1, len(values) + 1), values, styles[name], label=name, markersize=3)
        ax.set_title(case, fontsize=9)
    axes.flat[0].legend(fontsize=7)
    fig.suptitle('SGCM with disturbances, zero trust and hostile followers (Fig. 5)')
    plots.save(fig, path)
