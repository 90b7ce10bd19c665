"""The paper's SGCM experiments in the abstract game (``--mode core``).

- ``table1``: greedy vs SGCM on the ten cases (Table I), with the centralized lower
  bound on rounds, the stage-wise utility plots (Fig. 4) and results.json.
- ``disturbance``: Fig. 5: a perfect (obedient) follower vs a disturbed one (random
  moves in some rounds, executions failing with p_fail) vs zero trust (greedy follower),
  plus a random and an adversarial follower, on every case.

Each writes into its run directory and reports progress through ``log``.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .core.centralized import CentralizedPlanner
from .core.episode import EpisodeResult, run_greedy, run_sgcm
from .core.follower_behaviour import FollowerSettings
from .core.fse import FSEPlanner
from .core.rearrangement import RearrangementModel
from .core.task_config import Case, TaskConfig

Log = Callable[[str], None]


@dataclass
class CaseOutcome:
    case: str
    sgcm: EpisodeResult
    greedy: EpisodeResult
    greedy_stage_utilities: list[float]   # over SGCM's rounds, padded (Table I accounting)
    sgcm_utility: float
    greedy_utility: float
    centralized_rounds: int | None


def _final_reward(model: RearrangementModel, episode: EpisodeResult) -> float:
    return float(model.reward(np.array(episode.final_state)))


def run_table1(task: TaskConfig, cases: list[Case], run_dir: Path, log: Log = print,
               simulate_failures: bool = False, seed: int = 0, episodes=None) -> dict:
    """Table I. ``episodes(index, case) -> (sgcm, greedy)`` defaults to the abstract game."""
    model = RearrangementModel(task)
    planner = FSEPlanner(model)
    central = CentralizedPlanner(model)

    def in_core(index, case):
        state = model.state_of(case)
        return (run_sgcm(model, state, planner=planner, simulate_failures=simulate_failures, seed=seed + index),
                run_greedy(model, state, simulate_failures=simulate_failures, seed=seed + index))

    episodes = episodes or in_core
    outcomes = []
    for index, case in enumerate(cases, start=1):
        sgcm, greedy = episodes(index, case)
        greedy_over = greedy.stage_utilities_over(sgcm.rounds, _final_reward(model, greedy))
        outcome = CaseOutcome(case.name, sgcm, greedy, greedy_over,
                              sgcm.utility_over(sgcm.rounds, _final_reward(model, sgcm)),
                              float(sum(greedy_over)), central.plan(model.state_of(case)).rounds)
        outcomes.append(outcome)
        log(f'[sgcm-table1 {index}/{len(cases)}] {case.name}: greedy '
            f'{"completed" if greedy.completed else "stuck"} in {greedy.rounds} rounds, SGCM '
            f'{"completed" if sgcm.completed else "NOT completed"} in {sgcm.rounds} rounds '
            f'(centralized {outcome.centralized_rounds}), utility {outcome.greedy_utility:.1f} vs '
            f'{outcome.sgcm_utility:.1f}')
    results = table1_results(outcomes, task)
    write_table1(results, outcomes, run_dir)
    return results


def run_table1_sim(task: TaskConfig, task_file: Path, cases: list[Case], run_dir: Path, config_dir: Path,
                   log: Log = print, seed: int = 0) -> dict:
    """Table I in simulation: every case run twice (greedy, SGCM), recorded; the table
    is computed from the bags."""
    from .sim_runner import episode_from_bag, run_case
    model = RearrangementModel(task)
    quiet = lambda _text: None  # noqa: E731  (the session's own lines would drown the progress)

    def in_sim(index, case):
        found = {}
        for strategy in ('greedy', 'sgcm'):
            case_dir = run_dir / case.name / strategy
            log(f'[sgcm-table1 {index}/{len(cases)}] {case.name}: running {strategy} in simulation '
                f'({case_dir})')
            result = run_case(task, task_file, case, case_dir, config_dir, strategy=strategy,
                              seed=seed + index, log=quiet)
            if result.exit_code != 0 or result.bag is None:
                raise RuntimeError(f'{case.name} {strategy}: simulation run failed ({result.message}); '
                                   f'logs in {case_dir / "logs"}')
            found[strategy] = episode_from_bag(model, result.bag, strategy)
        return found['sgcm'], found['greedy']

    results = run_table1(task, cases, run_dir, log=log, episodes=in_sim)
    results['mode'] = 'sim'
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2))
    return results


def table1_results(outcomes: list[CaseOutcome], task: TaskConfig) -> dict:
    cases = []
    for o in outcomes:
        cases.append({
            'case': o.case,
            'greedy': {'completed': o.greedy.completed, 'stuck': o.greedy.stuck, 'rounds': o.greedy.rounds,
                       'utility': o.greedy_utility, 'stage_utilities': o.greedy.stage_utilities},
            'sgcm': {'completed': o.sgcm.completed, 'rounds': o.sgcm.rounds, 'utility': o.sgcm_utility,
                     'stage_utilities': o.sgcm.stage_utilities,
                     'planning_seconds': [r.planning_seconds for r in o.sgcm.records]},
            'centralized': {'rounds': o.centralized_rounds},
        })
    def fewer_or_equal_rounds(o):  # a stuck greedy run never finishes: any SGCM count is fewer
        return o.sgcm.completed and (not o.greedy.completed or o.sgcm.rounds <= o.greedy.rounds)

    acceptance = {
        'sgcm_completes_every_case': all(o.sgcm.completed for o in outcomes),
        'greedy_stuck_cases': [o.case for o in outcomes if not o.greedy.completed],
        'sgcm_never_more_rounds_than_greedy': all(fewer_or_equal_rounds(o) for o in outcomes),
        'sgcm_utility_at_least_greedy': all(o.sgcm_utility >= o.greedy_utility - 1e-9 for o in outcomes),
        'centralized_is_a_lower_bound': all(o.centralized_rounds is not None
                                            and o.centralized_rounds <= o.sgcm.rounds for o in outcomes),
    }
    acceptance['passed'] = (acceptance['sgcm_completes_every_case'] and bool(acceptance['greedy_stuck_cases'])
                            and acceptance['sgcm_never_more_rounds_than_greedy']
                            and acceptance['sgcm_utility_at_least_greedy']
                            and acceptance['centralized_is_a_lower_bound'])
    return {'experiment': 'sgcm-table1', 'mode': 'core', 'horizon': task.horizon, 'acceptance': acceptance,
            'failure_probability': {'leader': task.leader.failure_probability,
                                    'follower': task.follower.failure_probability},
            'utility_accounting': 'sum over SGCM rounds of r(state after round) - both costs',
            'cases': cases}


def _rounds_text(episode: EpisodeResult) -> str:
    return str(episode.rounds) if episode.completed else f'never (stuck after {episode.rounds})'


def write_table1(results: dict, outcomes: list[CaseOutcome], run_dir: Path) -> None:
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2))
    lines = ['| case | greedy status | greedy rounds | greedy utility | SGCM status | SGCM rounds | '
             'SGCM utility | centralized rounds |', '|---|---|---|---|---|---|---|---|']
    for o in outcomes:
        lines.append(f'| {o.case} | {"Yes" if o.greedy.completed else "No"} | {_rounds_text(o.greedy)} | '
                     f'{o.greedy_utility:.1f} | {"Yes" if o.sgcm.completed else "No"} | '
                     f'{_rounds_text(o.sgcm)} | {o.sgcm_utility:.1f} | {o.centralized_rounds} |')
    (run_dir / 'table1.md').write_text('\n'.join(lines) + '\n')
    _plot_stage_utilities(outcomes, run_dir / 'stage_utilities.png')


def _plot_stage_utilities(outcomes: list[CaseOutcome], path: Path) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, axes = _case_grid(plt, len(outcomes))
    for ax, o in zip(axes.flat, outcomes):
        rounds = range(1, o.sgcm.rounds + 1)
        ax.plot(rounds, o.sgcm.stage_utilities, 'o-', label='SGCM')
        ax.plot(rounds, o.greedy_stage_utilities, 's--', label='greedy')
        ax.set_title(f'{o.case} ({"stuck" if not o.greedy.completed else "both complete"})', fontsize=9)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle('Stage-wise utility, SGCM vs greedy (Fig. 4)')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _case_grid(plt, count: int, columns: int = 5):
    """One stage-wise-utility panel per case; spare panels hidden."""
    rows = (count + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(3.2 * columns, 2.6 * rows), squeeze=False)
    for index, ax in enumerate(axes.flat):
        if index >= count:
            ax.axis('off')
            continue
        ax.set_xlabel('round')
        ax.set_ylabel('stage-wise utility')
        ax.grid(alpha=0.3)
    return fig, axes


DISTURBANCE_SETTINGS = {
    'perfect': (FollowerSettings('obedient'), False),
    'disturbed': (FollowerSettings('random', deviation_probability=0.2), True),
    'zero_trust': (FollowerSettings('zero_trust'), True),
    'random': (FollowerSettings('random', deviation_probability=1.0), True),
    'adversarial': (FollowerSettings('adversarial'), True),
}


def run_disturbance(task: TaskConfig, cases: list[Case], run_dir: Path, log: Log = print, seed: int = 0,
                    round_limit: int = 40) -> dict:
    """Fig. 5: SGCM's resilience to disturbances, zero trust and hostile followers."""
    model = RearrangementModel(task)
    planner = FSEPlanner(model)
    results = {'experiment': 'sgcm-disturbance', 'round_limit': round_limit,
               'failure_probability': {'leader': task.leader.failure_probability,
                                       'follower': task.follower.failure_probability},
               'settings': {name: {'behaviour': s.behaviour, 'deviation_probability': s.deviation_probability,
                                   'execution_failures': failures}
                            for name, (s, failures) in DISTURBANCE_SETTINGS.items()},
               'cases': {}}
    total = len(cases) * len(DISTURBANCE_SETTINGS)
    done = 0
    for index, case in enumerate(cases, start=1):
        state = model.state_of(case)
        per_case = {}
        common_rounds = None  # the perfect follower's rounds: utilities are summed over them
        for name, (settings, failures) in DISTURBANCE_SETTINGS.items():
            episode = run_sgcm(model, state, follower=settings, planner=planner, simulate_failures=failures,
                               seed=seed + 100 * index, round_limit=round_limit)
            common_rounds = common_rounds or episode.rounds
            per_case[name] = {
                'completed': episode.completed, 'rounds': episode.rounds,
                'utility': episode.utility_over(common_rounds, _final_reward(model, episode)),
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
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2))
    _write_disturbance_table(results, run_dir / 'disturbance.md')
    _plot_disturbance(results, run_dir / 'disturbance.png')
    return results


