"""Table I and Fig. 4 of the SGCM paper (stackelberg_guidance_sgcm, Section V-A): greedy vs SGCM.

Every case is played twice, by the greedy baseline (each robot maximises its own one-stage
utility, no guidance) and by SGCM (Algorithm 1 with an obedient follower); the centralized
planner gives a lower bound on the rounds. ``--mode core`` plays the abstract game (without
execution failures unless ``--failures``); ``--mode sim`` runs both arms in pybullet through the
leader_planner and follower_executor nodes, records every run and computes the table from the
bags (:mod:`.sim_runner`). Utilities follow Table I's accounting (core/episode.py): the sum over
SGCM's rounds of r(state after the round) minus both robots' costs, the greedy run padded with
idle rounds at its final state if it ended sooner.

Writes ``table1.md`` (ours, the centralized rounds, and the paper's Table I row of the same case number
beside each case, compared in kind: :mod:`.table1_paper`), ``paper_notes.md`` (every difference from the
paper: the cases are the project's own, the utility scale, rounds and failures) and
``stage_utilities.png`` (Fig. 4: stage-wise utility per round, every case).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
from collab_tools.experiments import plots
from collab_tools.experiments.api import ExperimentRequest, ExperimentResult, Log
from collab_tools.experiments.checkpoint import fresh_step_dir

from ..core.centralized import CentralizedPlanner
from ..core.episode import EpisodeResult, RoundRecord, run_greedy, run_sgcm
from ..core.rearrangement import RearrangementModel
from ..core.scenario_builder import build_scenario
from ..core.task_config import Case, TaskConfig, task_of
from .case_plots import case_grid
from .inputs import CaseModels, cases_file, planner_path, task_and_cases, task_file
from .table1_paper import paper_comparison, paper_notes, paper_table

#: episodes(index, case) -> (SGCM episode, greedy episode)
Episodes = Callable[[int, Case], tuple[EpisodeResult, EpisodeResult]]


@dataclass
class CaseOutcome:
    case: str
    sgcm: EpisodeResult
    greedy: EpisodeResult
    greedy_stage_utilities: list[float]   # over SGCM's rounds, padded (Table I accounting)
    sgcm_utility: float
    greedy_utility: float
    centralized_rounds: int | None


def episode_from_dict(saved: dict) -> EpisodeResult:
    """An episode back from :meth:`EpisodeResult.to_dict` (a checkpointed case)."""
    return EpisodeResult(**{**saved, 'records': [RoundRecord(**r) for r in saved['records']]})


def final_reward(model: RearrangementModel, episode: EpisodeResult) -> float:
    return float(model.reward(np.array(episode.final_state)))


def run(request: ExperimentRequest) -> ExperimentResult:
    task, cases = task_and_cases(request)
    mode = request.option('mode', 'core')
    if mode == 'sim':
        episodes = sim_episodes(task, task_file(request).resolve(), cases, Path(request.run_dir),
                                Path(request.config_dir), request.log, request.seed)
    else:
        episodes = core_episodes(task, bool(request.option('failures', False)), request.seed, planner_path(request))
    with request.progress('sgcm-table1', len(cases)) as steps:   # each case checkpointed, restored by --resume
        outcomes = play_cases(task, cases, steps.checkpointed(
            episodes, key=lambda index, case: case.name, encode=lambda pair: [e.to_dict() for e in pair],
            decode=lambda saved: tuple(episode_from_dict(e) for e in saved),
            describe=lambda pair: f'SGCM {pair[0].rounds} rounds, greedy {pair[1].rounds}'), request.log)
    data, acceptance = table1_results(outcomes, task, mode, cases)
    data['paper_comparison'] = paper_comparison(outcomes, task, cases)
    report = write_table1(outcomes, Path(request.run_dir), data['paper_comparison'])
    (Path(request.run_dir) / 'paper_notes.md').write_text(
        paper_notes(data['paper_comparison'], task, mode, str(cases_file(request)), bool(request.option('failures'))))
    completed = sum(o.sgcm.completed for o in outcomes)
    stuck = acceptance['greedy_stuck_cases']
    return ExperimentResult(
        passed=acceptance.pop('passed'), report=report, acceptance=acceptance, data=data, report_file='table1.md',
        outcome=f'{mode}: SGCM completed {completed} of {len(outcomes)} cases; greedy stuck in {len(stuck)}'
                + (f" ({', '.join(stuck)})" if stuck else ''))


def core_episodes(task: TaskConfig, simulate_failures: bool = False, seed: int = 0, path: str = 'kernel') -> Episodes:
    """Both strategies in the abstract game (of the case's own task), case ``index`` seeded with ``seed + index``;
    ``path``: the leader's FSE path (kernel or reference)."""
    games = CaseModels(task, path)

    def in_core(index, case):
        model = games.model(case)
        state = model.state_of(case)
        return (run_sgcm(model, state, planner=games.planner(case), simulate_failures=simulate_failures,
                         seed=seed + index),
                run_greedy(model, state, simulate_failures=simulate_failures, seed=seed + index))
    return in_core


def sim_episodes(task: TaskConfig, task_path: Path, cases: list[Case], run_dir: Path, config_dir: Path,
                 log: Log = print, seed: int = 0) -> Episodes:
    """Both strategies in simulation, each run recorded under ``run_dir/<case>/<strategy>``."""
    from .sim_runner import episode_from_bag, run_case  # ROS and the orchestration only when simulating
    for case in cases:   # every case's set-up is checked before anything runs (TaskConfigError names it)
        build_scenario(task, case)
    games = CaseModels(task)
    quiet = lambda _text: None  # noqa: E731  (the session's own lines would drown the progress)

    def in_sim(index, case):
        found = {}
        for strategy in ('greedy', 'sgcm'):
            case_dir = fresh_step_dir(run_dir, run_dir / case.name / strategy)   # an interrupted try set aside
            log(f'[sgcm-table1 {index}/{len(cases)}] {case.name}: running {strategy} in simulation '
                f'({case_dir})')
            result = run_case(task, task_path, case, case_dir, config_dir, strategy=strategy,
                              seed=seed + index, log=quiet)
            if result.exit_code != 0 or result.bag is None:
                raise RuntimeError(f'{case.name} {strategy}: simulation run failed ({result.message}); '
                                   f'logs in {case_dir / "logs"}')
            found[strategy] = episode_from_bag(games.model(case), result.bag, strategy)
        return found['sgcm'], found['greedy']
    return in_sim


def play_cases(task: TaskConfig, cases: list[Case], episodes: Episodes, log: Log = print) -> list[CaseOutcome]:
    games = CaseModels(task)
    centrals: dict[int, CentralizedPlanner] = {}
    outcomes = []
    for index, case in enumerate(cases, start=1):
        model = games.model(case)
        central = centrals.setdefault(id(model), CentralizedPlanner(model))
        sgcm, greedy = episodes(index, case)
        greedy_over = greedy.stage_utilities_over(sgcm.rounds, final_reward(model, greedy))
        outcome = CaseOutcome(case.name, sgcm, greedy, greedy_over,
                              sgcm.utility_over(sgcm.rounds, final_reward(model, sgcm)),
                              float(sum(greedy_over)), central.plan(model.state_of(case)).rounds)
        outcomes.append(outcome)
        log(f'[sgcm-table1 {index}/{len(cases)}] {case.name}: greedy '
            f'{"completed" if greedy.completed else "stuck"} in {greedy.rounds} rounds, SGCM '
            f'{"completed" if sgcm.completed else "NOT completed"} in {sgcm.rounds} rounds '
            f'(centralized {outcome.centralized_rounds}), utility {outcome.greedy_utility:.1f} vs '
            f'{outcome.sgcm_utility:.1f}')
    return outcomes


def case_layout(case: Case, task: TaskConfig) -> dict:
    """The grid, goals and arm placement of a case played on its own task (results.json)."""
    own = task_of(case, task)
    ws = own.workspace
    return {'rows': own.rows, 'cols': own.cols, 'cell_capacity': own.cell_capacity,
            'goals': {colour: list(divmod(goal, own.cols)) for colour, goal in zip(own.colours, own.goals)},
            'cell_size': ws.cell_size, 'cube_size': ws.cube_size, 'arm_axis': ws.arm_axis,
            'arm_distance': ws.arm_distance}


def table1_results(outcomes: list[CaseOutcome], task: TaskConfig, mode: str = 'core',
                   played: list[Case] | None = None) -> tuple[dict, dict]:
    """(data, acceptance) of results.json; acceptance['passed'] is the overall check.

    ``played``: the cases (same order as ``outcomes``); one with its own grid or goals gets its
    ``layout`` in its entry."""
    cases = []
    for index, o in enumerate(outcomes):
        own = played[index] if played else None
        cases.append({
            'case': o.case,
            'greedy': {'completed': o.greedy.completed, 'stuck': o.greedy.stuck, 'rounds': o.greedy.rounds,
                       'utility': o.greedy_utility, 'stage_utilities': o.greedy.stage_utilities},
            'sgcm': {'completed': o.sgcm.completed, 'rounds': o.sgcm.rounds, 'utility': o.sgcm_utility,
                     'stage_utilities': o.sgcm.stage_utilities,
                     'planning_seconds': [r.planning_seconds for r in o.sgcm.records]},
            'centralized': {'rounds': o.centralized_rounds},
        })
        if own is not None and task_of(own, task) is not task:
            cases[-1]['layout'] = case_layout(own, task)

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
    data = {'mode': mode, 'horizon': task.horizon,
            'failure_probability': {'leader': task.leader.failure_probability,
                                    'follower': task.follower.failure_probability},
            'utility_accounting': 'sum over SGCM rounds of r(state after round) - both costs',
            'cases': cases}
    return data, acceptance


def _rounds_text(episode: EpisodeResult) -> str:
    return str(episode.rounds) if episode.completed else f'never (stuck after {episode.rounds})'


def write_table1(outcomes: list[CaseOutcome], run_dir: Path, comparison: dict | None = None) -> str:
    """stage_utilities.png in ``run_dir``; returns the table for table1.md (with the paper's rows beside
    ours when ``comparison``, from :func:`.table1_paper.paper_comparison`, is given)."""
    run_dir.mkdir(parents=True, exist_ok=True)
    lines = ['| case | greedy status | greedy rounds | greedy utility | SGCM status | SGCM rounds | '
             'SGCM utility | centralized rounds |', '|---|---|---|---|---|---|---|---|']
    for o in outcomes:
        lines.append(f'| {o.case} | {"Yes" if o.greedy.completed else "No"} | {_rounds_text(o.greedy)} | '
                     f'{o.greedy_utility:.1f} | {"Yes" if o.sgcm.completed else "No"} | '
                     f'{_rounds_text(o.sgcm)} | {o.sgcm_utility:.1f} | {o.centralized_rounds} |')
    table = '\n'.join(lines) + '\n'
    if comparison is not None:
        table += '\n' + paper_table(comparison)
    _plot_stage_utilities(outcomes, run_dir / 'stage_utilities.png')
    return table


def _plot_stage_utilities(outcomes: list[CaseOutcome], path: Path) -> None:
    fig, axes = case_grid(len(outcomes))
    for ax, o in zip(axes.flat, outcomes):
        rounds = range(1, o.sgcm.rounds + 1)
        ax.plot(rounds, o.sgcm.stage_utilities, 'o-', label='SGCM')
        ax.plot(rounds, o.greedy_stage_utilities, 's--', label='greedy')
        ax.set_title(f'{o.case} ({"stuck" if not o.greedy.completed else "both complete"})', fontsize=9)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle('Stage-wise utility, SGCM vs greedy (Fig. 4)')
    plots.save(fig, path)
