"""The roles-formation results computed from a synthetic bag written with the project's bag tools (no simulation)."""
import math
from pathlib import Path

import numpy as np
import pytest

from collab_tools.core.bag_types import build_typestore
from collab_tools.core.bag_writer import BagWriter, QosSpec

from role_engine.experiments.formation import formation_acceptance  # noqa: E402
from role_engine.experiments.formation_bag import commanded_positions, formation_results, read_formation_bag  # noqa: E402

WS = Path(__file__).resolve().parents[3]
#: The recorded engine's session (role_engine.core.sessions).
SESSION = 7
TYPES = {'/roles/assignment': 'role_interfaces/msg/RoleAssignment', '/roles/channel': 'role_interfaces/msg/ProcessRole',
         '/ground_truth/bodies': 'bridge_interfaces/msg/BodyStates', '/a/cmd_vel': 'geometry_msgs/msg/Twist',
         '/b/cmd_vel': 'geometry_msgs/msg/Twist'}
RADII = {'a': 0.2, 'b': 0.1}
START = 2.0            # the round's roles start at t = 2 s
GOALS = {'a': (1.0, 0.0), 'b': (-1.0, 0.0)}


@pytest.fixture
def typestore(tmp_path):
    prefix = tmp_path / 'prefix'
    for package in ('role_interfaces', 'bridge_interfaces'):
        target = prefix / 'share' / package / 'msg'
        target.mkdir(parents=True)
        for msg in (WS / 'interfaces' / package / 'msg').glob('*.msg'):
            (target / msg.name).write_text(msg.read_text())
    return build_typestore(list(TYPES.values()), prefixes=[prefix])


def _header(T, t):
    stamp = T['builtin_interfaces/msg/Time'](sec=int(t), nanosec=int(round((t % 1) * 1e9)))
    return T['std_msgs/msg/Header'](stamp=stamp, frame_id='world')


def _role(T, t, robot, start, goal, version, arrived=False):
    """A straight constant-speed role of 11 states over 10 s from ``start`` to ``goal``."""
    xs, ys = np.linspace(start[0], goal[0], 11), np.linspace(start[1], goal[1], 11)
    vx, vy = (goal[0] - start[0]) / 10.0, (goal[1] - start[1]) / 10.0
    return T['role_interfaces/msg/ProcessRole'](
        header=_header(T, t), sender=f'/{robot}/role_player', session=SESSION, robot=robot, role_id=f'line_{robot}', round=1, version=version, start_time=START,
        dt=1.0, radius=RADII[robot], x=xs, y=ys, vx=np.full(11, vx), vy=np.full(11, vy), arrived=arrived)


def _bodies(T, t, positions):
    vec = T['geometry_msgs/msg/Vector3']
    return T['bridge_interfaces/msg/BodyStates'](header=_header(T, t), bodies=[
        T['bridge_interfaces/msg/BodyState'](
            name=name, kind='mobile_robot', label=k + 1,
            pose=T['geometry_msgs/msg/Pose'](
                position=T['geometry_msgs/msg/Point'](x=x, y=y, z=0.0),
                orientation=T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0)),
            twist=T['geometry_msgs/msg/Twist'](linear=vec(x=0.0, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0)))
        for k, (name, (x, y)) in enumerate(positions.items())])


def truth_at(t, pass_gap):
    """a moves from (-1, 0.5 * gap) to its goal, b the other way at y = -0.5 * gap, both over [2, 12] s."""
    s = min(max((t - START) / 10.0, 0.0), 1.0)
    return {'a': (-1.0 + 2.0 * s, 0.5 * pass_gap * math.sin(math.pi * s) + 0.0),
            'b': (1.0 - 2.0 * s, -0.5 * pass_gap * math.sin(math.pi * s))}


