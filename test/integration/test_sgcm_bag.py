"""The SGCM simulation experiment's bag holds both arms' action feedback and status, and its
metadata is as rosbag2 Jazzy writes it (issue 11: bags as rosbag2 writes them).

Runs config/experiments/sgcm_case.yaml the way `scripts/experiment sgcm-table1 --mode sim`
does (sgcm.experiments.sim_runner.run_case) on the shortest case, case_8 (one cube per colour).
"""
import yaml

from collab_tools.core.bag_analysis import read_messages, summarize_bag
from collab_tools.core.bag_check import check_bag, read_mcap_summary
from sgcm.core.rearrangement import RearrangementModel
from sgcm.core.task_config import load_cases, load_task
from sgcm.experiments.sim_runner import episode_from_bag, run_case

ARMS = ('leader_arm', 'follower_arm')


def test_sgcm_bag_holds_both_arms_action_feedback_and_passes_the_check(tmp_path, config_dir):
    task_file = config_dir / 'sgcm' / 'task.yaml'
    task = load_task(task_file)
    case = next(c for c in load_cases(config_dir / 'sgcm' / 'cases.yaml', task) if c.name == 'case_8')
    lines = []
    result = run_case(task, task_file, case, tmp_path / 'run', config_dir, strategy='sgcm', log=lines.append)
    assert result.exit_code == 0 and result.condition_met, (result.message, lines)

    bag = result.bag
    counts = {t.topic: t.count for t in summarize_bag(bag).topics}
    for arm in ARMS:
        feedback, status = f'/{arm}/pick_and_place/_action/feedback', f'/{arm}/pick_and_place/_action/status'
        assert counts.get(feedback, 0) > 0 and counts.get(status, 0) > 0, (arm, counts)
        phases = {m.feedback.phase for _, _, m in read_messages(bag, [feedback])}
        assert {'grasp', 'place', 'retreat'} <= phases, (arm, phases)
    # What the experiment's analysis reads is still there: the episode completes.
    assert episode_from_bag(RearrangementModel(task), bag, 'sgcm').completed

    assert check_bag(bag) == []
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert (info['version'], info['ros_distro']) == (9, 'jazzy')
    channels = read_mcap_summary(bag / info['relative_file_paths'][0])['channels'].values()
    hashes = {c['topic']: c['metadata']['topic_type_hash'] for c in channels}
    assert len({hashes[f'/{arm}/pick_and_place/_action/feedback'] for arm in ARMS}) == 1
    assert set(hashes) == set(counts)
