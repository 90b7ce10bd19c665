"""coalition-boxpush's results computed from a run's bag (a synthetic bag written with the project's bag writer)."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from coalition_agents.core.agent_state import AgentState
from coalition_agents.experiments.boxpush import read_run

WORKSPACE = Path(__file__).resolve().parents[3]
AGENTS = {
    'pusher_g1': {'task': 'box_pushing_to_goal', 'goal_position': [2.0, 0.0]},
    'pusher_r1': {'task': 'none'},
    'pusher_r2': {'task': 'navigation', 'goal_position': [0.0, 3.0]},
    'localizer_l1': {'task': 'none'},
}


@pytest.fixture
def boxpush_bag(tmp_path):
    """write(statuses, poses): statuses (t, robot, state label, task, coalition_id, leader, members, cost);
    poses (t, {body: (x, y)}) on /ground_truth/bodies."""
    from collab_tools.core.bag_types import build_typestore
    from collab_tools.core.bag_writer import BagWriter

    prefix = tmp_path / 'prefix'
    for package in ('coalition_interfaces', 'bridge_interfaces'):
        shutil.copytree(WORKSPACE / 'interfaces' / package / 'msg', prefix / 'share' / package / 'msg')
    status_type, bodies_type = 'coalition_interfaces/msg/AgentStatus', 'bridge_interfaces/msg/BodyStates'
    store = build_typestore([status_type, bodies_type], prefixes=[prefix])
    T = store.types

    def header(t):
        return T['std_msgs/msg/Header'](stamp=T['builtin_interfaces/msg/Time'](
            sec=int(t), nanosec=int(round((t % 1) * 1e9))), frame_id='world')

    def not_yet():
        return T['builtin_interfaces/msg/Time'](sec=0, nanosec=0)

    def body(name, x, y):
        return T['bridge_interfaces/msg/BodyState'](
            name=name, kind='', label=0,
            pose=T['geometry_msgs/msg/Pose'](position=T['geometry_msgs/msg/Point'](x=x, y=y, z=0.0),
                                             orientation=T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0,
                                                                                         w=1.0)),
            twist=T['geometry_msgs/msg/Twist'](linear=T['geometry_msgs/msg/Vector3'](x=0.0, y=0.0, z=0.0),
                                               angular=T['geometry_msgs/msg/Vector3'](x=0.0, y=0.0, z=0.0)))

    def write(statuses, poses):
        path = tmp_path / 'bag'
        with BagWriter(path, store) as writer:
            writer.add_topic('/ground_truth/bodies', bodies_type)
            for robot in AGENTS:
                writer.add_topic(f'/{robot}/coalition', status_type)
            rows = [(s[0], f'/{s[1]}/coalition', status_type, T[status_type](
                header=header(s[0]), robot=s[1], state=AgentState.from_label(s[2]).value, task=s[3], coalition_id=s[4],
                leader=s[5], members=list(s[6]), cost=float(s[7]), search_started=not_yet(), coalition_found=not_yet(),
                found_cost=0.0, coalition_formed=not_yet(), task_finished=not_yet(), potential_solution=0, reforms=0,
                goal_distance=float('nan'), session=0, requests_sent=0, offers_received=0, retries=0, duplicates=0, dropped=0,
                detail='', commitments=[])) for s in statuses]
            rows += [(t, '/ground_truth/bodies', bodies_type, T[bodies_type](
                header=header(t), bodies=[body(name, *xy) for name, xy in bodies.items()])) for t, bodies in poses]
            for t, topic, type_name, msg in sorted(rows, key=lambda r: r[0]):
                writer.write(topic, int(t * 1e9), bytes(store.serialize_cdr(msg, type_name)))
        return path

    return write


def test_results_from_the_bag(boxpush_bag):
    box = ('pusher_g1/1', 'pusher_g1', ('pusher_g1', 'pusher_r1'), 21.5)
    nav = ('pusher_r2/1', 'pusher_r2', ('pusher_r2', 'localizer_l1'), 17.5)
    statuses = [
        (1.0, 'pusher_g1', 'searching', 'box_pushing_to_goal', '', '', (), 0.0),
        (1.0, 'pusher_r2', 'searching', 'navigation', '', '', (), 0.0),
        (2.5, 'pusher_g1', 'committed', 'box_pushing_to_goal', *box),
        (2.5, 'pusher_r1', 'committed', 'none', *box),
        (2.7, 'pusher_r2', 'committed', 'navigation', *nav),
        (2.7, 'localizer_l1', 'committed', 'none', *nav),
        (9.0, 'pusher_r2', 'completed', 'navigation', *nav),
        (20.0, 'pusher_g1', 'completed', 'box_pushing_to_goal', *box),
    ]
    poses = [(0.5, {'box': (0.0, 0.0), 'pusher_g1': (-0.5, 0.0), 'pusher_r2': (0.0, 0.0)}),
             (20.0, {'box': (1.8, 0.1), 'pusher_g1': (1.3, 0.1), 'pusher_r2': (0.1, 2.9)})]
    run = read_run(boxpush_bag(statuses, poses), AGENTS, goal_tolerance=0.3)
    assert {c['leader']: (c['members'], c['cost']) for c in run['coalitions'].values()} == {
        'pusher_g1': (['pusher_g1', 'pusher_r1'], 21.5), 'pusher_r2': (['pusher_r2', 'localizer_l1'], 17.5)}
    assert run['time_to_form_s'] == {'pusher_g1': 1.5, 'pusher_r2': 1.7}
    assert run['box']['final_distance_m'] == pytest.approx(0.224, abs=1e-3) and run['box']['reached']
    assert run['box']['completed'] and run['navigation']['completed']
    assert run['navigation']['final_distance_m'] == pytest.approx(0.141, abs=1e-3)
    assert run['conflicts'] == [] and run['reforms'] == {'pusher_g1': 0, 'pusher_r2': 0}


def test_a_helper_switching_coalitions_without_release_is_a_conflict(boxpush_bag):
    statuses = [
        (1.0, 'pusher_g1', 'searching', 'box_pushing_to_goal', '', '', (), 0.0),
        (1.0, 'pusher_r2', 'searching', 'navigation', '', '', (), 0.0),
        (2.0, 'pusher_r1', 'committed', 'none', 'pusher_g1/1', 'pusher_g1', ('pusher_g1', 'pusher_r1'), 21.5),
        (3.0, 'pusher_r1', 'committed', 'none', 'pusher_r2/1', 'pusher_r2', ('pusher_r2', 'pusher_r1'), 20.0),
    ]
    run = read_run(boxpush_bag(statuses, [(0.5, {'box': (0.0, 0.0)})]), AGENTS, goal_tolerance=0.3)
    assert run['conflicts'] == [{'robot': 'pusher_r1', 'coalitions': ['pusher_g1/1', 'pusher_r2/1']}]
    assert run['navigation']['final_distance_m'] is None and not run['navigation']['reached']