def write_bag(path, typestore, *, pass_gap, b_arrives=True, end=14.0):
    T = typestore.types
    with BagWriter(path, typestore) as writer:
        for topic, type_name in TYPES.items():
            writer.add_topic(topic, type_name, [QosSpec('keep_last', 10, 'reliable', 'volatile')])

        def put(topic, t, msg):
            writer.write(topic, int(round(t * 1e9)), bytes(typestore.serialize_cdr(msg, TYPES[topic])))

        initial = [_role(T, 1.0, r, (-GOALS[r][0], 0.0), GOALS[r], 0) for r in ('a', 'b')]
        put('/roles/assignment', 1.0, T['role_interfaces/msg/RoleAssignment'](
            header=_header(T, 1.0), sender='/role_engine', session=SESSION, round=1, status='assigned', message='initial negotiation', robots=['a', 'b'],
            role_ids=['line_a', 'line_b'], goal_x=np.array([1.0, -1.0]), goal_y=np.array([0.0, 0.0]),
            excluded_robots=[], initial_roles=initial))
        for role in initial:
            put('/roles/channel', 1.0, role)
        for k in range(int(end * 10) + 1):
            t = k / 10.0
            put('/ground_truth/bodies', t, _bodies(T, t, truth_at(t, pass_gap)))
            twist = T['geometry_msgs/msg/Twist'](linear=T['geometry_msgs/msg/Vector3'](x=0.2, y=0.0, z=0.0),
                                                 angular=T['geometry_msgs/msg/Vector3'](x=0.0, y=0.0, z=0.1 * k))
            put('/a/cmd_vel', t, twist)
        put('/roles/channel', 12.5, _role(T, 12.5, 'a', (-1.0, 0.0), GOALS['a'], 5, arrived=True))
        if b_arrives:
            put('/roles/channel', 13.0, _role(T, 13.0, 'b', (1.0, 0.0), GOALS['b'], 6, arrived=True))
    return path


def test_reads_every_topic_of_the_bag(tmp_path, typestore):
    log = read_formation_bag(write_bag(tmp_path / 'bag', typestore, pass_gap=0.6), ['a', 'b'])
    assert [a.round for a in log.assignments] == [1]
    assert log.assignments[0].goals == GOALS and log.assignments[0].start_time == START
    assert [r.version for r in log.roles['a']] == [0, 5] and log.roles['a'][-1].arrived
    assert len(log.truth_times) == 141 and log.truth['b'].shape == (141, 2)
    np.testing.assert_allclose(log.truth['a'][-1], [1.0, 0.0], atol=1e-9)
    assert log.commands['a'].shape == (141, 3) and len(log.commands['b']) == 0
    np.testing.assert_allclose(log.commands['a'][10], [1.0, 0.2, 0.1 * 10])


def test_results_of_a_clean_run(tmp_path, typestore):
    log = read_formation_bag(write_bag(tmp_path / 'bag', typestore, pass_gap=0.6), ['a', 'b'])
    results = formation_results(log, RADII, arrival_tolerance=0.08)
    # Closest at the middle of the crossing (t = 7 s): a at (0, 0.3), b at (0, -0.3).
    assert results['min_distance'] == pytest.approx(0.6, abs=1e-6)
    assert results['min_distance_time'] == pytest.approx(7.0)
    assert results['sum_of_radii'] == pytest.approx(0.3)
    assert results['min_clearance'] == pytest.approx(0.3, abs=1e-6)
    assert results['collisions'] == 0
    assert results['completed'] is True and results['final_round'] == 1
    assert results['robots']['a']['arrival_time'] == pytest.approx(12.5 - START)
    assert results['robots']['b']['arrival_time'] == pytest.approx(13.0 - START)
    assert results['robots']['a']['final_error'] == pytest.approx(0.0, abs=1e-9)
    # The commanded role is straight; the truth bulges sideways by up to 0.3 m in the middle.
    assert results['robots']['a']['tracking_error_max'] == pytest.approx(0.3, abs=1e-3)
    assert formation_acceptance(results)['passed']


