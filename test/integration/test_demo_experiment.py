"""The demo experiment runs end to end: recorded bag, robots moved, report written with the demo's
outcome first (as scripts/demo writes it), and its camera exported as a playable video."""

import json
import math

from collab_tools.core.bag_analysis import read_messages, summarize_bag
from collab_tools.core.run_outcome import OUTCOMES_FILE, write_outcomes
from collab_tools.core.video import read_video
from collab_tools.experiments.session_outcome import session_outcome
from collab_tools.orchestration.experiment import run_experiment
from collab_tools.report_cli import main as report_main


def test_demo_mobile_experiment_records_moving_robots(config_dir, tmp_path, capsys):
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

    # scripts/demo's outcome line: the session and what the bag shows.
    outcome = session_outcome('mobile', result)
    assert (outcome.status, outcome.passed) == ('completed', True), outcome.line()
    assert all(f'robot_{k} ' in outcome.summary for k in (1, 2, 3)), outcome.summary
    write_outcomes(run_dir / OUTCOMES_FILE, [outcome])
    capsys.readouterr()
    assert report_main([str(run_dir), '--out', str(run_dir / 'report'), '--video']) == 0
    assert capsys.readouterr().out.splitlines()[0] == f'outcome: {outcome.line()}'
    report = json.loads((run_dir / 'report' / 'report.json').read_text())
    assert [o['line'] for o in report['outcomes']] == [outcome.line()] and report['passed'] is True
    markdown = (run_dir / 'report' / 'report.md').read_text().splitlines()
    assert markdown[markdown.index('## Outcome') + 2].startswith('- **mobile: completed**')
    plots = sorted(p.name for p in (run_dir / 'report').rglob('*.png'))
    assert {'message_rates.png', 'trajectories.png', 'velocities.png'} <= set(plots), plots

    # The camera, recorded at 2 Hz as JPEG, plays back frame by frame.
    frames = counts['/top_camera/image_raw/compressed']
    assert frames >= 5, counts
    video = report['bags'][0]['videos'][0]
    assert video['frames'] == frames and video['camera_topic'] == '/top_camera/image_raw/compressed'
    assert read_video(run_dir / 'report' / video['path']) == (frames, video['width'], video['height'])


def test_scripts_demo_opens_its_report_with_one_outcome_line_per_demo(tmp_path):
    import os
    import subprocess
    import sys
    from pathlib import Path

    workspace = Path(__file__).resolve().parents[2]
    env = {**os.environ, 'COLLAB_RUNS_DIR': str(tmp_path)}
    done = subprocess.run([sys.executable, str(workspace / 'scripts' / 'demo'), '--only', 'mobile'], env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    run_dir = Path(done.stdout.strip().splitlines()[-1])
    assert run_dir.parent == tmp_path
    lines = [line for line in done.stdout.splitlines() if line.startswith('[demo] mobile: ')]
    assert len(lines) == 2 and lines[0].startswith('[demo] mobile: completed — the driver finished its plan'), lines
    outcomes = json.loads((run_dir / 'outcomes.json').read_text())['outcomes']
    assert [o['subject'] for o in outcomes] == ['mobile'] and outcomes[0]['passed'] is True
    markdown = (run_dir / 'report' / 'report.md').read_text().splitlines()
    first = markdown.index('## Outcome') + 2
    assert markdown[first] == f"- **mobile: completed** — {outcomes[0]['summary']}" and markdown[first + 1] == ''
    report = json.loads((run_dir / 'report' / 'report.json').read_text())
    assert [o['line'] for o in report['outcomes']] == [lines[0].removeprefix('[demo] ')]
    # The plots of the bag, each with something to show (the mobile demo has robots, commands, messages).
    assert sorted(Path(p).name for p in report['bags'][0]['plots']) == [
        'message_rates.png', 'trajectories.png', 'velocities.png']
    video = report['bags'][0]['videos'][0]                  # and its camera, to watch
    assert read_video(run_dir / 'report' / video['path'])[0] == video['frames'] > 0
