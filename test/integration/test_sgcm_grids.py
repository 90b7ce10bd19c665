"""Issue 13: SGCM cases on grids of their own give the same result in simulation as in the core.

The 4x4 and 5x3 cases of config/sgcm/cases_grids.yaml (the 4x4 one with objects in the corner
cells the old fixed set-up left out of the follower's reach) run through the nodes the way
``scripts/experiment sgcm-table1 --mode sim`` runs them (sgcm.experiments.sim_runner: the
scenario and the task file of the case's own grid; the bag holds only the rounds' topics), SGCM
with an obedient follower and no execution failures; the episode read from the bag equals the
abstract game's, round by round.
"""
import numpy as np
import pytest
import yaml

from sgcm.core.episode import run_sgcm
from sgcm.core.fse import FSEPlanner
from sgcm.core.rearrangement import RearrangementModel
from sgcm.core.task_config import load_cases, load_task
from sgcm.experiments.sim_runner import episode_from_bag, run_case


def moves(episode):
    return [(r.leader_action, r.leader_succeeded, r.follower_action, r.follower_succeeded) for r in episode.records]


def recording_only_the_rounds(config_dir, tmp_path):
    """config/experiments/sgcm_case.yaml recording only what episode_from_bag reads, on the wall clock: the
    recorder then takes neither /clock nor the camera, ground truth and arm feedback (CPU the nodes
    under test get instead); the nodes and their parameters are the experiment's."""
    experiment = yaml.safe_load((config_dir / 'experiments' / 'sgcm_case.yaml').read_text())
    rounds = ['/sgcm/guidance', '/sgcm/follower_report']
    experiment['record'].update(topics=rounds, analysis_topics=rounds, use_sim_time=False)
    experiment['record'].pop('rates', None)
    path = tmp_path / 'sgcm_case_rounds.yaml'
    path.write_text(yaml.safe_dump(experiment, sort_keys=False))
    return path


def test_4x4_and_5x3_cases_in_simulation_match_the_core(tmp_path, config_dir):
    task_file = config_dir / 'sgcm' / 'task.yaml'
    experiment = recording_only_the_rounds(config_dir, tmp_path)
    task = load_task(task_file)
    cases = load_cases(config_dir / 'sgcm' / 'cases_grids.yaml', task)
    assert [(c.task.rows, c.task.cols) for c in cases] == [(4, 4), (5, 3)]
    for index, case in enumerate(cases, start=1):
        model = RearrangementModel(case.task)
        core = run_sgcm(model, model.state_of(case), planner=FSEPlanner(model), seed=index)
        lines = []
        # status_rate: the run starts once the bridge's first status is heard (1 s after it is up at 1 Hz).
        result = run_case(task, task_file, case, tmp_path / case.name, config_dir, strategy='sgcm', seed=index,
                          log=lines.append, experiment=experiment,
                          parameters={'pybullet_bridge': {'status_rate': 10.0}})
        assert result.exit_code == 0 and result.bag is not None, (case.name, result.message, lines[-20:])
        assert (tmp_path / case.name / 'task.yaml').exists()   # the nodes played the case's own grid
        sim = episode_from_bag(model, result.bag, 'sgcm')
        assert sim.completed and core.completed, case.name
        assert (sim.rounds, moves(sim)) == (core.rounds, moves(core)), case.name
        assert np.array_equal(sim.final_state, core.final_state)
        assert sim.stage_utilities == pytest.approx(core.stage_utilities)