def _write_disturbance_table(results: dict, path: Path) -> None:
    names = list(DISTURBANCE_SETTINGS)
    lines = ['| case | ' + ' | '.join(names) + ' |', '|---|' + '---|' * len(names)]
    for case, per_case in results['cases'].items():
        cells = [f'{"Yes" if r["completed"] else "No"}, {r["rounds"]} r, {r["utility"]:.1f}'
                 for r in (per_case[n] for n in names)]
        lines.append(f'| {case} | ' + ' | '.join(cells) + ' |')
    path.write_text('completed, rounds, utility (sum of stage-wise utilities over the perfect run\'s rounds, '
                    'as Table I sums greedy over SGCM\'s rounds) per follower setting\n\n'
                    + '\n'.join(lines) + '\n')


def _plot_disturbance(results: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    cases = list(results['cases'])
    fig, axes = _case_grid(plt, len(cases))
    styles = {'perfect': 'o-', 'disturbed': 's--', 'zero_trust': '^-.', 'random': 'x:', 'adversarial': 'v:'}
    for ax, case in zip(axes.flat, cases):
        for name, record in results['cases'][case].items():
            values = record['stage_utilities']
            ax.plot(range(1, len(values) + 1), values, styles[name], label=name, markersize=3)
        ax.set_title(case, fontsize=9)
    axes.flat[0].legend(fontsize=7)
    fig.suptitle('SGCM with disturbances, zero trust and hostile followers (Fig. 5)')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
