"""The demo experiment runs end to end: recorded bag, robots moved, report written."""

import json
import math

from collab_tools.core.bag_analysis import read_messages, summarize_bag
from collab_tools.orchestration.experiment import run_experiment
from collab_tools.report_cli import main as report_main


def test_demo_mobile_experiment_records_moving_robots(config_dir, tmp_path):
    run_dir = tmp_path / 'demo'
    # The demo's own real-time factor: the driver runs on simulated time and must keep up.
    result = run_experiment(config_dir / 'experiments' / 'demo_mobile.yaml', config_dir,
                            run_dir=run_dir, log=None)
    assert result.exit_code == 0, result.message
    assert result.condition_met

    summary = summarize_bag(result.bag)
    counts = {t.topic: t.count for t in summary.topics}
    for topic in ('/clock', '/ground_truth/bodies', '/top_camera/image_raw',
                  '/robot_1/cmd_vel', '/scripted_driver/done'):
        assert counts.get(topic, 0) > 0, f'{topic} not recorded: {counts}'

    first, last = None, None
    for _, _, msg in read_messages(result.bag, ['/ground_truth/bodies']):
        poses = {b.name: (b.pose.position.x, b.pose.position.y) for b in msg.bodies}
        first = first or poses
        last = poses
    for robot in ('robot_1', 'robot_2', 'robot_3'):
        moved = math.dist(first[robot], last[robot])
        assert moved > 0.3, f'{robot} moved only {moved:.3f} m'

    assert report_main([str(run_dir), '--out', str(run_dir / 'report')]) == 0
    report = json.loads((run_dir / 'report' / 'report.json').read_text())
    assert report
    assert list((run_dir / 'report').rglob('*.png'))
