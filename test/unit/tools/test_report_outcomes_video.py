"""Reports that say what happened first, plots that have content and draw the scene, videos that play.

Synthetic bags (the conftest's make_bag, plus camera frames written here) stand in for recordings.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from collab_tools.core import report_plots
from collab_tools.core.bag_analysis import summarize_bag
from collab_tools.core.bag_types import build_typestore
from collab_tools.core.bag_writer import BagWriter, QosSpec
from collab_tools.core.image_codec import RGB8_JPEG_FORMAT, encode_rgb_jpeg
from collab_tools.core.run_outcome import Outcome, register_outcome, unregister_outcome, write_outcomes
from collab_tools.core.scene_layout import Disc, Rect, SceneLayout, register_scene_reader, unregister_scene_reader
from collab_tools.core.video import camera_topic, export_video, read_video, write_frames
from collab_tools.report_cli import main



def body_states_msg(store, stamp_ns: int, bodies):
    """BodyStates of (name, kind, label, x, y, vx) bodies."""
    T = store.types
    point = T['geometry_msgs/msg/Point']
    return T['bridge_interfaces/msg/BodyStates'](
        header=T['std_msgs/msg/Header'](stamp=T['builtin_interfaces/msg/Time'](sec=stamp_ns // 10**9,
                                                                               nanosec=stamp_ns % 10**9),
                                        frame_id='world'),
        bodies=[T['bridge_interfaces/msg/BodyState'](
            name=name, kind=kind, label=label,
            pose=T['geometry_msgs/msg/Pose'](position=point(x=x, y=y, z=0.0),
                                             orientation=T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0)),
            twist=T['geometry_msgs/msg/Twist'](linear=T['geometry_msgs/msg/Vector3'](x=vx, y=0.0, z=0.0),
                                               angular=T['geometry_msgs/msg/Vector3'](x=0.0, y=0.0, z=0.0)))
            for name, kind, label, x, y, vx in bodies])

RED = (0.85, 0.15, 0.15)
BLUE = (0.15, 0.35, 0.85)
LAYOUT = SceneLayout(source='test', bounds=(-1.0, -1.0, 3.0, 3.0),
                     walls=(Rect('walls', (1.0, -1.025), (4.1, 0.05)),),
                     obstacles=(Rect('pillar', (2.0, 2.0), (0.3, 0.3), 0.0, (0.1, 0.6, 0.1)),),
                     robots={'robot_1': Disc('robot_1', (0.0, 0.0), 0.2, RED),
                             'robot_2': Disc('robot_2', (0.0, 0.0), 0.2, BLUE)})


@pytest.fixture
def layout():
    register_scene_reader('test_layout', lambda bag: LAYOUT)
    yield LAYOUT
    unregister_scene_reader('test_layout')


def figures_saved(monkeypatch) -> list:
    """The figures report_plots saves (kept open for inspection)."""
    saved = []

    def keep(fig, path):
        fig.canvas.draw()
        saved.append(fig)
        fig.savefig(path)
        return path
    monkeypatch.setattr(report_plots, '_save', keep)
    return saved


# ------------------------------------------------------------------------------------ video writer
@pytest.mark.parametrize('fmt', ['mp4', 'gif'])
def test_written_video_reads_back_with_every_frame(tmp_path, fmt):
    frames = [np.full((48, 64, 3), 20 * k, np.uint8) for k in range(12)]
    info = write_frames(frames, tmp_path / f'clip.{fmt}', fmt, fps=4.0)
    assert (info.frames, info.width, info.height) == (12, 64, 48)
    if fmt == 'mp4':
        assert read_video(info.path) == (12, 64, 48)
    else:
        from PIL import Image
        with Image.open(info.path) as gif:
            assert (gif.n_frames, gif.size) == (12, (64, 48))


def test_unknown_video_format_is_refused(tmp_path):
    with pytest.raises(ValueError, match='video format'):
        write_frames([np.zeros((8, 8, 3), np.uint8)], tmp_path / 'x.avi', 'avi')


# ------------------------------------------------------------------------------- camera bag -> video
CAMERA_K = [100.0, 0.0, 32.0, 0.0, 100.0, 32.0, 0.0, 0.0, 1.0]   # 64 x 64, 4 m above (1, 1): 0.04 m per px


def camera_bag(path, frames: int = 6, bridge_prefix=None):
    types = {'/top_camera/image_raw/compressed': 'sensor_msgs/msg/CompressedImage',
             '/top_camera/camera_info': 'sensor_msgs/msg/CameraInfo',
             '/top_camera/pose': 'geometry_msgs/msg/PoseStamped',
             '/ground_truth/bodies': 'bridge_interfaces/msg/BodyStates'}
    store = build_typestore(types.values(), prefixes=[bridge_prefix])
    T = store.types
    header = lambda ns: T['std_msgs/msg/Header'](stamp=T['builtin_interfaces/msg/Time'](sec=ns // 10**9, nanosec=ns % 10**9),  # noqa: E731
                                                 frame_id='top_camera_optical')
    t0 = 5 * 10**9
    with BagWriter(path, store) as writer:
        for topic, type_name in types.items():
            writer.add_topic(topic, type_name, [QosSpec('keep_last', 10, 'reliable', 'volatile')])
        pose = T['geometry_msgs/msg/PoseStamped'](header=header(t0), pose=T['geometry_msgs/msg/Pose'](
            position=T['geometry_msgs/msg/Point'](x=1.0, y=1.0, z=4.0),
            orientation=T['geometry_msgs/msg/Quaternion'](x=1.0, y=0.0, z=0.0, w=0.0)))
        writer.write('/top_camera/pose', t0, bytes(store.serialize_cdr(pose, types['/top_camera/pose'])))
        for k in range(frames):
            t = t0 + k * 500_000_000
            info = T['sensor_msgs/msg/CameraInfo'](
                header=header(t), height=64, width=64, distortion_model='plumb_bob', d=np.zeros(5),
                k=np.array(CAMERA_K), r=np.eye(3).ravel(), p=np.zeros(12), binning_x=0, binning_y=0,
                roi=T['sensor_msgs/msg/RegionOfInterest'](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
            bodies = body_states_msg(store, t, [('robot_1', 'mobile_robot', 1, 0.2 * k, 0.0, 0.0),
                                                ('box_1', 'box_obstacle', 3, 2.0, 2.0, 0.0)])
            image = T['sensor_msgs/msg/CompressedImage'](header=header(t), format=RGB8_JPEG_FORMAT, data=np.frombuffer(
                encode_rgb_jpeg(np.full((64, 64, 3), 128, np.uint8), 90), np.uint8))
            for topic, msg in (('/top_camera/camera_info', info), ('/ground_truth/bodies', bodies),
                               ('/top_camera/image_raw/compressed', image)):
                writer.write(topic, t, bytes(store.serialize_cdr(msg, types[topic])))
    return path


def test_bag_video_has_every_frame_scaled_up_with_the_robot_drawn_in_its_colour(tmp_path, bridge_prefix):
    bag = camera_bag(tmp_path / 'cam', frames=6, bridge_prefix=bridge_prefix)
    summary = summarize_bag(bag)
    assert camera_topic(summary) == '/top_camera/image_raw/compressed'
    info = export_video(bag, summary, tmp_path / 'top.mp4', 'mp4', layout=LAYOUT)
    assert (info.frames, info.width, info.height) == (6, 480, 480)
    assert read_video(info.path) == (6, 480, 480)
    capture = __import__('cv2').VideoCapture(str(info.path))
    for _ in range(6):
        ok, last = capture.read()
    capture.release()
    # robot_1 is at (1.0, 0.0) in the last frame: pixel (32, 57) of 64 -> x7.5 scale; drawn red (BGR)
    b, g, r = last[int(57 * 7.5), int(32 * 7.5)].astype(int)
    assert r > 150 and g < 110 and b < 110, (b, g, r)
    plain = np.full(3, 128)
    assert np.abs(last[20, 240].astype(int) - plain).max() < 20     # far from every marker: the frame itself


def test_bag_without_camera_frames_gives_no_video(tmp_path, make_bag):
    bag = make_bag(tmp_path / 'bag', n=3)
    assert export_video(bag, summarize_bag(bag), tmp_path / 'none.mp4') is None
    assert not (tmp_path / 'none.mp4').exists()


def test_report_video_option_writes_a_playable_mp4(tmp_path, bridge_prefix, capsys):
    run = tmp_path / 'run'
    camera_bag(run / 'bags' / 'cam', frames=4, bridge_prefix=bridge_prefix)
    assert main([str(run), '--video']) == 0
    report = json.loads((run / 'report' / 'report.json').read_text())
    video = report['bags'][0]['videos'][0]
    assert video['frames'] == 4 and video['camera_topic'] == '/top_camera/image_raw/compressed'
    assert read_video(run / 'report' / video['path'])[0] == 4
    assert f"]({video['path']})" in (run / 'report' / 'report.md').read_text()


# ----------------------------------------------------------------------------------------- plots
def test_trajectories_draw_the_scene_under_robots_in_their_simulation_colours(tmp_path, make_bag, layout,
                                                                           monkeypatch):
    saved = figures_saved(monkeypatch)
    bag = make_bag(tmp_path / 'bag', n=5)
    paths = report_plots.plot_trajectories(bag, summarize_bag(bag), tmp_path)
    assert [p.name for p in paths] == ['trajectories.png']
    ax = saved[0].axes[0]
    pillar = [p for p in ax.patches if tuple(p.get_facecolor()[:3]) == pytest.approx((0.1, 0.6, 0.1))]
    assert len(pillar) == 1 and pillar[0].zorder < min(line.zorder for line in ax.lines if line.get_label() == 'robot_1')
    colours = {line.get_label(): tuple(line.get_color()) for line in ax.lines if line.get_label().startswith('robot')}
    assert colours == {'robot_1': RED, 'robot_2': BLUE}


def test_trajectory_plot_is_not_made_without_mobile_robots(tmp_path, bridge_prefix):
    store = build_typestore(['bridge_interfaces/msg/BodyStates'], prefixes=[bridge_prefix])
    with BagWriter(tmp_path / 'boxes', store) as writer:
        writer.add_topic('/ground_truth/bodies', 'bridge_interfaces/msg/BodyStates',
                         [QosSpec('keep_last', 10, 'reliable', 'volatile')])
        for k in range(3):
            msg = body_states_msg(store, k * 10**8, [('cube', 'cube', 3, 0.0, 0.0, 0.0)])
            writer.write('/ground_truth/bodies', k * 10**8,
                         bytes(store.serialize_cdr(msg, 'bridge_interfaces/msg/BodyStates')))
    bag = tmp_path / 'boxes'
    assert report_plots.plot_trajectories(bag, summarize_bag(bag), tmp_path) == []


def test_message_rates_on_a_log_scale_with_the_legend_beside_the_data(tmp_path, make_bag, monkeypatch):
    saved = figures_saved(monkeypatch)
    bag = make_bag(tmp_path / 'bag', n=30)
    report_plots.plot_message_rates(bag, summarize_bag(bag), tmp_path)
    ax = saved[0].axes[0]
    assert ax.get_yscale() == 'log'
    legend, axes_box = ax.get_legend().get_window_extent(), ax.get_window_extent()
    assert legend.x0 >= axes_box.x1          # right of the axes: over no line


def test_empty_bag_gets_no_rate_plot(tmp_path, make_bag):
    bag = make_bag(tmp_path / 'bag', n=0, topics=('/chatter',))
    assert report_plots.plot_message_rates(bag, summarize_bag(bag), tmp_path) == []


# ------------------------------------------------------------------------------- outcomes first
def test_report_opens_with_the_runs_outcomes_then_the_inventory(tmp_path, make_bag, capsys):
    run = tmp_path / 'demo'
    make_bag(run / 'mobile' / 'bags' / 'demo_mobile', n=4)
    write_outcomes(run / 'outcomes.json', [
        Outcome('mobile', 'completed', 'the driver finished its plan', True, checks={'plan_done': True}),
        Outcome('sgcm', 'ended', 'stuck in 7 rounds', False, checks={'goal_reached': False})])
    assert main([str(run)]) == 0     # the report itself succeeds; the verdict is in it
    out = capsys.readouterr().out.splitlines()
    assert out[:2] == ['outcome: mobile: completed — the driver finished its plan',
                       'outcome: sgcm: ended — stuck in 7 rounds [failed: goal_reached]']
    assert out.index('outcome: sgcm: ended — stuck in 7 rounds [failed: goal_reached]') < \
        min(i for i, line in enumerate(out) if line.startswith('bag: '))
    report = json.loads((run / 'report' / 'report.json').read_text())
    assert list(report)[:2] == ['passed', 'outcomes'] and report['passed'] is False
    assert [o['subject'] for o in report['outcomes']] == ['mobile', 'sgcm']
    md = (run / 'report' / 'report.md').read_text().splitlines()
    outcome_at = md.index('## Outcome')
    assert md[outcome_at + 2].startswith('- **mobile: completed** — the driver finished its plan')
    assert md[outcome_at + 3].startswith('- **sgcm: ended** — stuck in 7 rounds (failed: goal_reached)')
    assert outcome_at < md.index('## Recordings') < next(i for i, line in enumerate(md) if line.startswith('| topic'))


def test_an_experiments_results_give_the_outcome(tmp_path, make_bag, capsys):
    run = tmp_path / 'exp'
    make_bag(run / 'bags' / 'b', n=3)
    (run / 'results.json').write_text(json.dumps({
        'schema': 'collab-experiment/1', 'experiment': 'roles-formation', 'passed': True,
        'outcome': 'formed in 12.5 s', 'acceptance': {'passed': True, 'checks': {'completed': True}}}))
    assert main([str(run)]) == 0
    assert capsys.readouterr().out.splitlines()[0] == 'outcome: roles-formation: passed — formed in 12.5 s'
    assert json.loads((run / 'report' / 'report.json').read_text())['passed'] is True


def test_bag_outcome_readers_speak_when_the_run_states_nothing(tmp_path, make_bag, capsys):
    def reader(bag, summary):
        return Outcome('bodies', 'completed', f'{summary.topic("/sim/body_states").count} states', True)
    register_outcome('test_bodies', {'bridge_interfaces/msg/BodyStates'}, reader)
    try:
        run = tmp_path / 'run'
        make_bag(run / 'bags' / 'a', n=3)
        make_bag(run / 'bags' / 'chatter', n=3, topics=('/chatter',))
        assert main([str(run)]) == 0
    finally:
        unregister_outcome('test_bodies')
    assert capsys.readouterr().out.splitlines()[0] == 'outcome: bodies: completed — 3 states'
    report = json.loads((run / 'report' / 'report.json').read_text())
    assert [o['line'] for o in report['outcomes']] == ['bodies: completed — 3 states']
    assert {b['name']: len(b['outcomes']) for b in report['bags']} == {'bags/a': 1, 'bags/chatter': 0}


def test_no_outcome_is_said_plainly(tmp_path, make_bag, capsys):
    run = tmp_path / 'run'
    make_bag(run / 'bags' / 'chatter', n=2, topics=('/chatter',))
    assert main([str(run)]) == 0
    assert capsys.readouterr().out.startswith('outcome: none recorded')
    assert json.loads((run / 'report' / 'report.json').read_text())['passed'] is None


def test_a_demo_whose_session_failed_says_so_with_what_its_bag_shows(tmp_path, make_bag):
    from types import SimpleNamespace

    from collab_tools.experiments.session_outcome import session_outcome

    def reader(bag, summary):
        return Outcome('bodies', 'formed', 'two robots in place', True, checks={'formed': True})
    register_outcome('test_bodies', {'bridge_interfaces/msg/BodyStates'}, reader)
    try:
        bag = make_bag(tmp_path / 'run' / 'bags' / 'b', n=3)
        ok = session_outcome('roles', SimpleNamespace(exit_code=0, condition_met=True, bag=bag,
                                                      run_dir=tmp_path / 'run', message='condition met'))
        failed = session_outcome('roles', SimpleNamespace(exit_code=3, condition_met=False, bag=bag,
                                                          run_dir=tmp_path / 'run', message='role_engine exited 1'))
        nothing = session_outcome('sgcm', SimpleNamespace(exit_code=0, condition_met=True, bag=None,
                                                          run_dir=tmp_path / 'run', message='condition met'))
    finally:
        unregister_outcome('test_bodies')
    assert (ok.status, ok.passed, ok.summary) == ('formed', True, 'two robots in place')
    assert ok.checks == {'session_exit_0': True, 'formed': True}
    assert (failed.status, failed.passed) == ('FAILED', False)
    assert failed.line() == ('roles: FAILED — exit 3 (role_engine exited 1); two robots in place '
                             '[failed: session_exit_0]')
    assert (nothing.status, nothing.passed, nothing.summary) == ('unverified', False, 'no bag recorded')


def test_the_subsystems_register_their_outcome_and_scene_readers():
    from collab_tools.core import run_outcome, scene_layout
    from collab_tools.report_cli import load_plot_plugins
    loaded = set(load_plot_plugins())
    assert {'sgcm.experiments.report_plots', 'role_engine.experiments.formation_bag',
            'coalition_agents.experiments.coalition_bag', 'pybullet_bridge.report_scene'} <= loaded
    assert {'scripted_drive', 'sgcm', 'roles_formation', 'coalitions'} <= set(run_outcome._READERS)
    assert 'pybullet_bridge' in scene_layout._READERS