def test_collisions_are_counted_and_fail_the_acceptance(tmp_path, typestore):
    log = read_formation_bag(write_bag(tmp_path / 'bag', typestore, pass_gap=0.1), ['a', 'b'])
    results = formation_results(log, RADII, arrival_tolerance=0.08)
    assert results['min_distance'] == pytest.approx(0.1, abs=1e-6)
    assert results['collisions'] == 1              # one contact episode, however long
    assert results['collisions_by_pair'] == {'a-b': 1}
    acceptance = formation_acceptance(results)
    assert not acceptance['passed'] and acceptance['checks']['no_collision'] is False


def test_a_robot_that_never_reports_arrival_leaves_the_run_unfinished(tmp_path, typestore):
    log = read_formation_bag(write_bag(tmp_path / 'bag', typestore, pass_gap=0.6, b_arrives=False), ['a', 'b'])
    results = formation_results(log, RADII, arrival_tolerance=0.08)
    assert results['completed'] is False
    assert results['robots']['b']['arrived'] is False and results['robots']['b']['arrival_time'] is None
    assert not formation_acceptance(results)['passed']


def test_stop_player_acceptance_needs_a_renegotiation_without_it(tmp_path, typestore):
    log = read_formation_bag(write_bag(tmp_path / 'bag', typestore, pass_gap=0.6), ['a', 'b'])
    results = formation_results(log, RADII, arrival_tolerance=0.08)
    acceptance = formation_acceptance(results, stopped='b')
    assert acceptance['checks']['renegotiated_without_stopped'] is False and not acceptance['passed']


def test_commanded_position_is_the_latest_role_in_force(tmp_path, typestore):
    log = read_formation_bag(write_bag(tmp_path / 'bag', typestore, pass_gap=0.6), ['a', 'b'])
    positions = commanded_positions(log.roles['a'], np.array([0.5, 2.0, 7.0, 20.0]))
    assert np.isnan(positions[0]).all()                       # before any role was published
    np.testing.assert_allclose(positions[1:], [[-1.0, 0.0], [0.0, 0.0], [1.0, 0.0]], atol=1e-9)


def test_a_bag_without_ground_truth_is_a_clear_error(tmp_path, typestore):
    log = read_formation_bag(write_bag(tmp_path / 'bag', typestore, pass_gap=0.6), ['a', 'c'])
    with pytest.raises(ValueError, match='ground_truth'):
        formation_results(log, {'a': 0.2, 'c': 0.1}, arrival_tolerance=0.08)


def test_table_and_plots_are_written_from_the_bag(tmp_path, typestore):
    from role_engine.experiments.formation import formation_markdown, plot_commanded_vs_tracked, plot_commands
    log = read_formation_bag(write_bag(tmp_path / 'bag', typestore, pass_gap=0.1), ['a', 'b'])
    results = formation_results(log, RADII, arrival_tolerance=0.08)
    text = formation_markdown(results, formation_acceptance(results))
    assert '| a | line_a | yes | 10.5 | 0.000 |' in text and 'collisions 1' in text and 'FAILED' in text
    plot_commanded_vs_tracked(log, results, tmp_path / 'tracked.png')
    plot_commands(log, tmp_path / 'cmd.png')
    assert (tmp_path / 'tracked.png').stat().st_size > 10_000 and (tmp_path / 'cmd.png').stat().st_size > 10_000


def test_the_stopped_player_is_found_by_its_robot_namespace():
    from collab_tools.orchestration.experiment import load_experiment, parse_node
    from role_engine.experiments.formation import player_label

    data = load_experiment(WS / 'config' / 'experiments' / 'roles_formation.yaml')
    players = [parse_node(n, 'node') for n in data['nodes'] if n['executable'] == 'role_player']
    assert sorted(p.namespace for p in players) == ['/burger_1', '/burger_2', '/pioneer_1', '/pioneer_2']
    assert player_label(data, 'burger_2') == next(p.label for p in players if p.namespace == '/burger_2')
    with pytest.raises(ValueError, match='no role_player node runs in the namespace /burger_9'):
        player_label(data, 'burger_9')
