"""GP inference and GRA timing of the role engine (``scripts/bench gpmp``; on demand, not a test).

- **Time per GP plan, per formulation.** Every problem of ``benchmark.problems`` in
  ``config/roles/experiments.yaml`` (a map of the experiments, 200 x 200 cells, a start, a goal
  and the initial path: straight line or E-Map) is planned ``repeats`` times by the vectorised
  and by the gtsam formulation (:mod:`.core.gp_planner`) with the experiments' GP settings and
  ``benchmark.sigma_obs``, for one robot type (``benchmark.robot_radius``) on its own SDF. Both
  formulations must reach the same final cost (relative difference <= :data:`COST_RTOL`),
  otherwise the times would not compare like with like; ``plan_ms_median`` is the median over
  all plans of a formulation.
- **GRA time for n x n.** Group Role Assignment (:func:`.core.assignment.group_role_assignment`,
  Hungarian method with the workability check) on random Q with a share of inf entries (robots
  that cannot play a role), median of ``gra_repeats`` solves per n.
- **Role-player cycle time** with four robots is not measured: the role_player node does not
  exist yet. The results say so (``role_player_cycle.skipped``).

Run directly with ``python -m role_engine.benchmark [--config-dir DIR] [--out DIR]``.
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib.metadata
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

from .benchmark_core import median_ms
from .core.assignment import group_role_assignment
from .core.astar import EMapPlanner
from .core.emap import build_emap
from .core.environment import RobotType, load_map_file
from .core.errors import RoleEngineError
from .core.gp_planner import FORMULATIONS, GPPlanner
from .core.initial_paths import emap_trajectory, straight_line_trajectory
from .experiments import CONFIG_FILE, BenchmarkProblem, ExperimentConfig, load_experiment_config

Log = Callable[[str], None]

#: Largest relative difference of the two formulations' final costs that counts as equal.
COST_RTOL = 1e-6
ROLE_PLAYER_SKIPPED = 'the role_player node does not exist yet; its cycle time is not measured'


def _initial_trajectory(problem: BenchmarkProblem, planner: EMapPlanner, config: ExperimentConfig) -> np.ndarray:
    intervals = config.states - 1
    if problem.init == 'straight':
        return straight_line_trajectory(problem.start, problem.goal, config.total_time, intervals)
    trajectory, _ = emap_trajectory(planner, problem.start, problem.goal, config.total_time, intervals)
    return trajectory


def bench_problem(index: int, problem: BenchmarkProblem, config: ExperimentConfig) -> dict:
    """Plan one problem ``repeats`` times with each formulation; times, costs and their agreement."""
    settings = config.benchmark
    environment = load_map_file(config.map_file(problem.map))
    view = environment.for_robot(RobotType(f'r{settings.robot_radius:g}', settings.robot_radius))
    where = f'benchmark.problems[{index}]'
    for key in ('start', 'goal'):
        if not view.is_visitable(getattr(problem, key)):
            raise RoleEngineError(f'{where}.{key}: {list(getattr(problem, key))} is not visitable on {problem.map} '
                                  f'for a robot of radius {settings.robot_radius} m')
    try:
        initial = _initial_trajectory(problem, EMapPlanner(build_emap(view)), config)
    except RoleEngineError as error:
        raise RoleEngineError(f'{where}: {error}') from None
    planner = GPPlanner(config.gp_config(settings.sigma_obs), view.sdf)
    entry = {'map': problem.map, 'start': list(problem.start), 'goal': list(problem.goal), 'init': problem.init,
             'map_cells': list(environment.shape), 'initial_clearance_m': planner.clearance(initial, config.total_time)}
    for formulation in FORMULATIONS:
        times_ms, result = [], None
        for _ in range(settings.repeats):
            began = time.perf_counter()
            result = planner.plan(initial, config.total_time, formulation=formulation)
            times_ms.append((time.perf_counter() - began) * 1e3)
        entry[formulation] = {
            'plan_ms': times_ms, 'plan_ms_median': statistics.median(times_ms), 'cost': result.cost,
            'initial_cost': result.initial_cost, 'iterations': result.iterations, 'converged': result.converged,
            'collision_free': result.collision_free, 'min_clearance_m': result.min_clearance,
        }
    costs = [entry[f]['cost'] for f in FORMULATIONS]
    entry['cost_relative_difference'] = abs(costs[0] - costs[1]) / max(abs(costs[0]), abs(costs[1]), 1e-300)
    return entry


def bench_gra(sizes, repeats: int, inf_fraction: float, seed: int = 0) -> dict:
    """Median ms of GRA on a random workable n x n Q per n (inf entries off the diagonal only)."""
    rng = np.random.default_rng(seed)
    timings = {}
    for n in sizes:
        q = rng.uniform(0.0, 1.0, size=(n, n))
        q[rng.uniform(size=(n, n)) < inf_fraction] = np.inf
        np.fill_diagonal(q, rng.uniform(0.0, 1.0, size=n))     # a finite diagonal keeps it workable
        result = group_role_assignment(q)
        if not result.feasible:
            raise RoleEngineError(f'GRA benchmark: the {n} x {n} problem is not workable ({result.reason})')
        timings[str(n)] = median_ms(lambda: group_role_assignment(q), repeats)
    return timings


def _versions() -> dict:
    found = {}
    for package in ('numpy', 'scipy', 'gtsam'):
        try:
            found[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            found[package] = None
    return {'python': platform.python_version(), 'machine': platform.machine(), 'cpu_count': os.cpu_count(), **found}


def run_benchmark(config_dir: str | Path, out_dir: str | Path, log: Log = print) -> dict:
    """Run the benchmark (module docstring); writes ``out_dir/results.json`` and returns it."""
    config = load_experiment_config(Path(config_dir) / CONFIG_FILE)
    settings = config.benchmark
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    log(f'[bench gpmp] GP plans: {config.states} states over {config.total_time:g} s, sigma_obs '
        f'{settings.sigma_obs:g}, robot radius {settings.robot_radius:g} m, {settings.repeats} repeats per '
        f'formulation')
    problems = []
    for index, problem in enumerate(settings.problems):
        entry = bench_problem(index, problem, config)
        problems.append(entry)
        log(f'[bench gpmp {index + 1}/{len(settings.problems)}] {problem.map} {problem.init}: '
            + ', '.join(f"{f} {entry[f]['plan_ms_median']:.1f} ms ({entry[f]['iterations']} it, cost "
                        f"{entry[f]['cost']:.6g}, {'free' if entry[f]['collision_free'] else 'IN COLLISION'})"
                        for f in FORMULATIONS)
            + f"; cost relative difference {entry['cost_relative_difference']:.1e}")
    medians = {f: statistics.median(t for p in problems for t in p[f]['plan_ms']) for f in FORMULATIONS}
    worst = max(p['cost_relative_difference'] for p in problems)
    gra_ms = bench_gra(settings.gra_sizes, settings.gra_repeats, settings.gra_inf_fraction)
    log('[bench gpmp] GRA median ms: ' + ', '.join(f'n = {n}: {ms:.3f}' for n, ms in gra_ms.items()))
    log(f'[bench gpmp] role-player cycle time: skipped ({ROLE_PLAYER_SKIPPED})')
    results = {
        'benchmark': 'gpmp', 'config': str(config.path), 'states': config.states,
        'total_time_s': config.total_time, 'repeats': settings.repeats, 'sigma_obs': settings.sigma_obs,
        'robot_radius': settings.robot_radius,
        'gp_config': dataclasses.asdict(config.gp_config(settings.sigma_obs)),
        'plan_ms_median': medians,
        'ratio_gtsam_over_vectorised': medians['gtsam'] / medians['vectorised'],
        'cost_max_relative_difference': worst, 'cost_rtol': COST_RTOL, 'costs_equal': worst <= COST_RTOL,
        'gra_ms_median': gra_ms, 'gra_repeats': settings.gra_repeats, 'gra_inf_fraction': settings.gra_inf_fraction,
        'role_player_cycle': {'skipped': True, 'reason': ROLE_PLAYER_SKIPPED},
        'problems': problems, 'environment': _versions(),
    }
    (out_dir / 'results.json').write_text(json.dumps(results, indent=2) + '\n')
    log(f"[bench gpmp] median ms per plan: " + ', '.join(f'{f} {medians[f]:.1f}' for f in FORMULATIONS)
        + f"; final costs {'equal' if results['costs_equal'] else 'DIFFER'} (max relative difference {worst:.1e})")
    log(f"[bench gpmp] ratio gtsam / vectorised: {results['ratio_gtsam_over_vectorised']:.1f}x")
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--config-dir', type=Path, default=Path(__file__).resolve().parents[3] / 'config',
                        help="the workspace's config/ directory (default: the source tree's)")
    parser.add_argument('--out', type=Path, default=Path('bench-gpmp'), help='output directory')
    args = parser.parse_args(argv)
    results = run_benchmark(args.config_dir, args.out)
    print(args.out)
    return 0 if results['costs_equal'] else 1


if __name__ == '__main__':
    sys.exit(main())
