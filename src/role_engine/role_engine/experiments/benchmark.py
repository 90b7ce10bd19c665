"""GP inference and GRA timing of the role engine (``scripts/bench gpmp``; on demand, not a test).

- **Time per GP plan, per formulation.** Every problem of ``benchmark.problems`` in
  ``config/roles/experiments.yaml`` (a map of the experiments, 200 x 200 cells, a start, a goal
  and the initial path: straight line or E-Map) is planned by each formulation of
  :mod:`.core.gp_planner` -- gtsam (the reference, ``repeats`` times), the previous vectorised
  numpy path and the compiled one (the default; :data:`FAST_REPEATS` times each) -- with the
  experiments' GP settings and ``benchmark.sigma_obs``, for one robot type
  (``benchmark.robot_radius``) on its own SDF. The plans of one problem are interleaved (one of
  each formulation per round), so load changes hit all of them alike. Every formulation must
  reach gtsam's final cost (relative difference <= :data:`COST_RTOL`), otherwise the times would
  not compare like with like; ``plan_ms_median`` is the median over all plans of a formulation,
  and the ratios are taken between those medians of the same run. The compiled kernels are
  loaded (or compiled) before the timing starts; that one-off time is ``compiled_warm_up_s``.
- **GRA time for n x n.** Group Role Assignment (:func:`.core.assignment.group_role_assignment`,
  Hungarian method with the workability check) on random Q with a share of inf entries (robots
  that cannot play a role), median of ``gra_repeats`` solves per n.
- **Role-player cycle time with four robots.** On the formation map (the bridge scenario of
  ``config/roles/formation_demo.yaml``, its boxes rasterised at the task's grid resolution, as
  ``roles-collab`` does), the central computer's initial process roles of the four robots are
  computed once; then one role-playing update (:func:`.core.formation_task.replan_process_role`,
  Algorithm 4 lines 3-6, with the task's conflict horizon and robot-avoidance settings) of each
  robot, with the three others' roles as on the shared channel and its position on its own role,
  is timed at every instant of :data:`ROLE_PLAYER_INSTANTS`, :data:`ROLE_PLAYER_REPEATS` times;
  ``role_player_cycle.cycle_ms_median`` is the median over all of them, with the task's GP
  formulation (the compiled one unless the settings file says otherwise);
  ``role_player_cycle_vectorised`` is the same cycle with the vectorised formulation. What the
  node adds per cycle (message conversion, publishing) is not included.

Run directly with ``python -m role_engine.experiments.benchmark [--config-dir DIR] [--out DIR]``.
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
from .collab_config import CollabScenario
from .collab_simulation import initial_process_roles, scenario_team
from ..core.conflict import SharedRole
from ..core.environment import environment_from_scenario
from ..core.formation_task import load_formation_task, replan_process_role
from ..core.assignment import group_role_assignment
from ..core.astar import EMapPlanner
from ..core.emap import build_emap
from ..core.environment import RobotType, load_map_file
from ..core.errors import RoleEngineError
from ..core import gp_compiled
from ..core.gp_planner import GPPlanner
from ..core.initial_paths import emap_trajectory, straight_line_trajectory
from .config import CONFIG_FILE, BenchmarkProblem, ExperimentConfig, load_experiment_config

Log = Callable[[str], None]

#: Largest relative difference of a formulation's final cost from gtsam's that counts as equal.
COST_RTOL = 1e-9
#: The reference formulation and the order the formulations are reported in.
REFERENCE = 'gtsam'
ORDER = ('gtsam', 'vectorised', 'compiled')
#: Timed plans per problem of the fast formulations (gtsam: ``benchmark.repeats``).
FAST_REPEATS = 15
#: The formation task whose map and team the role-player cycle is timed on (config dir relative).
ROLE_PLAYER_TASK = 'roles/formation_demo.yaml'
#: Shares of the roles' total time at which every robot's update is timed.
ROLE_PLAYER_INSTANTS = (0.1, 0.3, 0.5, 0.7)
#: Timed updates per robot and instant.
ROLE_PLAYER_REPEATS = 3


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
    counts = {f: settings.repeats if f == REFERENCE else max(settings.repeats, FAST_REPEATS) for f in ORDER}
    times_ms = {f: [] for f in ORDER}
    results = {}
    for round_ in range(max(counts.values())):          # interleaved: one plan of each formulation per round
        for formulation in ORDER:
            if round_ < counts[formulation]:
                began = time.perf_counter()
                results[formulation] = planner.plan(initial, config.total_time, formulation=formulation)
                times_ms[formulation].append((time.perf_counter() - began) * 1e3)
    for formulation, result in results.items():
        entry[formulation] = {
            'plan_ms': times_ms[formulation], 'plan_ms_median': statistics.median(times_ms[formulation]),
            'cost': result.cost, 'initial_cost': result.initial_cost, 'iterations': result.iterations,
            'converged': result.converged, 'collision_free': result.collision_free,
            'min_clearance_m': result.min_clearance, 'ran_as': result.formulation,
        }
    reference = entry[REFERENCE]['cost']
    entry['cost_relative_difference'] = {
        f: abs(entry[f]['cost'] - reference) / max(abs(reference), abs(entry[f]['cost']), 1e-300)
        for f in ORDER if f != REFERENCE}
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


def bench_role_player(config_dir: Path, repeats: int = ROLE_PLAYER_REPEATS,
                      instants=ROLE_PLAYER_INSTANTS, formulation: str | None = None) -> dict:
    """Median ms of one role-playing update of a robot with three others sharing roles (module docstring);
    ``formulation`` overrides the task's GP formulation."""
    task = load_formation_task(Path(config_dir) / ROLE_PLAYER_TASK)
    bridge, team = scenario_team(task)
    if len(team) != 4:
        raise RoleEngineError(f'{ROLE_PLAYER_TASK}: the role-player benchmark needs four robots (got {len(team)})')
    environment = environment_from_scenario(bridge, task.grid_resolution)
    initial = initial_process_roles(CollabScenario('formation', task, None), environment, team)
    roles = {m.name: SharedRole(m.name, initial[m.name], task.total_time, m.robot_type.radius, 0.0) for m in team}
    views = {m.name: environment.for_robot(m.robot_type) for m in team}
    times_ms, conflicts, kept, per_robot = [], 0, 0, {}
    for member in team:
        own = roles[member.name]
        others = [role for name, role in roles.items() if name != member.name]
        config = task.gp_config(member.robot_type)
        if formulation is not None:
            config = dataclasses.replace(config, formulation=formulation)
        robot_ms = []
        for share in instants:
            now = share * task.total_time
            position = own.positions([now])[0]
            for _ in range(repeats):
                began = time.perf_counter()
                result = replan_process_role(config, views[member.name], own, others, now, position,
                                             horizon=task.conflict_horizon, avoidance=task.robot_avoidance)
                robot_ms.append((time.perf_counter() - began) * 1e3)
            conflicts += bool(result.conflicting)
            kept += result.trajectory is None
        per_robot[member.name] = statistics.median(robot_ms)
        times_ms += robot_ms
    return {'cycle_ms_median': statistics.median(times_ms), 'cycle_ms_max': max(times_ms),
            'per_robot_ms_median': per_robot, 'robots': len(team), 'others_per_update': len(team) - 1,
            'map': str(task.scenario), 'map_cells': list(environment.shape), 'states': task.states,
            'instants_s': [share * task.total_time for share in instants], 'repeats': repeats,
            'updates_timed': len(times_ms), 'instants_with_conflicts': conflicts, 'instants_role_kept': kept,
            'replan_period_s': task.replan_period, 'formulation': config.formulation}


