"""leader_planner and follower_executor drive both arms through the bridge until the goal.

Each runs in its arm's namespace (/leader_arm/leader_planner, /follower_arm/follower_executor).
Only topics connect them: the camera (state estimate), /sgcm/guidance (leader -> follower),
/sgcm/follower_report (round over) and the arms' pick_and_place actions.
"""

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, Image
from sgcm_interfaces.msg import Guidance, GridState, Move
from std_srvs.srv import SetBool

from collab_tools.orchestration.node_process import NodeSpec
from bridge_helpers import bridge_spec, wait_for_subscriber
from pybullet_bridge.core.scenario import parse_scenario
from pybullet_bridge.core.scene import Scene
from sgcm.core.rearrangement import RearrangementModel
from sgcm.core.scenario_builder import build_scenario
from sgcm.core.task_config import Case, load_cases, load_task

LEADER_NS, FOLLOWER_NS = '/leader_arm', '/follower_arm'


@pytest.fixture
def task_file(config_dir):
    return config_dir / 'sgcm' / 'task.yaml'


def leader_spec(task_file, **parameters) -> NodeSpec:
    return NodeSpec('sgcm', 'leader_planner', name='leader_planner', namespace=LEADER_NS,
                    parameters=[{'task_file': str(task_file), **parameters}], required=False)


def follower_spec(task_file, **parameters) -> NodeSpec:
    return NodeSpec('sgcm', 'follower_executor', name='follower_executor', namespace=FOLLOWER_NS,
                    parameters=[{'task_file': str(task_file), **parameters}], required=False)


def start_case(session, tmp_path, task_file, config_dir, case_name, follower_params=None, leader_params=None,
               follower=True, bridge_env=None, **bridge_params):
    task = load_task(task_file)
    case = next(c for c in load_cases(config_dir / 'sgcm' / 'cases.yaml', task) if c.name == case_name)
    scenario = tmp_path / 'scenario.yaml'
    scenario.write_text(yaml.safe_dump(build_scenario(task, case, execution_failures=False)))
    spec = bridge_spec(scenario, **{'ground_truth_rate': 5.0, 'start_paused': False, **bridge_params})
    session.start(replace(spec, env=bridge_env or {}))
    session.start(leader_spec(task_file, **(leader_params or {})))
    if follower:
        session.start(follower_spec(task_file, **(follower_params or {})))
    return task, case


def resume_once_heard(session, subscription, timeout=60.0):
    """Unpause the bridge once `subscription` has matched the leader's guidance publisher (guidance
    is not latched: a round published before the match would be missed)."""
    deadline = time.monotonic() + timeout
    while subscription.get_publisher_count() == 0:
        assert time.monotonic() < deadline, 'the leader never published guidance'
        time.sleep(0.05)
    assert session.call_service('/pybullet_bridge/pause', 'std_srvs/srv/SetBool', SetBool.Request(data=False)).success


def test_leader_and_follower_complete_a_case_through_topics(session, tmp_path, task_file, config_dir):
    # Guidance is not latched: the simulation runs only once our subscription has matched the
    # leader's publisher, so round 1 is never missed however slow discovery is.
    guidance = []
    subscription = session.observer.node.create_subscription(Guidance, '/sgcm/guidance', guidance.append, 10)
    task, case = start_case(session, tmp_path, task_file, config_dir, 'case_8', start_paused=True)
    model = RearrangementModel(task)
    # One node per arm, named in its arm's namespace.
    session.wait_for_nodes([f'{LEADER_NS}/leader_planner', f'{FOLLOWER_NS}/follower_executor'], 60.0)
    resume_once_heard(session, subscription)
    final = session.wait_for_message('/sgcm/guidance', 'sgcm_interfaces/msg/Guidance',
                                     predicate=lambda m: m.task_complete or bool(m.status), timeout=240)
    assert final.task_complete, final.status
    assert session.wait_for_exit('leader_arm/leader_planner', 30) == 0
    # The rounds announced the leader's moves and a recommendation; the last estimate is the goal.
    rounds = [g for g in guidance if not g.task_complete]
    assert 1 <= len(rounds) <= 4
    assert all(g.strategy == 'sgcm' and g.stage_games > 0 for g in rounds)
    start = model.state_of(case)
    assert np.array_equal(np.array(rounds[0].state.counts), start), 'first estimate is the initial case'
    assert np.array_equal(np.array(final.state.counts), model.goal_state(start))
    # Ground truth agrees with the camera estimate: every cube is in its colour's goal cell.
    bodies = session.wait_for_message('/ground_truth/bodies', 'bridge_interfaces/msg/BodyStates',
                                      timeout=20, latched=True)
    for body in bodies.bodies:
        if body.kind == 'cube':
            colour = task.colours.index(body.name.rsplit('_', 1)[0])
            cell = task.workspace.cell_of_point(task.rows, task.cols, body.pose.position.x,
                                                body.pose.position.y)
            assert cell == task.goals[colour], f'{body.name} ended in cell {cell}'


