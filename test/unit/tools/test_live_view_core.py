"""The live view's pure parts: topic selection, schemas as the recorder writes them, channel
bookkeeping (client subscriptions -> ROS subscriptions), settings, marker descriptions."""
import threading

import pytest

from collab_tools.core.bag_types import UnknownMessageTypeError, build_typestore, message_definition
from collab_tools.core.errors import ConfigurationError
from collab_tools.core.live_view import (LIVE_VIEW_SETTINGS, LiveChannels, SchemaBook, TopicSelection,
                                         connect_hint, host_problem)
from collab_tools.core.marker_specs import MARKER_SOURCES, MarkerInput, MarkerSpec, fan, line_list, rgba


def test_selection_forwards_everything_but_the_excluded_or_only_the_listed():
    every = TopicSelection()
    assert every.wanted('/clock') and every.wanted('/robot_1/coalition')
    assert not every.wanted('/rosout') and not every.wanted('/parameter_events')
    listed = TopicSelection(topics=('/markers/sgcm', ''))
    assert listed.wanted('/markers/sgcm') and not listed.wanted('/clock')
    assert not TopicSelection(exclude=('/sim2/.*',)).wanted('/sim2/clock')


def test_schemas_are_the_recorders_definitions_also_of_workspace_types():
    book = SchemaBook()
    for type_name in ('visualization_msgs/msg/MarkerArray', 'coalition_interfaces/msg/AgentStatus',
                      'sgcm_interfaces/Guidance'):
        name, data = book.schema(type_name)
        full = name if '/msg/' in type_name else type_name.replace('/', '/msg/')
        assert name == full
        assert data.decode() == message_definition(build_typestore([full]), full)
    assert b'MSG: geometry_msgs/Point' in book.schema('visualization_msgs/msg/MarkerArray')[1]
    # A later type does not change what an earlier one got, and the book keeps its answers.
    assert book.schema('sgcm_interfaces/msg/Guidance') == book.schema('sgcm_interfaces/Guidance')
    with pytest.raises(UnknownMessageTypeError):
        book.schema('no_such_pkg/msg/Nothing')


def test_a_topic_is_subscribed_while_a_client_watches_it():
    channels = LiveChannels()
    channels.add('/markers/roles', 'visualization_msgs/msg/MarkerArray', object(), 7)
    channels.add('/clock', 'rosgraph_msgs/msg/Clock', object(), 8)
    assert channels.pending() == []                    # advertised, nobody watches: no ROS subscription
    channels.client_subscribed(1, 7)
    channels.client_subscribed(2, 7)
    channels.client_subscribed(1, 99)                  # an unknown channel is ignored
    [(change, entry)] = channels.pending()
    assert (change, entry.topic) == ('subscribe', '/markers/roles')
    entry.subscribed = True
    channels.client_unsubscribed(1, 7)
    assert channels.pending() == []                    # client 2 still watches
    channels.client_unsubscribed(2, 7)
    assert [(c, e.topic) for c, e in channels.pending()] == [('unsubscribe', '/markers/roles')]
    with pytest.raises(ValueError):
        channels.add('/clock', 'rosgraph_msgs/msg/Clock', object(), 9)
    assert [e.topic for e in channels.vanished(['/clock'])] == ['/markers/roles']
    channels.remove('/markers/roles')
    assert channels.topics() == {'/clock': 'rosgraph_msgs/msg/Clock'}


def test_client_changes_from_another_thread_are_all_counted():
    channels = LiveChannels()
    channels.add('/a', 'std_msgs/msg/String', object(), 1)

    def watch(client):
        for _ in range(200):
            channels.client_subscribed(client, 1)
            channels.client_unsubscribed(client, 1)
        channels.client_subscribed(client, 1)
    threads = [threading.Thread(target=watch, args=(c,)) for c in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert channels.advertised('/a').clients == {0, 1, 2, 3}


def test_settings_refuse_what_cannot_be_served():
    values = LIVE_VIEW_SETTINGS.validate({})
    assert (values['host'], values['port']) == ('127.0.0.1', 8765)
    assert LIVE_VIEW_SETTINGS.validate({'host': '0.0.0.0', 'port': 0})['port'] == 0
    for bad, field in (({'port': 70000}, 'port'), ({'host': 'my laptop'}, 'host'),
                       ({'exclude': ['(']}, 'exclude'), ({'discovery_period': 0.0}, 'discovery_period')):
        with pytest.raises(ConfigurationError, match=f'parameter {field}'):
            LIVE_VIEW_SETTINGS.validate(bad)
    assert host_problem('localhost') is None and host_problem('::1') is None
    assert 'ws://127.0.0.1:9000' in connect_hint('0.0.0.0', 9000)


def test_marker_specs_refuse_what_a_viewer_cannot_draw():
    MarkerSpec('a', 0, 'line_list', 'world', points=((0, 0, 0), (1, 0, 0)))
    for bad in (dict(kind='blob'), dict(frame=''), dict(points=((float('nan'), 0, 0),)),
                dict(points=((0, 0, 0),), colors=())):
        args = dict(ns='a', id=0, kind='sphere', frame='world', points=(), colors=())
        args.update(bad)
        if bad.get('colors') == () and args['points']:
            args['colors'] = ((1, 1, 1, 1), (1, 1, 1, 1))  # two colours for one point
        with pytest.raises(ValueError):
            MarkerSpec(**args)
    with pytest.raises(ValueError, match='qos'):
        MarkerInput('x', 'std_msgs/msg/String', 'fast', 'on_x')
    assert line_list([((0, 0, 0), (1, 1, 0)), ((0, 0, 0), (float('inf'), 0, 0))]) == ((0, 0, 0), (1, 1, 0))
    wedge = fan(2.0, 3.14159 / 2, segments=4)
    assert len(wedge) == 12 and max(abs(p[1]) for p in wedge) == pytest.approx(2.0 * 0.7071, abs=1e-3)
    assert fan(0.0, 1.0) == () and rgba((2.0, -1.0, 0.5), 0.3) == (1.0, 0.0, 0.5, 0.3)
    assert set(MARKER_SOURCES) == {'sgcm', 'roles', 'coalitions'}


def test_live_option_addresses_and_a_busy_port_refused_before_anything_starts(monkeypatch):
    import socket

    from collab_tools.orchestration import live
    monkeypatch.delenv(live.ENVIRONMENT, raising=False)
    assert live.from_environment() is None
    assert live.parse_address('') == live.LiveView('127.0.0.1', 8765)
    assert live.parse_address('0.0.0.0:9000') == live.LiveView('0.0.0.0', 9000)
    assert live.parse_address('9001') == live.LiveView('127.0.0.1', 9001)
    for bad, words in (('laptop:80', 'host'), ('127.0.0.1:0', 'port'), ('x', 'port')):
        with pytest.raises(ConfigurationError, match=f'--live: {words}'):
            live.parse_address(bad)
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(ConfigurationError, match=f'cannot serve on 127.0.0.1:{port}'):
            live.enable(f'127.0.0.1:{port}')
    assert live.from_environment() is None            # nothing was turned on
    free = live.enable(f'127.0.0.1:{port}')  # free again once closed
    assert live.from_environment() == free
    specs = free.specs()
    assert [(s.executable, s.required) for s in specs] == [('live_view', False), ('visualiser', False)]
    assert specs[0].parameters == [{'host': '127.0.0.1', 'port': port}]
