"""Dead and restarted teammates (issue 16 item 5), no ROS: the sessions and silence of
core.transport.liveness, and whole teams of life cycles on their reliable channels (lifecycle_team)
in which a robot is killed (it neither ticks, sends nor receives) and restarted (a new agent with a
new session): a helper releases a dead or restarted leader, a leader re-forms without a dead helper
-- during its search, its negotiation or after it committed -- and takes a restarted one back.

Without liveness (``liveness=False``: what the agents did before) a helper stays committed to the
dead leader's coalition for ever (the default hold time 0 = until released)."""
from __future__ import annotations

import itertools

import pytest

from coalition_agents.core.agent_state import AgentState
from coalition_agents.core.errors import ConfigError
from coalition_agents.core.settings import AgentSettings
from coalition_agents.core.transport.liveness import CURRENT, FIRST, RESTARTED, STALE, PeerLiveness
from collab_tools.core.errors import ConfigurationError
from lifecycle_team import Team, capability_text

LOCALIZER = ('gps', 'fiducial', 'laser')
BLIND = ('fiducial', 'laser')
COMMITTED, FAILED, SEARCHING = AgentState.COMMITTED, AgentState.FAILED, AgentState.SEARCHING


# --- sessions and silence -------------------------------------------------------------------------

def test_sessions_tell_a_restarted_teammate_apart_and_drop_its_earlier_self():
    live = PeerLiveness('a', 2.0, 0.5)
    assert live.heard('b', 0, 0.0) == CURRENT  # no session (a tool) while b's own is unknown: judges nothing
    assert live.heard('b', 11, 0.0) == FIRST
    assert live.heard('b', 11, 0.1) == CURRENT
    assert live.heard('b', 0, 0.2) == STALE  # no session once b's is known: out of session
    assert live.heard('b', 22, 0.3) == RESTARTED
    assert live.heard('b', 11, 0.4) == STALE  # a batch of the session it left
    assert live.heard('b', 22, 0.5) == CURRENT
    assert (live.sessions['b'], live.stats.restarts, live.stats.stale_batches) == (22, 1, 2)


def follow(live, start, end, watched, dt=0.1):
    """Check every dt from start to end: {time: (heartbeats, lost, back)} where something happened."""
    events = {}
    for step in range(int(round((end - start) / dt)) + 1):
        now = round(start + step * dt, 6)
        check = live.check(now, watched)
        for robot in check.heartbeats:
            live.sent(robot, now)
        if check.heartbeats or check.lost or check.back:
            events[now] = (check.heartbeats, check.lost, check.back)
    return events


def test_a_watched_teammate_silent_for_the_bound_is_presumed_dead_once_and_back_when_heard():
    live = PeerLiveness('a', 2.0, 0.5)
    live.heard('b', 1, 0.0)
    live.heard('c', 1, 0.0)  # never watched: never judged
    events = follow(live, 0.0, 1.9, {'b'})
    assert [t for t, (beats, _, _) in events.items() if beats] == [0.0, 0.5, 1.0, 1.5]  # heartbeats to b
    assert not any(lost for _, lost, _ in events.values())
    live.heard('b', 1, 1.0)
    events = follow(live, 2.0, 4.0, {'b'})
    assert [(t, lost) for t, (_, lost, _) in events.items() if lost] == [(3.0, (('b', pytest.approx(2.0)),))]
    assert live.presumed_dead() == {'b'} and live.stats.presumed_dead == 1  # reported once
    live.heard('b', 1, 4.05)
    assert live.check(4.1, {'b'}).back == ('b',) and live.presumed_dead() == set()


