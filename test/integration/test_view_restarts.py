"""The view nodes survive a restart (issue 16 item 5), started by a session as ``--live`` starts them.

* The visualiser is killed with SIGKILL once it has drawn a role, the goal moves, and the visualiser is
  started again: it draws the new goal, in the team's colour, from the latched team and assignment it
  hears plus the next process role. A Foxglove client that stays connected through the kill receives the
  restarted visualiser's markers (on its channel, or on the channel advertised again if the live view
  saw the topic vanish: it subscribes again, as the Foxglove app does).
* The live view is killed with SIGKILL while a client watches and started again on the same port: a new
  client connects and receives the markers; the visualiser never noticed.

Bound: each restarted node draws or forwards within RESTART_BOUND_S of the kill (start-up of a node on
this machine is 2-5 s; the bound allows for 3x noise).
"""

import time

import pytest
from rclpy.serialization import deserialize_message
from role_interfaces.msg import ProcessRole, RoleAssignment, Team, TeamMember
from visualization_msgs.msg import MarkerArray

from foxglove_client import FoxgloveClient
from fuzz_helpers import LATCHED, publish_all
from restart_helpers import kill_9
from test_fuzz_view_nodes import assignment, markers_with, process_role

ROBOT = 'robot_view'
RESTART_BOUND_S = 30.0


@pytest.fixture
def session(live_session):
    return live_session


class RoleInputs:
    """The role engine's latched team and assignment, published once each by one publisher per topic
    (a restarted visualiser gets the newest), and the players' process roles."""

    def __init__(self, session, goal):
        node = session.observer.node
        self.team = publish_all(node, Team, '/roles/team', [Team(members=[
            TeamMember(name=ROBOT, robot_type='burger', radius=0.1, color=[1.0, 0.0, 0.0])])], qos=LATCHED)
        self.assignment = publish_all(node, RoleAssignment, '/roles/assignment', [self._assignment(goal)],
                                      qos=LATCHED)
        self.channel = publish_all(node, ProcessRole, '/roles/channel', [process_role()])

    @staticmethod
    def _assignment(goal):
        return assignment(goal_x=(goal[0],), goal_y=(goal[1],))

    def move_goal(self, goal):
        self.assignment.publish(self._assignment(goal))


def goal_of(array):
    return next(((m.pose.position.x, m.pose.position.y, m.color.r, m.color.g, m.color.b)
                 for m in array.markers if m.ns == 'goals'), None)


def roles_markers(session, inputs, timeout):
    """Publish a process role every second until the visualiser's roles markers hold goal and 'now'."""
    deadline = time.monotonic() + timeout
    while True:
        inputs.channel.publish(process_role())
        try:
            return markers_with(session, '/markers/roles', 'roles', f'{ROBOT}: diamond_0', also=('goals', 'now'),
                                timeout=1.0)
        except TimeoutError:
            if time.monotonic() > deadline:
                raise


def forwarded_goals(client):
    return [goal_of(deserialize_message(p, MarkerArray)) for p in client.payloads('/markers/roles')]


def resubscribed(client, topic='/markers/roles') -> bool:
    """Subscribe again to ``topic`` when its channel was advertised anew; always True (for pump_until)."""
    channel = client.channels.get(topic)
    if channel is not None and channel['id'] not in client.subscribed_channels:
        client.subscribe(topic)
        client.subscribed_channels.add(channel['id'])
    return True


def test_a_killed_visualiser_draws_again_and_a_connected_client_gets_its_markers(session, port):
    inputs = RoleInputs(session, goal=(1.0, 2.0))
    assert goal_of(roles_markers(session, inputs, 20.0)) == (1.0, 2.0, 1.0, 0.0, 0.0)
    with FoxgloveClient(f'ws://127.0.0.1:{port}', timeout=20.0) as client:
        assert client.pump_until(lambda: '/markers/roles' in client.channels, 20.0), sorted(client.channels)
        client.subscribed_channels = set()
        resubscribed(client)
        assert client.pump_until(lambda: (1.0, 2.0, 1.0, 0.0, 0.0) in forwarded_goals(client), 20.0)

        killed_at = time.monotonic()
        spec = kill_9(session, 'visualiser').spec
        # A new goal while no visualiser runs: only the restarted one can draw it.
        inputs.move_goal((3.0, 1.0))
        restarted = session.start(spec)
        # The restarted visualiser hears the latched team and assignment; the next process role completes
        # the picture.
        assert goal_of(roles_markers(session, inputs, RESTART_BOUND_S)) == (3.0, 1.0, 1.0, 0.0, 0.0)
        # The connected client receives it: on the channel it watches (the live view's subscription
        # matches the new publisher), or, if the live view saw the topic vanish meanwhile, on the channel
        # advertised again, to which it subscribes as the Foxglove app does.
        new_goal = (3.0, 1.0, 1.0, 0.0, 0.0)
        assert client.pump_until(lambda: resubscribed(client) and new_goal in forwarded_goals(client),
                                 RESTART_BOUND_S), 'the connected client received nothing from the restarted visualiser'
        took = time.monotonic() - killed_at
    assert took <= RESTART_BOUND_S, f'drawn and forwarded again {took:.1f} s after the kill'
    assert restarted.poll() is None and session.nodes['live_view'].poll() is None
    assert 'Traceback' not in restarted.log_path.read_text()
    print(f'visualiser restart: drawn and forwarded again {took:.1f} s after the kill')


def test_a_killed_live_view_serves_new_clients_on_its_port(session, port):
    inputs = RoleInputs(session, goal=(-1.0, 0.5))
    assert goal_of(roles_markers(session, inputs, 20.0))[:2] == (-1.0, 0.5)
    visualiser = session.nodes['visualiser']
    with FoxgloveClient(f'ws://127.0.0.1:{port}', timeout=20.0) as client:
        assert client.pump_until(lambda: '/markers/roles' in client.channels, 20.0), sorted(client.channels)
        client.subscribe('/markers/roles')
        assert client.pump_until(lambda: (-1.0, 0.5, 1.0, 0.0, 0.0) in forwarded_goals(client), 20.0)
        killed_at = time.monotonic()
        spec = kill_9(session, 'live_view').spec
    restarted = session.start(spec)
    # The same port at once: the SDK's server reuses the address of the killed one.
    with FoxgloveClient(f'ws://127.0.0.1:{port}', timeout=RESTART_BOUND_S) as client:
        assert client.pump_until(lambda: '/markers/roles' in client.channels, RESTART_BOUND_S), \
            sorted(client.channels)
        client.subscribe('/markers/roles')
        # The markers are latched: the restarted live view's subscription gets the newest array.
        assert client.pump_until(lambda: (-1.0, 0.5, 1.0, 0.0, 0.0) in forwarded_goals(client), RESTART_BOUND_S), \
            'the new client received no markers from the restarted live view'
        took = time.monotonic() - killed_at
    assert took <= RESTART_BOUND_S, f'served again {took:.1f} s after the kill'
    assert visualiser.poll() is None and restarted.poll() is None
    assert 'Traceback' not in restarted.log_path.read_text()
    print(f'live view restart: served again {took:.1f} s after the kill')
