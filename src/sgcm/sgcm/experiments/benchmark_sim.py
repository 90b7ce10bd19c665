"""Real-time factor of a whole SGCM case in pybullet, camera on demand vs streamed (``scripts/bench sim``).

Each case runs in simulation as ``scripts/experiment sgcm-table1 --mode sim`` runs it (the bridge at
``real_time_factor`` 0, i.e. as fast as it can, the leader and follower nodes, the recorder), once per
path, the paths interleaved, in one benchmark run:

* ``reference`` -- as before issue 14: the arms subscribe to the image stream (``camera_on_demand``
  false), so the bridge renders every camera period, with TinyRenderer (``camera_renderer: tiny``),
  one control tick per timer call (``fast_batch_period: 0``) and /clock every tick (``clock_rate: 0``);
* ``on_demand`` -- as the experiment file says now: the arms ask ``<camera>/get_frame`` once per look
  (``camera_on_demand`` true, the default) and the bridge renders nothing else (TinyRenderer, the
  bridge's default), 50 ms of simulation per timer call and /clock at 50 Hz (the experiment's
  ``fast_batch_period`` and ``clock_rate``);
* with ``breakdown`` also ``on_demand_tick_by_tick`` (on demand, but one tick per call and /clock
  every tick: the camera's share alone) and ``on_demand_egl`` (``camera_renderer: auto``:
  pybullet's EGL plugin where it loads).

From each run's bag: the real-time factor (simulated over wall seconds while the simulation ran,
from the bridge's ``~/status`` at 10 Hz), the camera frames rendered (its last status), and the SGCM
outcome (rounds, goal reached), which must be the same on both paths.
Beside it, in-process: the median time of one frame with each renderer on the case's table, and how
many label pixels differ between them.
"""
from __future__ import annotations

import json
import os
import statistics
import time
from pathlib import Path
from typing import Callable

import numpy as np
import yaml
from collab_tools.core.bag_analysis import read_messages
from collab_tools.core.fields import read_yaml_file

from ..core.rearrangement import RearrangementModel
from ..core.scenario_builder import build_scenario
from ..core.task_config import Case, TaskConfig, task_of
from .sim_runner import episode_from_bag, run_case

STATUS = '/pybullet_bridge/status'
#: Wall-clock Hz of the bridge's status during the benchmark (its factor is measured between two).
STATUS_RATE = 10.0
LEADER, FOLLOWER, BRIDGE = 'leader_arm/leader_planner', 'follower_arm/follower_executor', 'pybullet_bridge'

#: The two paths: per-node parameters by session label.
PATHS = {
    'reference': {BRIDGE: {'camera_renderer': 'tiny', 'clock_rate': 0.0, 'fast_batch_period': 0.0,
                           'status_rate': STATUS_RATE}, LEADER: {'camera_on_demand': False},
                  FOLLOWER: {'camera_on_demand': False}},
    'on_demand': {BRIDGE: {'status_rate': STATUS_RATE}, LEADER: {'camera_on_demand': True},
                  FOLLOWER: {'camera_on_demand': True}},
}


#: With ``breakdown``: the on-demand camera alone (one tick per call, /clock every tick), and with the
#: EGL renderer where it loads.
BREAKDOWN = {'on_demand_tick_by_tick': {**PATHS['on_demand'],
                                        BRIDGE: {**PATHS['on_demand'][BRIDGE], 'clock_rate': 0.0,
                                                 'fast_batch_period': 0.0}},
             'on_demand_egl': {**PATHS['on_demand'],
                               BRIDGE: {**PATHS['on_demand'][BRIDGE], 'camera_renderer': 'auto'}}}


def experiment_file(config_dir: Path, out: Path) -> Path:
    """config/experiments/sgcm_case.yaml, also recording the bridge's status (frames rendered)."""
    data = read_yaml_file(config_dir / 'experiments' / 'sgcm_case.yaml', 'experiment file')
    topics = data['record']['topics']
    if STATUS not in topics:
        topics.append(STATUS)
    out.write_text(yaml.safe_dump(data, sort_keys=False))
    return out


def clock_pace(bag: Path) -> dict:
    """Simulated over wall seconds while the simulation ran, from the bridge's recorded ``~/status``.

    The recorder stamps messages with simulated time (it uses /clock), so the wall time comes from
    the status: each carries its simulated stamp and the real-time factor measured since the
    previous one (wall = simulated / factor). Intervals that begin or end paused are left out.
    """
    sim_s = wall_s = 0.0
    previous = None
    frames, renderer = None, ''
    for _, _, msg in read_messages(bag, [STATUS]):
        frames, renderer = int(msg.camera_frames), msg.camera_renderer
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        if previous is not None and not previous[1] and not msg.paused and msg.measured_real_time_factor > 0:
            step = stamp - previous[0]
            sim_s += step
            wall_s += step / msg.measured_real_time_factor
        previous = (stamp, msg.paused)
    if wall_s <= 0.0:
        raise ValueError(f'{bag}: no running simulation in the recorded {STATUS}')
    return {'sim_s': sim_s, 'wall_s': wall_s, 'real_time_factor': sim_s / wall_s,
            'camera_frames': frames, 'camera_renderer': renderer}