def wait_for_follower(node, publisher, timeout=30.0):
    """Until the follower's own guidance subscription is matched (the observer and the recorder
    subscribe too, so a subscriber count of one proves nothing)."""
    deadline = time.monotonic() + timeout
    while True:
        subscribers = node.get_subscriptions_info_by_topic(publisher.topic_name)
        if (any(info.node_name == 'follower_executor' for info in subscribers)
                and publisher.get_subscription_count() >= len(subscribers)):
            return
        assert time.monotonic() < deadline, 'the follower never subscribed to the guidance'
        time.sleep(0.02)


def test_follower_drops_malformed_guidance_and_keeps_working(session, tmp_path, task_file, config_dir):
    start_case(session, tmp_path, task_file, config_dir, 'case_8')
    # Followed from before the bad message: case_8 can end within a second of it (volatile topic).
    endings = []
    session.observer.follow('/sgcm/guidance', 'sgcm_interfaces/msg/Guidance',
                            lambda m: endings.append(m) if m.task_complete or m.status else None)
    publisher = session.observer.node.create_publisher(Guidance, '/sgcm/guidance', 10)
    wait_for_follower(session.observer.node, publisher)
    bad = Guidance(round=1000, state=GridState(rows=3, cols=3, colours=['red'], counts=[1]),
                   leader_move=Move(empty=False, source_cell=99, target_cell=0, colour='purple'))
    publisher.publish(bad)
    # The real task still completes: the bad message neither crashed the follower nor
    # made it skip the leader's rounds.
    deadline = time.monotonic() + 240
    while not endings and time.monotonic() < deadline:
        time.sleep(0.1)
    assert endings, 'the task did not end within 240 s'
    assert endings[0].task_complete, endings[0].status
    log = (session.run_dir / 'logs' / 'follower_arm' / 'follower_executor.log').read_text()
    assert 'dropped malformed guidance for round 1000' in log


# One launch per executable proves a bad parameter stops the node with exit code 2 and the message;
# every other bad value is checked against the settings schema in test/unit/sgcm/test_sgcm_settings.py.
@pytest.mark.parametrize('executable, namespace, parameters, expected', [
    ('leader_planner', LEADER_NS, {'horizon': 7}, 'parameter horizon: must be in [0, 6] (got 7)'),
    ('follower_executor', FOLLOWER_NS, {'behaviour': 'sneaky'}, 'parameter behaviour: must be one of'),
])
def test_bad_parameters_stop_the_node_with_a_message(session, task_file, executable, namespace, parameters,
                                                     expected):
    parameters = {'task_file': str(task_file), **parameters}
    process = session.start(NodeSpec('sgcm', executable, name=executable, namespace=namespace,
                                     parameters=[parameters]))
    assert session.wait_for_exit(process.name, timeout=60.0) == 2
    log = process.log_path.read_text()
    assert expected in log
    assert 'Traceback' not in log


