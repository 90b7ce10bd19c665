"""The SGCM leader's round on the kernel path and on the reference path, side by side (``scripts/bench sgcm``).

For every horizon T (default 1..4) and case (default the ten of config/sgcm/cases.yaml), the
leader's round is timed as the leader_planner node runs it: :meth:`LeaderRound.observe` at the
case's initial state (goal and stuck checks, the FSE over the horizon, her move and the
recommendation), once on the reference path (:class:`sgcm.core.fse.FSEPlanner`: numpy and the
fast stage-game solver per state) and ``repeats`` times on the kernel path
(:class:`sgcm.core.fse_compiled.CompiledFSEPlanner`, the default), back to back on the same state so
both see the same machine load. The two rounds must agree: both equilibrium values to
``VALUE_TOLERANCE``, her move and the recommended follower move exactly. |S_t| per stage comes with
the round; |S_T| (never built by the planners) is counted by the kernel outside the timed round.

``round_ms_median`` per horizon holds the median over the cases of each path's round time (the
kernel's per case: the median of its repeats) and their ratio, reference / kernel.

The MILP vs fast stage-game comparison stays: the reference round keeps a sample of the stage games
it solved, and the paper's MILP and the fast exact solver re-solve exactly those, side by side
(values compared); on these games one MILP takes about a second, so only a sample is timed.
"""
from __future__ import annotations

import json
import os
import statistics
import time
from pathlib import Path
from typing import Callable

from ..core.fse_compiled import CompiledFSEPlanner
from ..core.leader_round import LeaderRound, LeaderTurn
from ..core.stage_game import solve_fast, solve_milp
from ..core.task_config import Case, TaskConfig
from .inputs import CaseModels

VALUE_TOLERANCE = 1e-9
#: The issue's goals (issue 14): kernel round medians and the ratio at T = 3.
GOALS = {'T3_round_ms': 100.0, 'T4_round_ms': 1000.0, 'T3_ratio': 15.0}


def _timed(solver, ua, ub):
    start = time.perf_counter()
    solution = solver(ua, ub)
    return solution, time.perf_counter() - start


def timed_round(model, planner, state) -> tuple[LeaderTurn, float]:
    """One leader's round as the node runs it (a fresh LeaderRound: no rounds before), wall seconds."""
    leader = LeaderRound(model, 'sgcm', planner)
    start = time.perf_counter()
    turn = leader.observe(state)
    seconds = time.perf_counter() - start
    if not isinstance(turn, LeaderTurn):
        raise ValueError(f'the task is over at this state ({turn.reason}): nothing to plan')
    return turn, seconds


def _agreement(kernel: LeaderTurn, reference: LeaderTurn) -> dict:
    dv = max(abs(kernel.leader_value - reference.leader_value), abs(kernel.follower_value - reference.follower_value))
    same_actions = (kernel.action, kernel.recommended) == (reference.action, reference.recommended)
    same_states = kernel.plan.states_per_stage == reference.plan.states_per_stage
    return {'value_difference': dv, 'same_actions': same_actions, 'same_states_per_stage': same_states,
            'agree': dv <= VALUE_TOLERANCE and same_actions and same_states}