def test_silence_counts_from_the_start_of_the_watch_and_not_while_this_robot_stalled():
    live = PeerLiveness('a', 2.0, 0.5, stall_s=0.5)
    live.heard('b', 1, 0.0)
    assert follow(live, 10.0, 11.9, {'b'}) and live.presumed_dead() == set()  # watched since 10 s
    assert live.check(12.0, {'b'}).lost == (('b', pytest.approx(2.0)),)
    other = PeerLiveness('a', 2.0, 0.5, stall_s=0.5)
    other.heard('b', 1, 0.0)
    other.check(0.0, {'b'})
    assert other.check(5.0, {'b'}).lost == () and other.stats.stalls == 1  # 5 s without checking: not b's silence
    assert not any(lost for _, lost, _ in follow(other, 5.1, 6.9, {'b'}).values())
    assert other.check(7.0, {'b'}).lost == (('b', pytest.approx(2.0)),)


def test_nothing_is_presumed_with_a_zero_bound_and_bad_bounds_are_refused(files):
    live = PeerLiveness('a', 0.0, 0.5)
    live.check(0.0, {'b'})
    assert live.check(100.0, {'b'}).lost == ()
    with pytest.raises(ConfigError, match='heartbeat_s'):
        PeerLiveness('a', 2.0, 0.0)
    with pytest.raises(ConfigError, match='silence_s'):
        PeerLiveness('a', float('nan'), 1.0)
    values = {**files, 'capabilities': capability_text({'blind': BLIND}, {'a': 'blind'}), 'task': 'navigation'}
    with pytest.raises(ConfigurationError, match='parameter liveness_timeout: 1 s is below twice heartbeat_period'):
        AgentSettings.build({**values, 'liveness_timeout': 1.0, 'heartbeat_period': 0.6}, 'a')
    assert AgentSettings.build({**values, 'liveness_timeout': 0.0}, 'a').liveness().silence_s == 0.0


# --- teams: kill and restart ----------------------------------------------------------------------------

@pytest.fixture
def files(config_dir):
    return {'schemas_file': str(config_dir / 'schemas.yaml'), 'costs_file': str(config_dir / 'costs.yaml'),
            'tasks_file': str(config_dir / 'tasks.yaml')}


class LiveTeam(Team):
    """A Team whose robots can be killed and restarted, each with its session and PeerLiveness, as
    the agent channel runs them: every delivered message is a batch heard from its sender, heartbeats
    and the announcement at start are empty batches (``liveness=False``: nothing of it, as before)."""

    def __init__(self, *args, silence=2.0, heartbeat=0.5, liveness=True, **kwargs):
        self.silence, self.heartbeat, self.alive_checks = silence, heartbeat, liveness
        self.down: set[str] = set()
        self.sessions, self.liveness = {}, {}
        self._sessions = itertools.count(1)
        super().__init__(*args, **kwargs)

    def start(self, robot):
        super().start(robot)
        self.sessions[robot] = next(self._sessions)
        self.liveness[robot] = PeerLiveness(robot, self.silence if self.alive_checks else 0.0, self.heartbeat, 10.0)
        self.down.discard(robot)

    def kill(self, robot):
        self.down.add(robot)

    def _heard(self, receiver, sender):
        if not self.alive_checks:
            return True
        heard = self.liveness[receiver].heard(sender, self.sessions[sender], self.now)
        if heard == RESTARTED:
            self.lives[receiver].on_teammate_lost(sender, self.now, 'restarted', restarted=True)
        return heard != STALE

    def accepts(self, message):
        # A dead robot neither receives nor sends.
        if message.receiver in self.down or message.sender in self.down:
            return False
        return self._heard(message.receiver, message.sender)

    def running(self):
        return {robot: life for robot, life in self.lives.items() if robot not in self.down}

    def after_step(self, now, running):
        if self.alive_checks:
            for robot, life in running.items():
                self._follow(robot, life, now)

    def _follow(self, robot, life, now):
        channel = self.channels[robot]
        heard_by = []
        if getattr(channel, 'announced', None) is not None:
            channel.announced = None
            heard_by = [other for other in self.robots if other != robot]
        check = self.liveness[robot].check(now, life.watched_teammates())
        for other in [*heard_by, *check.heartbeats]:
            if other not in self.down:
                self._heard(other, robot)
        for other, silent in check.lost:
            life.on_teammate_lost(other, now, f'silent for {silent:.1f} s')
        for other in check.back:
            life.on_teammate_back(other, now)
        self.deliver()


