"""Timing of the role engine core: E-Map construction, A* queries and GRA (Hungarian).

Run: ``python -m role_engine.experiments.benchmark_core [--maps DIR] [--repeats N]``. Prints median wall
times; speed targets live here, not in the unit tests. Maps default to config/roles/maps
of the workspace this file sits in (source tree layout).
"""
from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from role_engine.core.assignment import group_role_assignment
from role_engine.core.astar import EMapPlanner
from role_engine.core.emap import build_emap
from role_engine.core.environment import RobotType, load_map_file

DEFAULT_MAPS = Path(__file__).resolve().parents[3] / 'config' / 'roles' / 'maps'


def median_ms(function, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return 1000.0 * statistics.median(times)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--maps', type=Path, default=DEFAULT_MAPS)
    parser.add_argument('--repeats', type=int, default=5)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    print('map     radius  shape     view+SDF ms  E-Map ms  nodes  A* ms (median of 20 pairs)')
    for path in sorted(args.maps.glob('env_*.yaml')):
        env = load_map_file(path)
        for radius in (0.02, 0.1):
            robot_type = RobotType(f'r{radius}', radius)
            view_ms = median_ms(lambda: env.for_robot(robot_type), args.repeats)
            view = env.for_robot(robot_type)
            emap_ms = median_ms(lambda: build_emap(view), args.repeats)
            emap = build_emap(view)
            free = np.argwhere(view.visitable & (view.components == np.bincount(view.components.ravel())[1:].argmax() + 1))
            pairs = free[rng.integers(0, len(free), size=(20, 2))]
            query_times = []
            for source_cell, goal_cell in pairs:
                planner = EMapPlanner(emap)          # fresh: no cached joins
                source, goal = view.frame.cell_to_world(np.array([source_cell, goal_cell]))
                start = time.perf_counter()
                result = planner.plan(source, goal)
                query_times.append(time.perf_counter() - start)
                assert result.feasible, result.reason
            print(f'{env.name:7s} {radius:6.2f}  {env.shape[0]}x{env.shape[1]}  {view_ms:11.1f}  {emap_ms:8.1f}  '
                  f'{emap.graph.number_of_nodes():5d}  {1000 * statistics.median(query_times):.2f}')
    print('\nGRA (Hungarian, scipy linear_sum_assignment) on random Q with 20% inf entries')
    for n in (4, 6, 10):
        q = rng.uniform(0.0, 10.0, size=(n, n))
        q[rng.uniform(size=(n, n)) < 0.2] = np.inf
        np.fill_diagonal(q, rng.uniform(0.0, 10.0, size=n))    # keep it workable
        ms = median_ms(lambda: group_role_assignment(q), max(args.repeats, 50))
        print(f'n = {n:2d}: {ms:.3f} ms (including the workability check)')


if __name__ == '__main__':
    main()