def render_comparison(task: TaskConfig, case: Case, frames: int = 10) -> dict:
    """Median ms per frame with each renderer on the case's table (settled), and label differences."""
    from pybullet_bridge.core.renderer import EGL, TINY
    from pybullet_bridge.core.scenario import parse_scenario
    from pybullet_bridge.core.scene import Scene
    scenario = parse_scenario(build_scenario(task, case), Path('.'))
    out, labels = {}, {}
    for renderer in (TINY, 'auto'):
        with Scene(scenario, renderer=renderer) as scene:
            scene.step(240)
            scene.render()  # the first frame sets the renderer up
            times = []
            for _ in range(frames):
                start = time.perf_counter()
                frame = scene.render()
                times.append(time.perf_counter() - start)
            out[scene.renderer.name] = {'render_ms_median': 1e3 * statistics.median(times),
                                        'reason': scene.renderer.reason}
            labels[scene.renderer.name] = frame.labels
    result = {'renderers': out}
    if EGL in labels:
        differ = int(np.count_nonzero(labels[TINY] != labels[EGL]))
        result['label_pixels_differing'] = differ
        result['label_pixels'] = int(labels[TINY].size)
        result['egl_over_tiny_speed'] = out[TINY]['render_ms_median'] / out[EGL]['render_ms_median']
    return result


def run_benchmark(task: TaskConfig, task_file: Path, cases: list[Case], config_dir: Path, out_dir: Path,
                  repeats: int = 1, breakdown: bool = False, log: Callable[[str], None] = print) -> dict:
    experiment = experiment_file(config_dir, out_dir / 'sgcm_case_bench.yaml')
    load_before = [round(v, 2) for v in os.getloadavg()]
    paths = {**PATHS, **(BREAKDOWN if breakdown else {})}
    runs = []
    for case in cases:
        model = RearrangementModel(task_of(case, task))
        for repeat in range(repeats):
            # Interleaved, alternating which goes first, so a load change hits both paths alike.
            order = list(paths) if repeat % 2 == 0 else list(paths)[::-1]
            for path in order:
                run_dir = out_dir / f'{case.name}-{path}-{repeat}'
                log(f'{case.name} {path} (repeat {repeat + 1}/{repeats}) ...')
                started = time.monotonic()
                result = run_case(task, task_file, case, run_dir, config_dir, experiment=experiment,
                                  parameters=paths[path], log=None)
                row = {'case': case.name, 'path': path, 'repeat': repeat, 'exit_code': result.exit_code,
                       'session_s': time.monotonic() - started, 'run_dir': str(run_dir)}
                if result.bag is not None:
                    row.update(clock_pace(result.bag))
                    episode = episode_from_bag(model, result.bag, 'sgcm')
                    row.update(rounds=episode.rounds, goal_reached=episode.completed, stuck=episode.stuck,
                               final_state=[int(v) for v in np.asarray(episode.final_state).reshape(-1)])
                log(f"  rtf {row.get('real_time_factor', float('nan')):.2f}, {row.get('camera_frames')} frames "
                    f"({row.get('camera_renderer')}), rounds {row.get('rounds')}, goal {row.get('goal_reached')}, "
                    f"{row['session_s']:.0f} s session")
                runs.append(row)
    results = summarise(runs, list(paths))
    results['render'] = render_comparison(task, cases[0])
    results['load'] = {'before': load_before, 'after': [round(v, 2) for v in os.getloadavg()]}   # 1, 5, 15 min
    (out_dir / 'results.json').write_text(json.dumps(results, indent=2))
    return results


def summarise(runs: list[dict], paths: list[str]) -> dict:
    """Medians per path, the ratio, and whether every case ended the same way on every path."""
    per_path = {}
    for path in paths:
        rows = [r for r in runs if r['path'] == path and 'real_time_factor' in r]
        per_path[path] = {
            'real_time_factor_median': statistics.median(r['real_time_factor'] for r in rows) if rows else None,
            'camera_frames_median': statistics.median(r['camera_frames'] for r in rows
                                                      if r['camera_frames'] is not None) if rows else None,
            'runs': len(rows)}
    outcomes = {}
    for r in runs:
        outcomes.setdefault(r['case'], {}).setdefault(r['path'], set()).add(
            (r.get('rounds'), r.get('goal_reached'), r.get('stuck')))
    same = all(len(set().union(*by_path.values())) == 1 and len(by_path) == len(paths)
               for by_path in outcomes.values())
    ref, new = (per_path[p]['real_time_factor_median'] for p in ('reference', 'on_demand'))
    return {'real_time_factor': {p: v['real_time_factor_median'] for p, v in per_path.items()},
            'real_time_factor_ratio': new / ref if ref and new else None,
            'per_path': per_path, 'outcomes_equal': same, 'runs': runs}
