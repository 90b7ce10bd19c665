"""Discovery settings, hosts and namespaced sessions of the orchestration (no ROS graph)."""
import pytest

from collab_tools.orchestration.network import Discovery, Host, NetworkConfigError, parse_hosts
from collab_tools.orchestration.node_process import NodeSpec
from collab_tools.orchestration.session import Session, _in_namespace


def test_default_discovery_is_local_only():
    env = Discovery.parse(None).environment()
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    assert 'ROS_DISCOVERY_SERVER' not in env
    assert set(Discovery().unset) == {'ROS_DISCOVERY_SERVER', 'ROS_SUPER_CLIENT'}


def test_subnet_and_static_peers():
    discovery = Discovery.parse({'range': 'subnet', 'static_peers': ['10.1.0.2', 'robot2']})
    env = discovery.environment()
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'SUBNET'
    assert env['ROS_STATIC_PEERS'] == '10.1.0.2;robot2'


def test_discovery_server_makes_super_clients():
    env = Discovery.parse({'server': '10.1.0.1:11811'}).environment()
    assert env['ROS_DISCOVERY_SERVER'] == '10.1.0.1:11811'
    assert env['ROS_SUPER_CLIENT'] == 'TRUE'
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'SYSTEM_DEFAULT'


@pytest.mark.parametrize('bad, field', [
    ({'range': 'everywhere'}, 'discovery.range'),
    ({'server': 'a b'}, 'discovery.server'),
    ({'static_peers': [3]}, 'discovery.static_peers'),
    ({'rnage': 'SUBNET'}, 'discovery.rnage'),
    (['SUBNET'], 'discovery'),
])
def test_bad_discovery_names_the_field(bad, field):
    with pytest.raises(NetworkConfigError, match=field.replace('.', r'\.')):
        Discovery.parse(bad)


def test_hosts():
    hosts = parse_hosts({'arm_b': {'netns': 'sgcm_b'}, 'robot2': 'remote'})
    assert hosts['arm_b'].wrap(['node', '--ros-args']) == ['ip', 'netns', 'exec', 'sgcm_b', 'node', '--ros-args']
    assert hosts['robot2'].remote
    with pytest.raises(NetworkConfigError, match='--host robot2'):
        hosts['robot2'].wrap(['node'])
    with pytest.raises(NetworkConfigError, match=r'hosts\.x'):
        parse_hosts({'x': {'ssh': 'a@b'}})
    with pytest.raises(NetworkConfigError, match=r'hosts\.x\.netns'):
        parse_hosts({'x': {'netns': 'a b'}})


def test_namespaced_session_moves_nodes_and_remaps_the_global_topics():
    spec = NodeSpec('role_engine', 'role_player', namespace='/burger1', remappings={'/tf': '/custom_tf'})
    moved = _in_namespace(spec, '/sim1')
    assert moved.namespace == '/sim1/burger1'
    assert moved.remappings == {'/clock': '/sim1/clock', '/tf': '/custom_tf', '/tf_static': '/sim1/tf_static'}
    assert spec.namespace == '/burger1'  # the caller's spec is unchanged
    top = _in_namespace(NodeSpec('pybullet_bridge', 'pybullet_bridge'), '/sim1')
    assert top.namespace == '/sim1'


def test_session_resolves_names_and_sets_discovery(tmp_path):
    session = Session('t', run_dir=tmp_path, namespace='/sim2', discovery=Discovery.parse({'range': 'SUBNET'}),
                      log=None, domain_id=None)
    assert session.resolve('/clock') == '/sim2/clock'
    assert session.resolve('ground_truth/bodies') == '/sim2/ground_truth/bodies'
    with session:
        env = session.environment()
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'SUBNET'
    assert env['ROS_DOMAIN_ID'].isdigit()


def test_session_started_discovery_server_commands():
    discovery = Discovery.parse({'server': ['127.0.0.1:11811', '127.0.0.1:11812'], 'start_server': True})
    assert discovery.server_commands() == [
        ['fastdds', 'discovery', '-i', '0', '-l', '127.0.0.1', '-p', '11811'],
        ['fastdds', 'discovery', '-i', '1', '-l', '127.0.0.1', '-p', '11812']]
    assert discovery.environment()['ROS_DISCOVERY_SERVER'] == '127.0.0.1:11811;127.0.0.1:11812'
    assert Discovery.parse({'server': '10.0.0.1:11811'}).server_commands() == []
    with pytest.raises(NetworkConfigError, match='start_server'):
        Discovery.parse({'start_server': True})


def test_parameter_file_content_is_written_as_it_is(tmp_path):
    from collab_tools.orchestration.node_process import build_command, is_parameter_file_content
    import yaml
    per_node = {'/**': {'ros__parameters': {'a': 1}}, '/**/robot_2/schema_agent': {'ros__parameters': {'b': 2}}}
    assert is_parameter_file_content(per_node)
    assert not is_parameter_file_content({'a': 1}) and not is_parameter_file_content({})
    spec = NodeSpec('collab_tools', 'scripted_driver', parameters=[per_node, {'c': 3}])
    command = build_command(spec, tmp_path)
    files = [command[i + 1] for i, arg in enumerate(command) if arg == '--params-file']
    assert yaml.safe_load(open(files[0])) == per_node
    assert yaml.safe_load(open(files[1])) == {'/**': {'ros__parameters': {'c': 3}}}


def test_a_local_session_after_a_discovery_server_session_in_one_process_is_refused(tmp_path, monkeypatch):
    from collab_tools.orchestration import session as session_module
    monkeypatch.setattr(session_module, '_OBSERVED_WITH_SERVER', True)
    with Session('t', run_dir=tmp_path, log=None) as session:
        with pytest.raises(RuntimeError, match='its own process'):
            session.observer