LEADER, HELPER, SPARE = 'robot_l', 'robot_h', 'robot_s'


def team_of(files, spare=False, **options):
    """A blind leader that only its localising helper(s) can localise (each sees it)."""
    robots = {LEADER: 'blind', HELPER: 'localizer', **({SPARE: 'localizer'} if spare else {})}
    poses = {LEADER: (0.0, 0.0, 0.0), HELPER: (-1.0, 0.0, 0.0), SPARE: (-1.0, 0.8, 0.0)}
    return LiveTeam(files, capability_text({'localizer': LOCALIZER, 'blind': BLIND}, robots),
                    {robot: 'navigation' if robot == LEADER else 'none' for robot in robots},
                    {robot: poses[robot] for robot in robots}, {robot: [LEADER] for robot in robots if robot != LEADER},
                    search_time=3.0, settle_time=1.0, **options)


def formed(team, helpers=(HELPER,)):
    return lambda t: t.state(LEADER) is COMMITTED and set(t.lives[LEADER].held.own.members) - {LEADER} <= set(helpers) \
        and all(t.state(h) is COMMITTED for h in helpers)


def logs(team, robot):
    return '\n'.join(text for _, text in team.ports[robot].logs)


def test_a_helper_releases_a_dead_leader_and_the_restarted_leader_forms_again(files):
    team = team_of(files)
    first = team.run(0.1, 10.0, until=formed(team))
    assert team.state(LEADER) is COMMITTED, team.report(LEADER).detail
    team.kill(LEADER)
    released = team.run(first + 0.1, first + 5.0, until=lambda t: t.state(HELPER) is AgentState.IDLE)
    assert team.state(HELPER) is AgentState.IDLE and 2.0 <= released - first <= 2.3  # the bound, then released
    assert f'released from coalition {team.report(LEADER).coalition_id} (its leader silent for 2' in logs(team, HELPER)
    assert team.channels[HELPER].core.ledger.held(team.now) == ()
    team.start(LEADER)
    again = team.run(released + 0.1, released + 10.0, until=formed(team))
    assert team.state(LEADER) is COMMITTED and again - released <= first + 0.5


def test_a_restarted_leader_is_admitted_at_once_and_without_liveness_it_is_refused(files):
    for liveness in (True, False):
        team = team_of(files, liveness=liveness)
        first = team.run(0.1, 10.0, until=formed(team))
        old = team.report(LEADER).coalition_id
        team.kill(LEADER)
        team.start(LEADER)  # back before the helper could notice the silence: its session says so
        end = team.run(first + 0.1, first + 10.0, until=lambda t: t.state(LEADER) in (COMMITTED, FAILED))
        team.run(end + 0.1, end + 5.0)
        held = list(team.lives[HELPER].held.serving)
        if liveness:
            assert team.state(LEADER) is COMMITTED, team.report(LEADER).detail
            assert end - first <= first + 0.5
            assert 'its leader restarted' in logs(team, HELPER)
            assert held == [team.report(LEADER).coalition_id]
        else:  # issue 16 item 5: the helper holds the dead leader's coalition for ever (hold time 0)
            assert old in held and len(held) == 2


def test_a_leader_re_forms_without_a_helper_killed_after_committing(files):
    team = team_of(files, spare=True)
    first = team.run(0.1, 10.0, until=lambda t: t.state(LEADER) is COMMITTED)
    helper = next(robot for robot in team.lives[LEADER].held.own.members if robot != LEADER)
    spare = SPARE if helper == HELPER else HELPER
    team.kill(helper)
    end = team.run(first + 0.1, first + 12.0, until=formed(team, (spare,)))
    assert team.state(LEADER) is COMMITTED and team.lives[LEADER].held.own.members == (LEADER, spare)
    assert end - first <= 2.0 + 2 * first  # the bound, then at most the undisturbed time twice
    assert f're-forming (1/3) without {helper}' in logs(team, LEADER)
    assert team.report(LEADER).reforms == 1


