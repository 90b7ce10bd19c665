"""The pure parts of the simulated coalition experiments: the generated scenarios (column,
clusters) and the results computed from a run's bag (a synthetic bag written with the project's
bag writer)."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from coalition_agents.core import load_capability_file, load_library
from coalition_agents.core.agent_state import AgentState
from coalition_agents.core.errors import ConfigError
from coalition_agents.core.sim_scenarios import (
    COLUMN_TYPES, SensorSettings, agent_parameter_file, bridge_scenario, capability_file, capability_text,
    column_placements,
    column_sees_only_the_robot_ahead, placements_from_poses,
)

WORKSPACE = Path(__file__).resolve().parents[3]
INTERFACES = WORKSPACE / 'interfaces' / 'coalition_interfaces' / 'msg'


# --- scenario generation -----------------------------------------------------------------------

def test_column_puts_the_localising_robot_in_front_and_everyone_facing_it():
    placements = column_placements(4, spacing_m=1.5)
    assert [p.robot for p in placements] == ['robot_1', 'robot_2', 'robot_3', 'robot_4']
    assert [p.robot_type for p in placements] == ['localizer', 'blind', 'blind', 'blind']
    assert [p.x for p in placements] == [0.0, -1.5, -3.0, -4.5]
    assert all(p.heading_deg == 0.0 and p.y == 0.0 for p in placements)


@pytest.mark.parametrize('robots, spacing, message', [(1, 1.0, 'robots'), (True, 1.0, 'robots'),
                                                      (3, 0.0, 'spacing_m')])
def test_column_rejects_bad_sizes(robots, spacing, message):
    with pytest.raises(ConfigError, match=message):
        column_placements(robots, spacing)


def test_fiducial_must_reach_only_the_robot_ahead():
    assert column_sees_only_the_robot_ahead(1.0, SensorSettings(60.0, 1.5))
    assert not column_sees_only_the_robot_ahead(1.0, SensorSettings(60.0, 2.0))   # sees two ahead
    assert not column_sees_only_the_robot_ahead(1.0, SensorSettings(60.0, 0.9))   # sees nobody
    assert not column_sees_only_the_robot_ahead(1.0, SensorSettings(360.0, 1.5))  # sees behind


def test_bridge_scenario_and_team_file_of_a_column_load(library, tmp_path):
    placements = column_placements(3)
    sensors = SensorSettings(60.0, 1.5)
    scenario = bridge_scenario('column', placements, COLUMN_TYPES, sensors, seed=3)
    robots = {r['name']: r for r in scenario['mobile_robots']}
    assert set(robots['robot_1']['sensors']) == {'fiducial', 'laser', 'gps'}
    assert set(robots['robot_3']['sensors']) == {'fiducial', 'laser'}
    assert robots['robot_2']['sensors']['fiducial'] == {'fov_deg': 60.0, 'range': 1.5, 'rate': 10.0,
                                                         'active': False}
    assert not any(s['active'] for r in robots.values() for s in r['sensors'].values())
    x0, y0, x1, y1 = scenario['world']['bounds']
    assert x0 < -2.0 and x1 > 0.0 and y0 < 0.0 < y1
    colours = [r['color'] for r in scenario['mobile_robots']]
    assert all(sum((a - b) ** 2 for a, b in zip(c1, c2)) ** 0.5 >= 0.1
               for i, c1 in enumerate(colours) for c2 in colours[i + 1:])
    team_path = tmp_path / 'team.yaml'
    team_path.write_text(yaml.safe_dump(capability_file(placements, COLUMN_TYPES)))
    team = load_capability_file(team_path, library)
    assert team.robots['robot_1'].sensor_names == ('fiducial', 'laser', 'gps')
    assert 'gps' not in team.robots['robot_2'].sensor_names


def test_clusters_team_renames_the_papers_sensor_names_for_the_bridge(config_dir, library, tmp_path):
    types = yaml.safe_load((config_dir / 'capabilities' / 'fig7_team.yaml').read_text())['robot_types']
    placements = placements_from_poses({'robot_red': (0.0, 0.0, 0.0), 'helper_1': (2.5, 0.5, 0.0)},
                                       {'robot_red': 'type1', 'helper_1': 'type2'})
    with pytest.raises(ConfigError, match="'localization' is not a bridge sensor"):
        capability_file(placements, types)
    team = capability_file(placements, types, {'localization': 'gps'})
    assert [s['name'] for s in team['robot_types']['type2']['sensors']] == ['fiducial', 'laser', 'gps']
    path = tmp_path / 'team.yaml'
    path.write_text(yaml.safe_dump(team))
    assert load_capability_file(path, library).robots['helper_1'].sensor_names == ('fiducial', 'laser', 'gps')
    with pytest.raises(ConfigError, match='robots.ghost: no type'):
        placements_from_poses({'ghost': (0, 0, 0)}, {})


def test_agent_parameter_file_is_keyed_by_the_node_in_its_robot_namespace():
    data = agent_parameter_file({'task': 'none'}, {'robot_2': {'task': 'navigation'}})
    # /**/<robot>/schema_agent: also when the robot's namespace sits under a session's (/sim1/robot_2)
    assert data == {'/**': {'ros__parameters': {'task': 'none'}},
                    '/**/robot_2/schema_agent': {'ros__parameters': {'task': 'navigation'}}}


def test_capability_text_is_the_team_in_one_line(library):
    from coalition_agents.core import capability_file_from_text
    team = capability_file(column_placements(3), COLUMN_TYPES)
    text = capability_text(team)
    assert '\n' not in text and yaml.safe_load(text) == team
    assert capability_file_from_text(text, library).robots['robot_1'].sensor_names == ('fiducial', 'laser', 'gps')


def run_dir_paths(value, run_dir: Path) -> list[str]:
    """Every string in ``value`` (nested) that names something in the run directory."""
    if isinstance(value, dict):
        return [p for item in value.values() for p in run_dir_paths(item, run_dir)]
    if isinstance(value, list):
        return [p for item in value for p in run_dir_paths(item, run_dir)]
    return [value] if isinstance(value, str) and ('{run_dir}' in value or str(run_dir) in value) else []


@pytest.mark.parametrize('hosted, processes', [(True, 2), (False, 1)])
def test_run_session_gives_the_agents_their_parameters_not_files(monkeypatch, tmp_path, config_dir, library,
                                                                 hosted, processes):
    """The generated experiment: only the bridge reads a file of the run directory (its scenario);
    every agent process gets the team inline and its robots' parameters as a parameter-file mapping."""
    from collab_tools.orchestration import experiment as orchestration
    from coalition_agents.core import capability_file_from_text
    from coalition_agents.experiments.sessions import AgentSetup, run_session
    monkeypatch.setattr(orchestration, 'run_experiment', lambda path, *args, **kwargs: path)
    placements = column_placements(3)
    setup = AgentSetup(leaders=('robot_3',), hosted=hosted, host_processes=processes,
                       bridge_control_period=0.05 if hosted else None)
    generated = run_session(tmp_path, config_dir.parent, 'column', placements, COLUMN_TYPES, SensorSettings(60.0, 1.5),
                            setup)
    experiment = yaml.safe_load(Path(generated).read_text())
    agents = {}
    for node in experiment['nodes']:
        paths = run_dir_paths(node.get('parameters', []), tmp_path)
        if node['executable'] == 'pybullet_bridge':
            assert paths == ['{run_dir}/scenario.yaml']
            periods = [e['control_period'] for e in node['parameters'] if isinstance(e, dict) and 'control_period' in e]
            assert periods == ([0.05] if hosted else [])   # the column's bridge_control_period, last
            continue
        assert paths == [], (node['executable'], paths)
        mappings = [e for e in node['parameters'] if isinstance(e, dict) and '/**' in e]
        assert len(mappings) == 1
        common = mappings[0]['/**']['ros__parameters']
        assert 'capability_file' not in common
        team = capability_file_from_text(common['capabilities'], library)
        assert sorted(team.robots) == ['robot_1', 'robot_2', 'robot_3']
        for key, entry in mappings[0].items():
            if key != '/**':
                agents[key] = entry['ros__parameters']
    # Every robot's own entry exactly once (a host gets its group's; a lone agent its own).
    assert sorted(agents) == [f'/**/robot_{k}/schema_agent' for k in (1, 2, 3)]
    assert agents['/**/robot_3/schema_agent']['task'] == 'navigation'
    assert sum(n['executable'] in ('schema_agent_host', 'schema_agent') for n in experiment['nodes']) == \
        (processes if hosted else 3)


