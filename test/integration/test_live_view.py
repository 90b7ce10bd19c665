"""The live view during a real run, started by the session as ``--live`` starts it
(orchestration.live): the bridge and three schema agents (the coalition test's team) with the
visualiser and the live_view node. A client speaking Foxglove's WebSocket protocol (subprotocol
foxglove.sdk.v1, as the Foxglove app) sees the run's topics advertised with their ros2msg schemas,
subscribes, and decodes a visualization_msgs/MarkerArray and the agents' AgentStatus from the CDR
payloads it receives; the node stops forwarding once the client has gone."""

import socket
import time

import pytest
from coalition_interfaces.msg import AgentStatus
from rclpy.serialization import deserialize_message
from visualization_msgs.msg import MarkerArray

from collab_tools.core.bag_types import build_typestore, message_definition
from collab_tools.orchestration.node_process import NodeSpec
from collab_tools.orchestration.session import Session
from foxglove_client import SUBPROTOCOL, FoxgloveClient
from test_coalition_agents import HELPER, LEADER, start_team

MARKERS = '/markers/coalitions'
STATUS_TOPIC = f'/{LEADER}/coalition'
STATUS_TYPE = 'coalition_interfaces/msg/AgentStatus'


@pytest.fixture
def session(live_session):
    return live_session


def test_a_foxglove_client_watches_a_coalition_form(session, port, config_dir):
    assert set(session.nodes) == {'live_view', 'visualiser'}  # started first, by the session
    coalitions = config_dir / 'coalitions'
    files = {'capability_file': str(coalitions / 'capabilities' / 'coalition_three_robots.yaml'),
             'schemas_file': str(coalitions / 'schemas.yaml'), 'costs_file': str(coalitions / 'costs.yaml'),
             'tasks_file': str(coalitions / 'tasks.yaml')}
    start_team(session, files, config_dir, 0.0)

    with FoxgloveClient(f'ws://127.0.0.1:{port}', timeout=20.0) as client:
        assert client.subprotocol == SUBPROTOCOL
        assert client.pump_until(lambda: {MARKERS, STATUS_TOPIC} <= set(client.channels), 40.0), \
            sorted(client.channels)
        assert client.server_info is not None and client.server_info['name'] == 'hetero_collab'
        for topic, type_name in ((MARKERS, 'visualization_msgs/msg/MarkerArray'), (STATUS_TOPIC, STATUS_TYPE)):
            channel = client.channels[topic]
            assert (channel['encoding'], channel['schemaEncoding'], channel['schemaName']) == \
                ('cdr', 'ros2msg', type_name)
            # The schema is the definition the bag recorder writes into its MCAP files.
            assert channel['schema'] == message_definition(build_typestore([type_name]), type_name)
        # Topics nobody watches are advertised, not forwarded.
        assert '/clock' in client.channels and not client.messages

        client.subscribe(MARKERS)
        client.subscribe(STATUS_TOPIC)

        def helper_line_seen() -> bool:
            arrays = [deserialize_message(p, MarkerArray) for p in client.payloads(MARKERS)]
            return any(m.ns == 'helps' for array in arrays for m in array.markers)
        assert client.pump_until(helper_line_seen, 45.0), 'no marker of the helper -> leader line arrived'

        # The status is latched and published on change, so it may come after the markers (CI).
        assert client.pump_until(lambda: client.payloads(STATUS_TOPIC), 20.0), 'no status arrived'
        statuses = [deserialize_message(p, AgentStatus) for p in client.payloads(STATUS_TOPIC)]
        assert all(s.robot == LEADER for s in statuses)
        assert client.pump_until(lambda: any(
            deserialize_message(p, AgentStatus).state == AgentStatus.COMMITTED
            for p in client.payloads(STATUS_TOPIC)), 20.0)
        arrays = [deserialize_message(p, MarkerArray) for p in client.payloads(MARKERS)]
        line = next(m for array in arrays for m in array.markers if m.ns == 'helps')
        assert line.header.frame_id == 'world' and len(line.points) == 2
        texts = [m.text for array in arrays for m in array.markers if m.ns == 'states']
        assert any(t.startswith(f'{HELPER}: COMMITTED') for t in texts), texts
        assert all(log_time > 0 for _, log_time, _ in client.messages)
    # Nothing is forwarded once the client has gone: the node drops its subscriptions.
    log = session.nodes['live_view'].log_path
    deadline = time.monotonic() + 10.0
    while 'stopped forwarding /markers/coalitions' not in log.read_text():
        assert time.monotonic() < deadline, log.read_text()[-2000:]
        time.sleep(0.2)
    assert session.nodes['live_view'].poll() is None and session.nodes['visualiser'].poll() is None


@pytest.mark.parametrize('executable, parameters, message', [
    ('live_view', {'port': 70000}, 'parameter port: must be in [0, 65535]'),
    ('live_view', {'host': 'laptop'}, 'parameter host: must be an IP address'),
    ('live_view', {'port': 'taken'}, 'parameter host/port: cannot serve on 127.0.0.1:'),
    ('visualiser', {'sources': ['sgcm', 'maps']}, 'parameter sources: must be one of'),
])
def test_a_bad_parameter_stops_the_node_with_a_message(tmp_path, executable, parameters, message):
    with socket.socket() as taken, Session('bad_live', run_dir=tmp_path / 'run', log=None, live=None) as session:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        if parameters.get('port') == 'taken':
            parameters = {'port': taken.getsockname()[1]}
        process = session.start(NodeSpec('collab_tools', executable, name=executable, parameters=[parameters]))
        assert session.wait_for_exit(executable, timeout=60.0) == 2
        assert message in process.log_path.read_text()