def test_a_helper_killed_after_committing_and_restarted_is_taken_back(files):
    team = team_of(files)
    first = team.run(0.1, 10.0, until=formed(team))
    team.kill(HELPER)
    lost = team.run(first + 0.1, first + 5.0, until=lambda t: t.state(LEADER) is SEARCHING)
    assert 2.0 <= lost - first <= 2.3 and f'{HELPER} silent for 2' in logs(team, LEADER)
    team.start(HELPER)
    end = team.run(lost + 0.1, lost + 12.0, until=formed(team))
    assert team.state(LEADER) is COMMITTED, team.report(LEADER).detail
    assert end - lost <= 2 * first
    assert f'{HELPER} restarted; searching again' in logs(team, LEADER)


def test_a_helper_killed_during_the_search_is_skipped_or_taken_back_when_restarted(files):
    team = team_of(files, spare=True)
    team.run(0.1, 0.6)  # the requests are answered: both localizers offered
    team.kill(HELPER)
    end = team.run(0.7, 15.0, until=formed(team, (SPARE,)))
    assert team.lives[LEADER].held.own.members == (LEADER, SPARE), team.report(LEADER).detail
    alone = team_of(files)
    alone.run(0.1, 0.6)
    alone.kill(HELPER)
    alone.run(0.7, 4.5)  # the leader negotiates with the dead helper, finds it silent, searches without it
    assert 'presumed dead' in logs(alone, LEADER) or f'{HELPER}: silent' in logs(alone, LEADER), logs(alone, LEADER)
    alone.start(HELPER)
    again = alone.run(4.6, 15.0, until=formed(alone))
    assert alone.state(LEADER) is COMMITTED, alone.report(LEADER).detail
    assert again - 4.6 <= 2 * 3.5 and end <= 2 * 3.5 + 2.0


def test_the_bag_reader_times_a_restarted_leaders_last_search():
    from coalition_agents.experiments.coalition_bag import CoalitionRun, StatusRecord, leader_timeline
    status = lambda stamp, state, session, **more: StatusRecord(  # noqa: E731
        stamp, LEADER, state, 'navigation', more.get('cid', ''), LEADER if more.get('cid') else '',
        (LEADER, HELPER) if more.get('cid') else (), 17.5 if more.get('cid') else 0.0,
        search_started=more.get('start'), session=session)
    run = CoalitionRun(statuses=[status(1.0, SEARCHING, 7, start=1.0), status(2.5, COMMITTED, 7, cid='robot_l/1'),
                                 status(20.0, SEARCHING, 9, start=20.0), status(22.0, COMMITTED, 9, cid='robot_l/5')])
    timeline = leader_timeline(run, LEADER)
    assert (timeline.search_start, timeline.formed, timeline.coalition_id) == (20.0, 22.0, 'robot_l/5')
    assert len(run.last_session(LEADER)) == 2 and len(run.of(LEADER)) == 4


def test_a_helper_restarted_during_the_negotiation_is_asked_again(files):
    team = team_of(files)
    team.run(0.1, 1.0)  # found at 0.2 s, settled at 1.2 s: it negotiates with the dead helper
    team.kill(HELPER)
    negotiating = team.run(1.1, 1.5)
    assert team.state(LEADER) is AgentState.NEGOTIATING
    team.start(HELPER)  # back before its silence reached the bound
    end = team.run(negotiating + 0.1, negotiating + 10.0, until=formed(team))
    assert team.state(LEADER) is COMMITTED, team.report(LEADER).detail
    assert f'{HELPER} restarted during the negotiation; searching again' in logs(team, LEADER)
    assert end - negotiating <= 2 * 3.5
