"""SGCM survives a restart of each of its processes (issue 16 item 5): ``kill -9`` at a fixed point, restart.

* the leader, once her round 2 is announced: her new session is followed by the follower from its
  round 1 (his round ordering restarts; before sessions he ignored it as "lower or equal");
* the follower, once he has reported round 1: the restarted follower joins the leader's session
  under way (the round he missed ends by the leader's follower_timeout);
* the bridge, while the leader's arm carries a cube in round 2: her goal is given up (the restarted
  simulation's clock goes back; else server loss or the goal timeout, sgcm.arm_client) instead of
  waiting in ``executing``, and she plans from the table the new simulation shows (its scenario
  starts again from case_3).

Each time the task completes at the goal within the bound the issue sets: twice the undisturbed
time plus the restart (from the kill until the restarted node says it is up).
"""

import os
import time

import pytest
from bridge_interfaces.action import PickAndPlace
from sgcm_interfaces.msg import FollowerReport, Guidance

from bridge_helpers import bridge_spec
from restart_helpers import kill_9
from test_sgcm_nodes import FOLLOWER_NS, LEADER_NS, resume_once_heard, start_case

LEADER = f'{LEADER_NS}/leader_planner'
FOLLOWER = f'{FOLLOWER_NS}/follower_executor'
#: s (wall) case_3 takes undisturbed from unpausing to the goal: 8 s measured at load 2.6 (4 rounds);
#: 20 s allows for this machine's 2-3x noise. The bound after a kill is 2 x this + the restart.
UNDISTURBED_S = 20.0
#: The leader's follower_timeout (simulated s) for a round the restarted follower never heard.
FOLLOWER_TIMEOUT = 5.0
#: A Fast DDS participant lease of 4 s (default 20 s) for the bridge a test kills: the others notice a
#: killed participant only when its lease runs out, so its action server leaves their graph 4 s after
#: the kill instead of 20 s. Announced every 0.5 s, a live bridge is not dropped under load.
SHORT_LEASE_PROFILE = '''<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <participant profile_name="short_lease" is_default_profile="true">
      <rtps><builtin><discovery_config>
        <leaseDuration><sec>4</sec></leaseDuration>
        <leaseAnnouncement><nanosec>500000000</nanosec></leaseAnnouncement>
      </discovery_config></builtin></rtps>
    </participant>
  </profiles>
</dds>
'''


@pytest.fixture
def task_file(config_dir):
    return config_dir / 'sgcm' / 'task.yaml'


