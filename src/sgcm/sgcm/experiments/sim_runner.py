"""Run SGCM cases in simulation and read them back from their bags.

``run_case`` generates the case's bridge scenario into the run directory (with the task file of
the case's own grid and goals when it has them, which both nodes then read) and runs
config/experiments/sgcm_case.yaml (bridge, /leader_arm/leader_planner and
/follower_arm/follower_executor, all recorded) with the per-run parameters; ``episode_from_bag``
rebuilds the episode from the recorded /sgcm/guidance and /sgcm/follower_report messages.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml
from collab_tools.core.bag_analysis import read_messages
from collab_tools.names import join
from collab_tools.orchestration.experiment import SessionRunResult, run_experiment

from ..core.episode import EpisodeResult
from ..core.follower_behaviour import FollowerSettings
from ..core.rearrangement import FOLLOWER, LEADER, RearrangementModel
from ..core.round_log import LoggedRound, episode_from_log, rounds_in_order
from ..core.scenario_builder import build_scenario
from ..core.task_config import Case, TaskConfig, task_of, task_yaml
from ..ros_conversions import FOLLOWER_REPORT, GUIDANCE as GUIDANCE_TOPIC, action_from_msg

# As recorded by a run in the default team namespace.
GUIDANCE = join('/', GUIDANCE_TOPIC)
REPORT = join('/', FOLLOWER_REPORT)


def run_case(task: TaskConfig, task_file: Path, case: Case, run_dir: Path, config_dir: Path,
             strategy: str = 'sgcm', follower: FollowerSettings | None = None, seed: int = 0,
             execution_failures: bool = False, log=print, experiment: Path | None = None,
             parameters: dict[str, dict] | None = None) -> SessionRunResult:
    """experiment: another experiment file than config/experiments/sgcm_case.yaml (e.g. the same
    nodes split over hosts, with its own discovery); its node names must be the same.
    parameters: more node parameters by session label (e.g. ``{'pybullet_bridge': {...}}``)."""
    follower = follower or FollowerSettings('zero_trust' if strategy == 'greedy' else 'obedient')
    scenario = build_scenario(task, case, seed=seed, execution_failures=execution_failures)
    run_dir.mkdir(parents=True, exist_ok=True)
    own = task_of(case, task)
    if own is not task:  # the case's own grid and goals: the nodes read this task
        task_file = run_dir / 'task.yaml'
        task_file.write_text(task_yaml(own))
        task = own
    (run_dir / 'scenario.yaml').write_text(yaml.safe_dump(scenario, sort_keys=False))
    overrides = {
        # moves_can_fail: the leader's stuck rule (sgcm.core.stuck_rule) knows what the scenario says.
        'leader_arm/leader_planner': {'task_file': str(task_file), 'strategy': strategy, 'seed': seed,
                                      'horizon': task.horizon, 'moves_can_fail': execution_failures},
        'follower_arm/follower_executor': {'task_file': str(task_file), 'behaviour': follower.behaviour,
                                           'deviation_probability': follower.deviation_probability,
                                           'deviation_rounds': list(follower.deviation_rounds) or [0],
                                           'seed': seed + 1},
    }
    for label, values in (parameters or {}).items():
        overrides[label] = {**overrides.get(label, {}), **values}
    return run_experiment(experiment or config_dir / 'experiments' / 'sgcm_case.yaml', config_dir,
                          run_dir=run_dir, overrides=overrides, log=log)


def episode_from_bag(model: RearrangementModel, bag: Path, method: str,
                     namespace: str = '/') -> EpisodeResult:
    """namespace: the team namespace the run's channels were under (an experiment's namespace)."""
    guidance_topic, report_topic = join(namespace, GUIDANCE_TOPIC), join(namespace, FOLLOWER_REPORT)

    def action(robot, move):  # the bag's messages have the same fields as the ROS ones
        return action_from_msg(model, robot, move)

    guidance, reports = [], []
    for topic, _, msg in read_messages(bag, [guidance_topic, report_topic]):
        (guidance if topic == guidance_topic else reports).append(msg)
    played, final = rounds_in_order(guidance, reports)   # a restarted leader's rounds after her earlier ones
    if final is None:
        raise ValueError(f'{bag}: no final guidance (the leader did not end the task)')
    rounds = []
    for number, (g, report) in enumerate(played, start=1):
        rounds.append(LoggedRound(
            round=number, state=np.array(g.state.counts, dtype=np.int64),
            leader_action=action(LEADER, g.leader_move), leader_succeeded=bool(g.leader_move_succeeded),
            recommended_action=action(FOLLOWER, g.recommended_follower_move),
            follower_action=None if report is None else action(FOLLOWER, report.move),
            follower_succeeded=bool(report.succeeded) if report else False,
            follower_deviated=bool(report.deviated) if report else False,
            planning_seconds=float(g.planning_seconds),
            predicted_leader_value=float(g.predicted_leader_value),
            predicted_follower_value=float(g.predicted_follower_value)))
    final_state = np.array(final.state.counts, dtype=np.int64)
    return episode_from_log(model, method, rounds, final_state, complete=bool(final.task_complete),
                            stuck=final.status.startswith('stuck'))