def run_benchmark(task: TaskConfig, cases: list[Case], out_dir: Path, horizons=(1, 2, 3, 4), repeats: int = 3,
                  milp_samples: int = 3, log: Callable[[str], None] = print) -> dict:
    load_start = os.getloadavg()
    rows = []
    milp_ms, fast_ms = [], []
    milp_mismatches = 0
    total = len(horizons) * len(cases)
    step = 0
    for horizon in horizons:
        # each case on its own task (grid, goals), one planner per path and distinct task
        references = CaseModels(task, 'reference', horizon=horizon, keep_stage_games=milp_samples)
        kernels = CaseModels(task, 'kernel', horizon=horizon)
        for case in cases:
            step += 1
            model = references.model(case)
            state = model.state_of(case)
            reference, reference_s = timed_round(model, references.planner(case), state)
            kernel_runs = [timed_round(model, kernels.planner(case), state) for _ in range(repeats)]
            kernel = kernel_runs[0][0]
            kernel_s = statistics.median(s for _, s in kernel_runs)
            check = _agreement(kernel, reference)
            kernel_planner: CompiledFSEPlanner = kernels.planner(case)
            terminal = kernel_planner.terminal_states(state)
            pair_ms = []
            for ua, ub in reference.plan.stage_game_samples:
                slow, slow_s = _timed(solve_milp, ua, ub)
                fast, fast_s = _timed(solve_fast, ua, ub)
                if (abs(slow.leader_value - fast.leader_value) > 1e-6
                        or abs(slow.follower_value - fast.follower_value) > 1e-6):
                    milp_mismatches += 1
                milp_ms.append(slow_s * 1e3)
                fast_ms.append(fast_s * 1e3)
                pair_ms.append((slow_s * 1e3, fast_s * 1e3, ua.shape))
            row = {'horizon': horizon, 'case': case.name,
                   'round_ms': {'kernel': kernel_s * 1e3, 'reference': reference_s * 1e3,
                                'ratio': reference_s / kernel_s},
                   'kernel_round_ms_runs': [s * 1e3 for _, s in kernel_runs],
                   'states_per_stage': kernel.plan.states_per_stage + [terminal],
                   'stage_games': kernel.plan.stage_games, 'lps_solved_reference': reference.plan.programs_solved,
                   'leader_value': {'kernel': kernel.leader_value, 'reference': reference.leader_value},
                   'follower_value': {'kernel': kernel.follower_value, 'reference': reference.follower_value},
                   'leader_action': {'kernel': kernel.action, 'reference': reference.action},
                   'recommended': {'kernel': kernel.recommended, 'reference': reference.recommended},
                   **check,
                   'sampled_games': [{'milp_ms': a, 'fast_ms': b, 'shape': list(s)} for a, b, s in pair_ms]}
            rows.append(row)
            log(f'[bench sgcm {step}/{total}] T={horizon} {case.name}: round {kernel_s * 1e3:.1f} ms kernel, '
                f'{reference_s * 1e3:.0f} ms reference (x{reference_s / kernel_s:.0f}); values '
                f'{"equal" if check["agree"] else "DIFFER"} (|dv| {check["value_difference"]:.1e}, actions '
                f'{"same" if check["same_actions"] else "DIFFERENT"}); |S_t| {row["states_per_stage"]}; '
                f'{len(pair_ms)} sampled games MILP/fast ' + ', '.join(f'{a:.0f}/{b:.2f} ms' for a, b, _ in pair_ms))
    results = {'benchmark': 'sgcm', 'rows': rows, **summarise(rows, horizons),
               'stage_game_ms_median': {'milp': statistics.median(milp_ms) if milp_ms else None,
                                        'fast': statistics.median(fast_ms) if fast_ms else None},
               'sampled_stage_games': len(milp_ms), 'value_mismatches': milp_mismatches,
               'repeats': repeats, 'load_average': {'start': list(load_start), 'end': list(os.getloadavg())}}
    if milp_ms:
        results['milp_over_fast'] = results['stage_game_ms_median']['milp'] / results['stage_game_ms_median']['fast']
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / 'results.json').write_text(json.dumps(results, indent=2))
    return results


def summarise(rows: list[dict], horizons) -> dict:
    """Per horizon: the medians of both paths and their ratio; the kernel/reference disagreements; the goals."""
    medians = {}
    for h in horizons:
        mine = [r for r in rows if r['horizon'] == h]
        kernel = statistics.median(r['round_ms']['kernel'] for r in mine)
        reference = statistics.median(r['round_ms']['reference'] for r in mine)
        medians[str(h)] = {'kernel': kernel, 'reference': reference, 'ratio': reference / kernel}
    disagreements = [f"T={r['horizon']} {r['case']}" for r in rows if not r['agree']]
    goals = {}
    if '3' in medians:
        goals['T3_round_ms'] = medians['3']['kernel'] <= GOALS['T3_round_ms']
        goals['T3_ratio'] = medians['3']['ratio'] >= GOALS['T3_ratio']
    if '4' in medians:
        goals['T4_round_ms'] = medians['4']['kernel'] <= GOALS['T4_round_ms']
    return {'round_ms_median': medians,
            'per_horizon_stage_games_median': {str(h): statistics.median(r['stage_games'] for r in rows
                                                                         if r['horizon'] == h) for h in horizons},
            'max_value_difference': max(r['value_difference'] for r in rows),
            'disagreements': disagreements, 'values_identical': not disagreements,
            'goals': {'targets': GOALS, 'met': goals}}