def test_column_config_errors_name_the_field(tmp_path):
    from coalition_agents.experiments.column import load_column_config
    good = {'robots': [2, 10], 'spacing_m': 1.0, 'fiducial': {'fov_deg': 60.0, 'range_m': 1.5},
            'search_time_s': {'default': 2.0, 10: 3.0}, 'paper_time_s': {10: 28.0}}
    path = tmp_path / 'column.yaml'
    path.write_text(yaml.safe_dump(good))
    config = load_column_config(path)
    assert config.robots == (2, 10) and config.search_time(10) == 3.0 and config.search_time(2) == 2.0
    assert config.paper_time_s == {10: 28.0}
    assert config.agent_processes == 1
    path.write_text(yaml.safe_dump({**good, 'agent_processes': 2}))
    assert load_column_config(path).agent_processes == 2
    assert config.bridge_control_period is None
    path.write_text(yaml.safe_dump({**good, 'bridge_control_period': 0.05}))
    assert load_column_config(path).bridge_control_period == 0.05
    for change, message in ((({'fiducial': {'fov_deg': 60.0, 'range_m': 2.5}}), 'fiducial: each robot must see only'),
                            ({'robots': [1]}, 'robots'), ({'search_time_s': {10: 3.0}}, 'search_time_s.default'),
                            ({'search_time_s': {'default': 2.0, 'ten': 3.0}}, 'search_time_s.ten'),
                            ({'agent_processes': 0}, 'agent_processes'), ({'agent_processes': 1.5}, 'agent_processes'),
                            ({'bridge_control_period': 0.2}, 'bridge_control_period'),
                            ({'bridge_control_period': 0}, 'bridge_control_period'), ({'colour': 1}, 'colour')):
        path.write_text(yaml.safe_dump({**good, **change}))
        with pytest.raises(ConfigError, match=message):
            load_column_config(path)