def test_bad_task_file_names_the_field(session, tmp_path):
    bad = tmp_path / 'task.yaml'
    bad.write_text('colours: {red: {goal: [5, 0], rgb: [1, 0, 0]}}\n')
    process = session.start(NodeSpec('sgcm', 'leader_planner', name='leader_planner', namespace=LEADER_NS,
                                     parameters=[{'task_file': str(bad)}]))
    assert session.wait_for_exit('leader_arm/leader_planner', timeout=60.0) == 2
    assert 'colours.red.goal: cell [5, 0] is outside the 3x3 grid' in process.log_path.read_text()


def image_msg(array, encoding, stamp, frame_id):
    array = np.ascontiguousarray(array)
    msg = Image(height=int(array.shape[0]), width=int(array.shape[1]), encoding=encoding,
                is_bigendian=int(sys.byteorder == 'big'), step=int(array.strides[0]), data=array.tobytes())
    msg.header.stamp, msg.header.frame_id = stamp, frame_id
    return msg


def test_a_best_effort_camera_feeds_the_leader(session, tmp_path, task_file, config_dir):
    """A camera driver with sensor-data QoS (best effort) is the leader's only camera.

    The bridge simulates case_8 but publishes no images; the test renders the same table with
    the red cube in another cell and publishes that frame best effort. The leader's first
    guidance estimates the test's table, not the bridge's: the frame it used is the test's.
    """
    task, case = start_case(session, tmp_path, task_file, config_dir, 'case_8', follower=False,
                            publish_camera=False)
    red = task.colours.index('red')
    moved = case.counts.copy()
    source = int(np.flatnonzero(moved[:, red])[0])
    target = next(cell for cell in range(task.cells) if cell != source and cell != task.goals[red]
                  and not moved[cell].any())
    moved[source, red], moved[target, red] = 0, 1
    scenario = build_scenario(task, Case('seen', moved), execution_failures=False)
    node = session.observer.node
    publishers = {topic: node.create_publisher(kind, f'/top_camera/{topic}', qos_profile_sensor_data)
                  for topic, kind in (('image_raw', Image), ('labels', Image), ('camera_info', CameraInfo))}
    guidance = []
    node.create_subscription(Guidance, '/sgcm/guidance', guidance.append, 10)
    legend = session.wait_for_message('/top_camera/label_legend', 'bridge_interfaces/msg/LabelLegend',
                                      timeout=60, latched=True)
    with Scene(parse_scenario(scenario, Path(tmp_path))) as scene:
        # Same entities, same labels as the bridge's scene: only the red cube's place differs.
        assert [(e.label, e.name, e.kind) for e in legend.entries] == scene.label_legend()
        scene.step(60)
        frame = scene.render()
        camera = scene.camera
        info = CameraInfo(width=camera.width, height=camera.height, distortion_model='plumb_bob', d=[0.0] * 5,
                          k=[float(v) for v in camera.intrinsics().flatten()],
                          r=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                          p=[float(v) for v in camera.projection().flatten()])
    clock = session.wait_for_message('/clock', 'rosgraph_msgs/msg/Clock', timeout=30)
    info.header.stamp, info.header.frame_id = clock.clock, 'top_camera'
    messages = {'image_raw': image_msg(frame.rgb, 'rgb8', clock.clock, 'top_camera'),
                'labels': image_msg(frame.labels, '16UC1', clock.clock, 'top_camera'), 'camera_info': info}
    for publisher in publishers.values():
        wait_for_subscriber(publisher, timeout=30.0)
    deadline = time.monotonic() + 180.0
    while not guidance:  # a camera driver publishes again and again; best effort may drop a frame
        assert time.monotonic() < deadline, 'the leader published no guidance from the best-effort frames'
        session.check_alive()
        for topic, publisher in publishers.items():
            publisher.publish(messages[topic])
        time.sleep(0.5)
    first = guidance[0]
    assert first.round == 1
    model = RearrangementModel(task)
    assert np.array_equal(np.array(first.state.counts), model.state_of(Case('seen', moved)))
    assert not np.array_equal(np.array(first.state.counts), model.state_of(case))