def _versions() -> dict:
    found = {}
    for package in ('numpy', 'scipy', 'gtsam', 'numba'):
        try:
            found[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            found[package] = None
    return {'python': platform.python_version(), 'machine': platform.machine(), 'cpu_count': os.cpu_count(), **found}


def _load() -> list[float]:
    return [round(v, 2) for v in os.getloadavg()]


def run_benchmark(config_dir: str | Path, out_dir: str | Path, log: Log = print) -> dict:
    """Run the benchmark (module docstring); writes ``out_dir/results.json`` and returns it."""
    config = load_experiment_config(Path(config_dir) / CONFIG_FILE)
    settings = config.benchmark
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    load_before = _load()
    began = time.perf_counter()
    gp_compiled.warm_up()
    warm_up_s = time.perf_counter() - began
    log(f'[bench gpmp] GP plans: {config.states} states over {config.total_time:g} s, sigma_obs '
        f'{settings.sigma_obs:g}, robot radius {settings.robot_radius:g} m; {settings.repeats} plans per problem '
        f'with gtsam, {max(settings.repeats, FAST_REPEATS)} with vectorised and compiled (interleaved); compiled '
        f'kernels loaded in {warm_up_s:.2f} s; load average {load_before}')
    problems = []
    for index, problem in enumerate(settings.problems):
        entry = bench_problem(index, problem, config)
        problems.append(entry)
        log(f'[bench gpmp {index + 1}/{len(settings.problems)}] {problem.map} {problem.init}: '
            + ', '.join(f"{f} {entry[f]['plan_ms_median']:.2f} ms ({entry[f]['iterations']} it, cost "
                        f"{entry[f]['cost']:.10g}, {'free' if entry[f]['collision_free'] else 'IN COLLISION'})"
                        for f in ORDER)
            + '; relative difference from gtsam: '
            + ', '.join(f'{f} {d:.1e}' for f, d in entry['cost_relative_difference'].items()))
    medians = {f: statistics.median(t for p in problems for t in p[f]['plan_ms']) for f in ORDER}
    worst = {f: max(p['cost_relative_difference'][f] for p in problems) for f in ORDER if f != REFERENCE}
    ran_as = {f: sorted({p[f]['ran_as'] for p in problems}) for f in ORDER}
    costs_equal = all(d <= COST_RTOL for d in worst.values()) and ran_as['compiled'] == ['compiled']
    gra_ms = bench_gra(settings.gra_sizes, settings.gra_repeats, settings.gra_inf_fraction)
    log('[bench gpmp] GRA median ms: ' + ', '.join(f'n = {n}: {ms:.3f}' for n, ms in gra_ms.items()))
    cycle = bench_role_player(Path(config_dir))
    cycle_vectorised = bench_role_player(Path(config_dir), formulation='vectorised')
    for row in (cycle, cycle_vectorised):
        log(f"[bench gpmp] role-player cycle time, 4 robots, {row['formulation']} ({row['updates_timed']} updates "
            f"on {Path(row['map']).name}, {row['map_cells'][0]} x {row['map_cells'][1]} cells, {row['states']} "
            f"states): median {row['cycle_ms_median']:.1f} ms, max {row['cycle_ms_max']:.1f} ms (replan period "
            f"{row['replan_period_s'] * 1e3:.0f} ms)")
    load_after = _load()
    results = {
        'benchmark': 'gpmp', 'config': str(config.path), 'states': config.states,
        'total_time_s': config.total_time, 'repeats': settings.repeats,
        'fast_repeats': max(settings.repeats, FAST_REPEATS), 'sigma_obs': settings.sigma_obs,
        'robot_radius': settings.robot_radius,
        'gp_config': dataclasses.asdict(config.gp_config(settings.sigma_obs)),
        'reference': REFERENCE, 'plan_ms_median': medians,
        'ratio_gtsam_over_compiled': medians['gtsam'] / medians['compiled'],
        'ratio_vectorised_over_compiled': medians['vectorised'] / medians['compiled'],
        'ratio_gtsam_over_vectorised': medians['gtsam'] / medians['vectorised'],
        'cost_max_relative_difference': worst, 'cost_rtol': COST_RTOL, 'costs_equal': costs_equal,
        'ran_as': ran_as, 'compiled_warm_up_s': warm_up_s,
        'gra_ms_median': gra_ms, 'gra_repeats': settings.gra_repeats, 'gra_inf_fraction': settings.gra_inf_fraction,
        'role_player_cycle': cycle, 'role_player_cycle_ms_median': cycle['cycle_ms_median'],
        'role_player_cycle_vectorised': cycle_vectorised,
        'load_average': {'before': load_before, 'after': load_after},
        'problems': problems, 'environment': _versions(),
    }
    (out_dir / 'results.json').write_text(json.dumps(results, indent=2) + '\n')
    log('[bench gpmp] median ms per plan: ' + ', '.join(f'{f} {medians[f]:.2f}' for f in ORDER)
        + f"; final costs {'equal' if costs_equal else 'DIFFER'} (max relative difference from gtsam: "
        + ', '.join(f'{f} {d:.1e}' for f, d in worst.items()) + f'; load average {load_after})')
    log(f"[bench gpmp] ratios: gtsam / compiled {results['ratio_gtsam_over_compiled']:.0f}x, vectorised / compiled "
        f"{results['ratio_vectorised_over_compiled']:.1f}x, gtsam / vectorised "
        f"{results['ratio_gtsam_over_vectorised']:.1f}x")
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