def test_host_groups_split_the_agents_evenly_with_the_leaders_in_the_first_host():
    from coalition_agents.experiments.sessions import host_groups
    robots = [f'robot_{k}' for k in range(1, 11)]
    groups = host_groups(robots, ['robot_10'], 2)
    assert groups == [['robot_10', 'robot_1', 'robot_2', 'robot_3', 'robot_4'],
                      ['robot_5', 'robot_6', 'robot_7', 'robot_8', 'robot_9']]
    assert host_groups(robots, ['robot_10'], 1) == [['robot_10', *robots[:9]]]
    three = host_groups(robots[:7], ['robot_2', 'robot_5'], 3)
    assert [len(group) for group in three] == [3, 2, 2] and three[0][:2] == ['robot_2', 'robot_5']
    assert sorted(sum(three, [])) == sorted(robots[:7])
    assert host_groups(robots[:2], ['robot_2'], 5) == [['robot_2'], ['robot_1']]  # no empty host
    with pytest.raises(ConfigError, match='host_processes'):
        host_groups(robots, ['robot_1', 'robot_2', 'robot_3'], 5)  # 2 robots per host < 3 leaders
    with pytest.raises(ConfigError, match='host_processes'):
        host_groups(robots, ['robot_1'], 0)


# --- results from a bag --------------------------------------------------------------------------

