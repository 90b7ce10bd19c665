"""Leader compute time per round for T = 1..4, MILP path vs fast path (``scripts/bench sgcm``).

For every horizon and case the leader plans once at the case's initial state with the
fast stage solver (the whole rolling-horizon step: forward prediction and dynamic
programming), and keeps a sample of the stage games it solved. The MILP path and the
fast path then solve exactly those games, side by side, and must agree on both
equilibrium values; their median times per stage game give the ratio. The MILP path is
timed on a sample only: on these games one MILP solve takes about a second, and a
T = 3 round has thousands of stage games.
"""
from __future__ import annotations

import json
import statistics
import time
from pathlib import Path
from typing import Callable

from ..core.stage_game import solve_fast, solve_milp
from ..core.task_config import Case, TaskConfig
from .inputs import CaseModels

VALUE_TOLERANCE = 1e-6


def _timed(solver, ua, ub):
    start = time.perf_counter()
    solution = solver(ua, ub)
    return solution, time.perf_counter() - start


def run_benchmark(task: TaskConfig, cases: list[Case], out_dir: Path, horizons=(1, 2, 3, 4),
                  milp_samples: int = 3, log: Callable[[str], None] = print) -> dict:
    rows = []
    milp_ms, fast_ms = [], []
    mismatches = 0
    total = len(horizons) * len(cases)
    step = 0
    for horizon in horizons:
        # each case on its own task (grid, goals), one planner per distinct task
        games = CaseModels(task, horizon=horizon, keep_stage_games=milp_samples, count_terminal_states=True)
        for case in cases:
            step += 1
            result = games.planner(case).plan(games.model(case).state_of(case))
            pair_ms = []
            for ua, ub in result.stage_game_samples:
                slow, slow_s = _timed(solve_milp, ua, ub)
                fast, fast_s = _timed(solve_fast, ua, ub)
                if (abs(slow.leader_value - fast.leader_value) > VALUE_TOLERANCE
                        or abs(slow.follower_value - fast.follower_value) > VALUE_TOLERANCE):
                    mismatches += 1
                milp_ms.append(slow_s * 1e3)
                fast_ms.append(fast_s * 1e3)
                pair_ms.append((slow_s * 1e3, fast_s * 1e3, ua.shape))
            row = {'horizon': horizon, 'case': case.name, 'round_ms': result.seconds * 1e3,
                   'states_per_stage': result.states_per_stage, 'stage_games': result.stage_games,
                   'lps_solved': result.programs_solved,
                   'sampled_games': [{'milp_ms': a, 'fast_ms': b, 'shape': list(s)} for a, b, s in pair_ms]}
            rows.append(row)
            log(f'[bench sgcm {step}/{total}] T={horizon} {case.name}: round {row["round_ms"]:.1f} ms, '
                f'states per stage {result.states_per_stage}, {result.stage_games} stage games, '
                f'{len(pair_ms)} sampled games MILP/fast '
                + ', '.join(f'{a:.0f}/{b:.2f} ms' for a, b, _ in pair_ms))
    summary = {
        'per_horizon_round_ms_median': {
            str(h): statistics.median(r['round_ms'] for r in rows if r['horizon'] == h) for h in horizons},
        'per_horizon_stage_games_median': {
            str(h): statistics.median(r['stage_games'] for r in rows if r['horizon'] == h) for h in horizons},
        'stage_game_ms_median': {'milp': statistics.median(milp_ms), 'fast': statistics.median(fast_ms)},
        'sampled_stage_games': len(milp_ms),
        'value_mismatches': mismatches,
    }
    summary['milp_over_fast'] = summary['stage_game_ms_median']['milp'] / summary['stage_game_ms_median']['fast']
    results = {'benchmark': 'sgcm', 'rows': rows, **summary}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / 'results.json').write_text(json.dumps(results, indent=2))
    return results