def wait_until(condition, what, session, timeout=120.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f'{what} within {timeout:.0f} s'
        session.check_alive()
        time.sleep(0.02)


class Watch:
    """The leader's guidance and the follower's reports as the test hears them."""

    def __init__(self, node):
        self.guidance, self.reports, self.feedback = [], [], []
        self.subscription = node.create_subscription(Guidance, '/sgcm/guidance', self.guidance.append, 50)
        node.create_subscription(FollowerReport, '/sgcm/follower_report', self.reports.append, 50)
        node.create_subscription(PickAndPlace.Impl.FeedbackMessage, '/leader_arm/pick_and_place/_action/feedback',
                                 self.feedback.append, 50)

    def rounds(self, session=None):
        return [g for g in self.guidance if not (g.task_complete or g.status)
                and (session is None or g.session == session)]

    def final(self):
        return next((g for g in self.guidance if g.task_complete or g.status), None)


def start(session, tmp_path, task_file, config_dir, bridge_env=None, **leader_params):
    watch = Watch(session.observer.node)
    start_case(session, tmp_path, task_file, config_dir, 'case_3', start_paused=True, bridge_env=bridge_env,
               leader_params={'arm_server_lost_after': 2.0, **leader_params},
               follower_params={'arm_server_lost_after': 2.0})
    session.wait_for_nodes([LEADER, FOLLOWER], 60.0)
    resume_once_heard(session, watch.subscription)
    return watch


#: What each node logs once it is up (the graph still lists a killed node until DDS notices).
READY = {'leader_arm/leader_planner': '; session 0x', 'follower_arm/follower_executor': ', follows /',
         'pybullet_bridge': 'running scenario'}


def restart(session, label, spec, killed_at):
    """Start ``spec`` again; the restart: seconds from the kill until the new node says it is up."""
    process = session.start(spec)
    wait_until(lambda: READY[label] in process.log_path.read_text(errors='replace'), f'{label} did not start',
               session, timeout=60.0)
    return time.monotonic() - killed_at


def finish(session, watch, killed_at, restart_s):
    """The task completes at the goal within 2 x UNDISTURBED_S + the restart; the seconds it took."""
    bound = 2 * UNDISTURBED_S + restart_s
    wait_until(watch.final, 'no task end', session, timeout=bound + 60.0)
    took = time.monotonic() - killed_at
    final = watch.final()
    assert final.task_complete and final.status == 'goal reached', final.status
    assert took <= bound, f'the task took {took:.1f} s after the kill; bound {bound:.1f} s (load {os.getloadavg()})'
    assert session.wait_for_exit('leader_arm/leader_planner', 30) == 0
    print(f'completed {took:.1f} s after the kill (restart {restart_s:.1f} s, bound {bound:.1f} s, '
          f'load {os.getloadavg()[0]:.1f})')
    return final


def log_of(session, label):
    return (session.run_dir / 'logs' / f'{label}.log').read_text()


def test_a_restarted_leader_is_followed_in_her_new_session(session, tmp_path, task_file, config_dir):
    watch = start(session, tmp_path, task_file, config_dir)
    wait_until(lambda: len(watch.rounds()) >= 2, 'the leader announced no round 2', session)
    old = watch.rounds()[0].session
    killed_at = time.monotonic()
    killed = kill_9(session, 'leader_arm/leader_planner')
    restart_s = restart(session, 'leader_arm/leader_planner', killed.spec, killed_at)
    final = finish(session, watch, killed_at, restart_s)

    new = final.session
    assert new not in (0, old)
    assert [g.round for g in watch.rounds(new)] == list(range(1, len(watch.rounds(new)) + 1))
    # He followed her new session from its round 1, and reported its rounds to it.
    answered = {r.round for r in watch.reports if r.leader_session == new and r.sender == FOLLOWER}
    assert {g.round for g in watch.rounds(new)} <= answered, answered
    assert session.wait_for_exit('follower_arm/follower_executor', 30) == 0
    follower = log_of(session, 'follower_arm/follower_executor')
    assert f"the leader's session changed ({old:#x} -> {new:#x}" in follower
    assert 'Traceback' not in follower


def test_a_restarted_follower_rejoins(session, tmp_path, task_file, config_dir):
    watch = start(session, tmp_path, task_file, config_dir, follower_timeout=FOLLOWER_TIMEOUT)
    wait_until(lambda: any(r.round == 1 for r in watch.reports), 'the follower reported no round 1', session)
    killed_at = time.monotonic()
    killed = kill_9(session, 'follower_arm/follower_executor')
    old = watch.reports[0].session
    restart_s = restart(session, 'follower_arm/follower_executor', killed.spec, killed_at)
    final = finish(session, watch, killed_at, restart_s)

    # The restarted follower (a new session of his own) reported rounds of her session after the kill.
    rejoined = [r for r in watch.reports if r.session not in (0, old) and r.leader_session == final.session]
    assert rejoined, [(r.session, r.round) for r in watch.reports]
    assert session.wait_for_exit('follower_arm/follower_executor', 30) == 0
    leader = log_of(session, 'leader_arm/leader_planner')
    assert "the follower's session changed" in leader and 'Traceback' not in leader


@pytest.mark.parametrize('restart_when', ['at once', 'once the goal is given up'])
def test_a_bridge_killed_during_an_arm_goal_is_not_waited_for(session, tmp_path, task_file, config_dir, restart_when):
    """Restarted at once, the new simulation's clock going back gives her goal up; restarted only after she
    gave it up, the action server's absence from the graph (arm_server_lost_after) did."""
    lease = tmp_path / 'short_lease.xml'
    lease.write_text(SHORT_LEASE_PROFILE)
    watch = start(session, tmp_path, task_file, config_dir, bridge_env={'FASTRTPS_DEFAULT_PROFILES_FILE': str(lease)})
    # The fixed point: her arm is carrying in round 2 (feedback after round 1's guidance).
    wait_until(lambda: len(watch.rounds()) >= 1, 'the leader announced no round 1', session)
    seen = len(watch.feedback)
    wait_until(lambda: len(watch.feedback) > seen and watch.feedback[-1].feedback.phase == 'transport',
               'no transport feedback in round 2', session)
    killed_at = time.monotonic()
    kill_9(session, 'pybullet_bridge')
    leader_log = session.run_dir / 'logs' / 'leader_arm' / 'leader_planner.log'
    if restart_when != 'at once':
        wait_until(lambda: 'pick_and_place goal given up' in leader_log.read_text(), 'the goal was not given up',
                   session, timeout=90.0)
        assert 'left the graph' in leader_log.read_text()
    scenario = tmp_path / 'scenario.yaml'
    restart_s = restart(session, 'pybullet_bridge', bridge_spec(scenario, ground_truth_rate=5.0, start_paused=False),
                        killed_at)
    finish(session, watch, killed_at, restart_s)

    leader = log_of(session, 'leader_arm/leader_planner')
    assert 'pick_and_place goal given up' in leader and 'leader move not done: given up' in leader
    assert 'Traceback' not in leader
    assert session.wait_for_exit('follower_arm/follower_executor', 30) == 0