@pytest.fixture
def coalition_bag(tmp_path):
    """write(path, statuses, messages, typed=None): a bag with /coalition/channel and /<robot>/coalition.

    statuses: (t, robot, state label, task, coalition_id, leader, members, cost);
    messages: (t, sender, receiver, kind, members);
    typed: status index -> the AgentStatus stamps (s, 0 = not yet) and other typed fields it carries."""
    from collab_tools.core.bag_types import build_typestore
    from collab_tools.core.bag_writer import BagWriter

    prefix = tmp_path / 'prefix'
    msg_dir = prefix / 'share' / 'coalition_interfaces' / 'msg'
    msg_dir.mkdir(parents=True)
    for source in INTERFACES.glob('*.msg'):
        (msg_dir / source.name).write_text(source.read_text())
    status_type, message_type = 'coalition_interfaces/msg/AgentStatus', 'coalition_interfaces/msg/AgentMessage'
    store = build_typestore([status_type, message_type], prefixes=[prefix])
    T = store.types

    def time(t):
        return T['builtin_interfaces/msg/Time'](sec=int(t), nanosec=int(round((t % 1) * 1e9)))

    def header(t):
        return T['std_msgs/msg/Header'](stamp=time(t), frame_id='')

    def status_fields(fields):
        """AgentStatus's typed fields: zero stamps (not yet) unless given."""
        typed = {'search_started': 0.0, 'coalition_found': 0.0, 'found_cost': 0.0, 'coalition_formed': 0.0,
                 'task_finished': 0.0, 'potential_solution': 0, 'reforms': 0, 'goal_distance': float('nan'),
                 'commitments': [], **fields}
        stamps = ('search_started', 'coalition_found', 'coalition_formed', 'task_finished')
        return {key: time(value) if key in stamps else value for key, value in typed.items()}

    def info():
        return T['coalition_interfaces/msg/Information'](type='', referents=[])

    # AgentMessage's streamed values (INFORMATION messages), empty here
    streamed_values = {'values': []} if 'values' in T[message_type].__dataclass_fields__ else {}

    def write(path, statuses, messages, typed=None):
        typed = typed or {}
        with BagWriter(path, store) as writer:
            writer.add_topic('/coalition/channel', message_type)
            for robot in sorted({s[1] for s in statuses}):
                writer.add_topic(f'/{robot}/coalition', status_type)
            rows = [(s[0], f'/{s[1]}/coalition', status_type, T[status_type](
                header=header(s[0]), robot=s[1], state=AgentState.from_label(s[2]).value, task=s[3], coalition_id=s[4],
                leader=s[5], members=list(s[6]), cost=float(s[7]), requests_sent=0, offers_received=0, retries=0,
                session=0, duplicates=0, dropped=0, detail='', **status_fields(typed.get(index, {}))))
                for index, s in enumerate(statuses)]
            rows += [(m[0], '/coalition/channel', message_type, T[message_type](
                header=header(m[0]), message_id=i + 1, sender=m[1], receiver=m[2], kind=m[3], conversation_id=0,
                in_reply_to=0, label=info(), chain=[], instance=info(), cost=0.0, members=list(m[4]), coalition_id='',
                hold_seconds=0.0, reason='', **streamed_values)) for i, m in enumerate(messages)]
            for t, topic, type_name, msg in sorted(rows, key=lambda r: r[0]):
                writer.write(topic, int(t * 1e9), bytes(store.serialize_cdr(msg, type_name)))
        return path

    return write


REQUEST, OFFER, ACK = 1, 2, 3


