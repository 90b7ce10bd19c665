#!/usr/bin/env python3
"""Benchmark of GP inference (role engine): time per plan for each formulation, side by side.

    scripts/bench_gpmp.py [--out bench-gpmp-results.json] [--repeats 3] [--states 100]
                          [--interpolation 0] [--max-speed S]

Every problem is a straight-line initial trajectory (GPMP's classic start) through a 5 x 5 m
arena rasterised at 200 x 200 cells, whose signed distance field is built here with
``scipy.ndimage.distance_transform_edt`` and queried bilinearly (the role engine's own SDF works
the same way; this script does not depend on it). Each problem is planned ``--repeats`` times
by the vectorised and by the gtsam formulation with the same configuration; the script prints
per-problem medians, checks that both formulations reach the same final cost (relative
difference <= 1e-6), writes ``plan_ms_median`` per formulation (median over all plans) to the
JSON file, and prints the time ratio last. Exit status 1 if the costs disagree.

On demand only (several seconds per gtsam plan): it is not part of the test suite.
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

import numpy as np
from scipy import ndimage

WORKSPACE = Path(__file__).resolve().parents[1]
try:
    import role_engine.core.gp_planner  # noqa: F401
except ImportError:
    sys.path.insert(0, str(WORKSPACE / 'src' / 'role_engine'))

from role_engine.core.gp_planner import GPPlanner, GPPlannerConfig  # noqa: E402

ARENA_M = 5.0
CELLS = 200
TOTAL_TIME_S = 20.0
COST_RTOL = 1e-6
FORMULATIONS = ('vectorised', 'gtsam')

#: Obstacles of the arena: discs (cx, cy, r) and boxes (x_min, y_min, x_max, y_max), metres.
DISCS = [(2.5, 2.5, 0.6), (1.2, 1.3, 0.35), (3.8, 3.7, 0.4)]
BOXES = [(1.0, 3.3, 1.6, 4.3), (3.3, 0.6, 3.9, 1.8)]

#: Start and goal positions; every straight line between them crosses an obstacle.
PROBLEMS = {
    'diagonal': ((0.4, 0.4), (4.6, 4.5)),
    'west_east': ((0.3, 2.4), (4.7, 2.7)),
    'north_south': ((1.3, 4.8), (1.2, 0.3)),
    'anti_diagonal': ((0.4, 3.0), (4.6, 1.9)),
}


class GridSDF:
    """Signed distance (m) of an occupancy grid, bilinear between cell centres.

    Distances are Euclidean distance transforms shifted by half a cell so the obstacle
    surface lies on cell boundaries; the gradient is that of the bilinear interpolant.
    Points beyond the outer cell centres are clamped onto them.
    """

    def __init__(self, occupied: np.ndarray, resolution: float):
        outside = ndimage.distance_transform_edt(~occupied)
        inside = ndimage.distance_transform_edt(occupied)
        self.data = np.where(occupied, -(inside - 0.5), outside - 0.5) * resolution
        self.resolution = resolution

    def query(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        ny, nx = self.data.shape
        fx = np.clip(points[:, 0] / self.resolution - 0.5, 0.0, nx - 1.0)
        fy = np.clip(points[:, 1] / self.resolution - 0.5, 0.0, ny - 1.0)
        ix0 = np.minimum(fx.astype(int), nx - 2)
        iy0 = np.minimum(fy.astype(int), ny - 2)
        tx, ty = fx - ix0, fy - iy0
        d00, d01 = self.data[iy0, ix0], self.data[iy0, ix0 + 1]
        d10, d11 = self.data[iy0 + 1, ix0], self.data[iy0 + 1, ix0 + 1]
        distance = (1 - ty) * ((1 - tx) * d00 + tx * d01) + ty * ((1 - tx) * d10 + tx * d11)
        gradient = np.column_stack([(1 - ty) * (d01 - d00) + ty * (d11 - d10),
                                    (1 - tx) * (d10 - d00) + tx * (d11 - d01)]) / self.resolution
        return distance, gradient


def arena_sdf() -> GridSDF:
    resolution = ARENA_M / CELLS
    centres = (np.arange(CELLS) + 0.5) * resolution
    x, y = np.meshgrid(centres, centres)            # occupied[iy, ix], y up
    occupied = np.zeros((CELLS, CELLS), dtype=bool)
    for cx, cy, r in DISCS:
        occupied |= np.hypot(x - cx, y - cy) <= r
    for x0, y0, x1, y1 in BOXES:
        occupied |= (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
    return GridSDF(occupied, resolution)


def straight_line(start, goal, state_count: int, total_time: float) -> np.ndarray:
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    positions = start + np.linspace(0.0, 1.0, state_count)[:, None] * (goal - start)
    return np.hstack([positions, np.broadcast_to((goal - start) / total_time, (state_count, 2))])


def bench_problem(planner: GPPlanner, name: str, state_count: int, repeats: int) -> dict:
    start, goal = PROBLEMS[name]
    initial = straight_line(start, goal, state_count, TOTAL_TIME_S)
    entry = {'name': name, 'start': list(start), 'goal': list(goal),
             'initial_clearance_m': planner.clearance(initial, TOTAL_TIME_S)}
    for formulation in FORMULATIONS:
        times_ms, result = [], None
        for _ in range(repeats):
            began = time.perf_counter()
            result = planner.plan(initial, TOTAL_TIME_S, formulation=formulation)
            times_ms.append((time.perf_counter() - began) * 1e3)
        entry[formulation] = {
            'plan_ms': times_ms, 'plan_ms_median': statistics.median(times_ms),
            'cost': result.cost, 'initial_cost': result.initial_cost, 'iterations': result.iterations,
            'converged': result.converged, 'collision_free': result.collision_free,
            'min_clearance_m': result.min_clearance,
        }
    costs = [entry[f]['cost'] for f in FORMULATIONS]
    entry['cost_relative_difference'] = abs(costs[0] - costs[1]) / max(abs(costs[0]), abs(costs[1]), 1e-300)
    return entry


def versions() -> dict:
    found = {}
    for package in ('numpy', 'scipy', 'gtsam'):
        try:
            found[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            found[package] = None
    return {'python': platform.python_version(), 'machine': platform.machine(), 'cpu_count': os.cpu_count(),
            **found}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--out', type=Path, default=Path('bench-gpmp-results.json'), help='results JSON path')
    parser.add_argument('--repeats', type=int, default=3, help='plans per problem and formulation (>= 1)')
    parser.add_argument('--states', type=int, default=100, help='support states per trajectory (>= 2)')
    parser.add_argument('--interpolation', type=int, default=0,
                        help='GP-interpolated obstacle checks per interval (GPPlannerConfig.obstacle_interpolation)')
    parser.add_argument('--max-speed', type=float, default=None, help='speed limit in m/s (default: none)')
    args = parser.parse_args(argv)
    if args.repeats < 1 or args.states < 2:
        parser.error('--repeats must be >= 1 and --states >= 2')

    config = GPPlannerConfig(sigma_obs=0.1, epsilon=0.15, obstacle_interpolation=args.interpolation,
                             max_speed=args.max_speed)
    planner = GPPlanner(config, arena_sdf())
    print(f'GP plans: {args.states} states over {TOTAL_TIME_S:g} s, {CELLS}x{CELLS} map ({ARENA_M:g} m), '
          f'{args.repeats} repeats, obstacle_interpolation={args.interpolation}, max_speed={args.max_speed}')
    print(f'{"problem":<14} {"formulation":<11} {"median ms":>10} {"iters":>5} {"final cost":>16} '
          f'{"clearance m":>11} {"free":>5}')
    problems = []
    for name in PROBLEMS:
        entry = bench_problem(planner, name, args.states, args.repeats)
        problems.append(entry)
        for formulation in FORMULATIONS:
            r = entry[formulation]
            print(f'{name:<14} {formulation:<11} {r["plan_ms_median"]:>10.1f} {r["iterations"]:>5d} '
                  f'{r["cost"]:>16.10g} {r["min_clearance_m"]:>11.3f} {str(r["collision_free"]):>5}')
        print(f'{name:<14} cost relative difference {entry["cost_relative_difference"]:.2e}')

    medians = {f: statistics.median(t for p in problems for t in p[f]['plan_ms']) for f in FORMULATIONS}
    worst = max(p['cost_relative_difference'] for p in problems)
    costs_equal = worst <= COST_RTOL
    ratio = medians['gtsam'] / medians['vectorised']
    results = {
        'benchmark': 'gpmp', 'states': args.states, 'map_cells': [CELLS, CELLS], 'arena_m': ARENA_M,
        'total_time_s': TOTAL_TIME_S, 'repeats': args.repeats,
        'config': dataclasses.asdict(config),
        'plan_ms_median': medians,
        'ratio_gtsam_over_vectorised': ratio,
        'cost_max_relative_difference': worst, 'cost_rtol': COST_RTOL, 'costs_equal': costs_equal,
        'problems': problems, 'environment': versions(),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + '\n')
    print(f'median ms per plan: ' + ', '.join(f'{f} {medians[f]:.1f}' for f in FORMULATIONS)
          + f'; final costs {"equal" if costs_equal else "DIFFER"} (max relative difference {worst:.1e}); '
          f'results in {args.out}')
    print(f'ratio gtsam / vectorised: {ratio:.1f}x')
    return 0 if costs_equal else 1


if __name__ == '__main__':
    sys.exit(main())