def test_column_result_from_a_bag(coalition_bag, tmp_path):
    from coalition_agents.experiments.coalition_bag import read_coalition_bag
    from coalition_agents.experiments.column import column_result
    members = ('robot_3', 'robot_1', 'robot_2')
    statuses = [(10.0, 'robot_1', 'idle', 'none', '', '', (), 0), (10.0, 'robot_2', 'idle', 'none', '', '', (), 0),
                (10.1, 'robot_3', 'searching', 'navigation', '', '', (), 0),
                (12.2, 'robot_3', 'negotiating', 'navigation', '', '', (), 0),
                (12.25, 'robot_1', 'committed', 'none', 'c1', 'robot_3', members, 25.5),
                (12.26, 'robot_2', 'committed', 'none', 'c1', 'robot_3', members, 25.5),
                (12.3, 'robot_3', 'committed', 'navigation', 'c1', 'robot_3', members, 25.5)]
    messages = [(10.12, 'robot_3', 'robot_2', REQUEST, ()), (10.12, 'robot_3', 'robot_1', REQUEST, ()),
                (10.13, 'robot_2', 'robot_3', ACK, ()),
                (10.4, 'robot_1', 'robot_3', OFFER, ('robot_1',)),            # a partial coalition
                (10.9, 'robot_2', 'robot_3', OFFER, ('robot_1', 'robot_2')),  # the whole coalition
                (11.0, 'robot_2', 'robot_3', OFFER, ('robot_1', 'robot_2'))]
    bag = coalition_bag(tmp_path / 'bag', statuses, messages)
    run = read_coalition_bag(bag)
    assert run.leaders() == ['robot_3'] and run.robots() == ['robot_1', 'robot_2', 'robot_3']
    result = column_result(run, 3, bin_s=0.1)
    assert result['state'] == 'committed' and result['includes_all_robots']
    assert result['time_s'] == pytest.approx(0.8, abs=1e-6)        # 10.9 - 10.1
    assert result['formed_s'] == pytest.approx(2.2, abs=1e-6)      # 12.3 - 10.1
    assert result['cost'] == 25.5 and result['messages'] == 6
    assert result['kinds'] == {'request': 2, 'ack': 1, 'offer': 3}
    counts = result['counts']
    assert sum(counts['sent']['robot_3']) == 2 and sum(counts['received']['robot_3']) == 4
    assert counts['sent']['robot_3'][0] == 2 and counts['received']['robot_3'][8] == 1  # 10.9 s -> bin 8
    assert result['conflicting_commitments'] == {}


def test_a_robot_committed_to_two_coalitions_is_reported(coalition_bag, tmp_path):
    from coalition_agents.experiments.coalition_bag import (
        commitments, conflicting_commitments, leader_timeline, read_coalition_bag,
    )
    statuses = [(1.0, 'helper', 'committed', 'none', 'a/1', 'a', ('a', 'helper'), 16),
                (2.0, 'helper', 'committed', 'none', 'b/1', 'b', ('b', 'helper'), 16),   # no release in between
                (3.0, 'other', 'committed', 'none', 'a/1', 'a', ('a', 'other'), 16),
                (4.0, 'other', 'idle', 'none', '', '', (), 0),                            # released
                (5.0, 'other', 'committed', 'none', 'b/2', 'b', ('b', 'other'), 16),
                (0.5, 'a', 'searching', 'navigation', '', '', (), 0)]
    run = read_coalition_bag(coalition_bag(tmp_path / 'bag', statuses, []))
    assert conflicting_commitments(run) == {'helper': ['a/1', 'b/1']}
    assert commitments(run) == {'helper': ['a/1', 'b/1'], 'other': ['a/1', 'b/2']}
    timeline = leader_timeline(run, 'a')   # searched, never committed, no offers
    assert timeline.state == 'searching' and timeline.found is None and timeline.formed_s is None


def test_found_is_the_leaders_first_executable_coalition_status(coalition_bag, tmp_path):
    from coalition_agents.experiments.coalition_bag import leader_timeline, read_coalition_bag
    members = ('robot_2', 'robot_1')
    statuses = [(5.0, 'robot_2', 'searching', 'navigation', '', '', (), 0),
                (5.4, 'robot_2', 'searching', 'navigation', '', '', (), 0),
                (5.8, 'robot_1', 'committed', 'none', 'c', 'robot_2', members, 16),
                (5.9, 'robot_2', 'committed', 'navigation', 'c', 'robot_2', members, 16)]
    # The leader's status at 5.4 reports its search start and its first executable coalition (typed stamps).
    typed = {1: {'search_started': 5.0, 'coalition_found': 5.4, 'found_cost': 16.0}}
    # An offer covering the helper arrives earlier than the status: the status decides.
    messages = [(5.2, 'robot_1', 'robot_2', OFFER, ('robot_1',))]
    run = read_coalition_bag(coalition_bag(tmp_path / 'bag', statuses, messages, typed))
    timeline = leader_timeline(run, 'robot_2')
    assert timeline.found_s == pytest.approx(0.4, abs=1e-6) and timeline.formed_s == pytest.approx(0.9, abs=1e-6)
