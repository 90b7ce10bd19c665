"""Three schema_agent processes and the bridge: the robot without localisation forms its
least-cost coalition with the GPS robot its fiducial sees (IQ-ASyMTRe, Algorithm 2); during
execution the helper streams what it committed to, and the leader re-forms (or reports failed)
when its helper stops.

The expectation is computed with the core: what each robot's sensors retrieve in the scenario's
geometry (fields of view and ranges from the scenario file) goes through the node's own
conversion (LiveSensing) into the in-process CoalitionSearch.
"""

import math
import re
import time
from dataclasses import dataclass

import pytest
import yaml

from collab_tools.orchestration.node_process import NodeSpec
from bridge_helpers import body_pose, bridge_spec
from coalition_interfaces.msg import AgentMessage, AgentMessageBatch, AgentStatus, Information, NamedValue
from coalition_agents.core import CoalitionSearch, StaticSensing, load_capability_file, load_costs, load_library, load_tasks
from coalition_agents.core.live_sensing import LiveSensing
from coalition_agents.core.transport.link_model import LinkModel

LEADER, HELPER, BYSTANDER = 'robot_blind', 'robot_helper', 'robot_bystander'
STATUS = 'coalition_interfaces/msg/AgentStatus'


@dataclass
class AgentSpec(NodeSpec):
    """A schema_agent in its robot's namespace (/<robot>/schema_agent). Its session label names the
    robot too: every agent's node name is schema_agent, and a session's labels must be unique."""

    @property
    def label(self) -> str:
        return f"{self.namespace.strip('/')}.{self.name}"


def agent_spec(robot: str, params: dict, **options) -> AgentSpec:
    return AgentSpec('coalition_agents', 'schema_agent', name='schema_agent', namespace=f'/{robot}',
                     parameters=[params], **options)


@pytest.fixture
def files(config_dir):
    coalitions = config_dir / 'coalitions'
    return {'capability_file': str(coalitions / 'capabilities' / 'coalition_three_robots.yaml'),
            'schemas_file': str(coalitions / 'schemas.yaml'), 'costs_file': str(coalitions / 'costs.yaml'),
            'tasks_file': str(coalitions / 'tasks.yaml')}


def sees(observer, other, fov_deg, range_m):
    (x, y, yaw), (ox, oy, _) = observer, other
    bearing = math.degrees(math.atan2(oy - y, ox - x) - yaw)
    bearing = (bearing + 180.0) % 360.0 - 180.0
    return math.hypot(ox - x, oy - y) <= range_m and abs(bearing) <= fov_deg / 2.0


def expected_best(files, scenario_path):
    """The least-cost coalition of the leader computed by the core from the scenario geometry."""
    library = load_library(files['schemas_file'])
    team = dict(load_capability_file(files['capability_file'], library).robots)
    scenario = yaml.safe_load(open(scenario_path))
    robots = {robot['name']: robot for robot in scenario['mobile_robots']}
    table = {}
    for name, capabilities in team.items():
        live = LiveSensing(name, capabilities, team, library.catalog.objects)
        for sensor in capabilities.sensor_names:
            seen = []
            if sensor == 'fiducial':
                view = robots[name]['sensors']['fiducial']
                seen = [other for other in team if other != name
                        and sees(robots[name]['pose'], robots[other]['pose'], view['fov_deg'], view['range'])]
            table.setdefault(name, {})[sensor] = [str(i) for i in live.report(sensor, 0.0, seen)]
    search = CoalitionSearch(library, load_costs(files['costs_file']),
                             load_tasks(files['tasks_file'], library)['navigation'], team,
                             StaticSensing.from_text(table, library, list(team)))
    return search.run([LEADER])[LEADER].best


def longest_loss_streak(seed, loss, batches=400):
    """The most batches in a row the agent's seeded link model drops among its first ``batches``
    (the agents' link preset, ``paper_fig9``, with ``loss``). The draws are fixed by the seed but
    which batches meet a streak depends on the run's timing, so a test's seeds must keep every
    streak within what its search time absorbs."""
    link = LinkModel.preset('paper_fig9', loss_probability=loss, seed=seed)
    longest = run = 0
    for _ in range(batches):
        run = run + 1 if not link.sample()[0] else 0
        longest = max(longest, run)
    return longest


#: link seeds of the three-robot team: at 20 % loss, at most 3 batches in a row lost (seed 100 lost 4)
TEAM_SEEDS = (101, 102, 103)


def start_team(session, files, config_dir, loss, extra=None):
    """The bridge and the three agents (``extra``: more parameters for every agent)."""
    scenario = config_dir / 'scenarios' / 'coalition_three_robots.yaml'
    session.start(bridge_spec(scenario, real_time_factor=1.0, start_paused=False, publish_camera=False,
                              ground_truth_rate=1.0))
    processes = {}
    for index, robot in enumerate((LEADER, HELPER, BYSTANDER)):
        params = {**files, 'task': 'navigation' if robot == LEADER else 'none',
                  'team_task': 'navigation', 'loss_probability': loss, 'seed': TEAM_SEEDS[index], 'search_time': 3.0,
                  **(extra or {})}
        if robot == LEADER:  # the team as a parameter, no capability file (as on a machine without it)
            params.pop('capability_file')
            params['capabilities'] = open(files['capability_file']).read()
        processes[robot] = session.start(agent_spec(robot, params))
    return scenario, processes


@pytest.mark.parametrize('loss', [0.0, 0.2])
def test_robot_without_localisation_forms_its_least_cost_coalition(session, files, config_dir, loss):
    wall_start = time.monotonic()
    scenario, agents = start_team(session, files, config_dir, loss)
    expected = expected_best(files, scenario)
    assert expected is not None
    # A malformed message on the channel (unknown information type) is dropped with a message.
    publisher = session.observer.node.create_publisher(AgentMessage, '/coalition/channel', 10)
    deadline = time.monotonic() + 30.0
    while publisher.get_subscription_count() < 3:  # every agent, not just the first to match
        assert time.monotonic() < deadline, 'the agents did not all subscribe to /coalition/channel'
        time.sleep(0.05)
    publisher.publish(AgentMessage(message_id=1, sender=BYSTANDER, kind=AgentMessage.REQUEST,
                                   label=Information(type='F_Q', referents=['X'])))
    leader = session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=45.0,
                                      predicate=lambda m: m.state in (AgentStatus.COMMITTED, AgentStatus.FAILED))
    wall = time.monotonic() - wall_start
    assert leader.state == AgentStatus.COMMITTED, leader.detail
    assert tuple(leader.members) == expected.members == (LEADER, HELPER)
    assert leader.cost == pytest.approx(expected.cost)
    assert leader.leader == LEADER
    helper = session.wait_for_message(f'/{HELPER}/coalition', STATUS, latched=True, timeout=10.0,
                                      predicate=lambda m: m.state == AgentStatus.COMMITTED)
    assert (helper.coalition_id, helper.leader, tuple(helper.members)) == \
        (leader.coalition_id, LEADER, tuple(leader.members))
    bystander = session.wait_for_message(f'/{BYSTANDER}/coalition', STATUS, latched=True, timeout=10.0)
    assert bystander.state != AgentStatus.COMMITTED and bystander.coalition_id == ''
    # Nobody held two commitments: each agent logs every commitment it took.
    for robot in (LEADER, HELPER, BYSTANDER):
        log = agents[robot].log_path.read_text()
        committed = re.findall(r'committed to coalition (\S+)|coalition (\S+) established', log)
        assert len(committed) <= 1, f'{robot} committed twice: {committed}'
    leader_log = agents[LEADER].log_path
    # The presence check saw every teammate's agent (/<teammate>/schema_agent publishing
    # /<teammate>/coalition and reading its inbox) before team_wait ran out.
    assert 'starting anyway' not in leader_log.read_text()
    deadline = time.monotonic() + 10.0  # the log is written by another process
    while 'dropped a malformed message on /coalition/channel' not in leader_log.read_text():
        assert time.monotonic() < deadline, 'the malformed message was not reported by the leader'
        time.sleep(0.1)
    started, formed = (t.sec + t.nanosec * 1e-9 for t in (leader.search_started, leader.coalition_formed))
    assert 0 < started <= formed
    print(f'\nloss {loss}: coalition {leader.coalition_id} cost {leader.cost:g} formed after '
          f'{formed - started:.3f} sim s (search_time 3 s), {wall:.1f} wall s from start; '
          f'retries {leader.retries}, dropped {leader.dropped}')


# --- execution: streamed information, re-forming ---------------------------------------------------

NAV_LEADER, SPARE_A, SPARE_B = 'pusher_r2', 'localizer_l1', 'localizer_l2'


def boxpush_files(config_dir):
    coalitions = config_dir / 'coalitions'
    return {'capability_file': str(coalitions / 'capabilities' / 'box_pushing_team.yaml'),
            'schemas_file': str(coalitions / 'schemas.yaml'), 'costs_file': str(coalitions / 'costs.yaml'),
            'tasks_file': str(coalitions / 'tasks.yaml')}


#: link seeds of the navigation team: at 20 % loss, at most 3 batches in a row lost. Seed 202 (the
#: spare localizer_l2, formerly) dropped 5 in a row (its batches 19-23): when the re-forming search
#: met that streak -- whether it does depends on how many batches the spare sent before, i.e. on
#: timing -- the spare's offers or its COMMIT_ACCEPT waited 0.2 + 0.4 + 0.8 + 1.6 + 3.2 s for the
#: back-off, longer than the search time, and the leader reported FAILED (about 1 run in 6).
NAV_SEEDS = (200, 201, 203)


def test_the_link_seeds_keep_loss_streaks_within_the_tests_budget():
    """The teams' seeded links never drop more than 3 batches in a row at 20 % loss (the budget
    the search times are set for; see start_navigation_team)."""
    streaks = {seed: longest_loss_streak(seed, 0.2) for seed in TEAM_SEEDS + NAV_SEEDS}
    assert max(streaks.values()) <= 3, streaks
    assert longest_loss_streak(202, 0.2) == 5 and longest_loss_streak(100, 0.2) == 4  # the seeds they replaced


def start_navigation_team(session, config_dir, loss):
    """The navigation part of the box-pushing scenario: pusher_r2 cannot localise; localizer_l1 and
    localizer_l2 both see it (it sees neither). The box-pushing robots' agents are not started.
    Search time 6 s: at 20 % loss per batch, three lost batches in a row (the most the seeds in
    :data:`NAV_SEEDS` ever draw; the streaks land anywhere, depending on timing) delay an answer by
    the retry back-off, 0.2 + 0.4 + 0.8 + 1.6 s = 3 s; the leader still negotiates as soon as its
    coalition has settled."""
    session.start(bridge_spec(config_dir / 'scenarios' / 'coalition_boxpush.yaml', real_time_factor=1.0,
                              start_paused=False, publish_camera=False, ground_truth_rate=5.0))
    processes = {}
    for index, robot in enumerate((NAV_LEADER, SPARE_A, SPARE_B)):
        params = {**boxpush_files(config_dir), 'task': 'navigation' if robot == NAV_LEADER else 'none',
                  'team_task': 'navigation', 'loss_probability': loss, 'seed': NAV_SEEDS[index], 'search_time': 6.0,
                  'team_wait': 3.0, 'reform_timeout': 1.5, 'stream_timeout': 1.0, 'goal_position': [1.0, -3.0]}
        processes[robot] = session.start(agent_spec(robot, params))
    return processes


@pytest.mark.parametrize('loss', [0.0, 0.2])
def test_helper_streams_the_leader_position_and_the_leader_re_forms_when_it_stops(session, config_dir, loss):
    agents = start_navigation_team(session, config_dir, loss)
    first = session.wait_for_message(f'/{NAV_LEADER}/coalition', STATUS, latched=True, timeout=60.0,
                                     predicate=lambda m: m.state in (AgentStatus.COMMITTED, AgentStatus.FAILED))
    assert first.state == AgentStatus.COMMITTED, first.detail
    assert len(first.members) == 2 and first.members[0] == NAV_LEADER
    helper = first.members[1]
    first_id = first.coalition_id
    spare = SPARE_B if helper == SPARE_A else SPARE_A
    # The helper streams what it committed to: its GPS pose F_G(helper) and its fiducial's view of
    # the leader F_R(pusher_r2, helper); composed (Table I), they put the leader where it truly is.
    def streamed(label, referents):
        # The batch topic carries every agent's batches, one per sender, recipient and processing
        # step, their messages as columns (message_rows of batch_columns; kind 8 = INFORMATION).
        def values(b):
            if b.sender != helper or b.recipient != NAV_LEADER:
                return None
            info = value = 0
            for index, kind in enumerate(b.kinds):
                count, n_values = b.information_counts[index], b.value_counts[index]
                first = sum(b.referent_counts[:info])
                entry = (b.information_types[info], list(b.referents[first:first + b.referent_counts[info]])) \
                    if count else None
                if kind == 8 and entry == (label, referents) and b.coalition_ids[index] == first_id:
                    return dict(zip(b.value_names[value:value + n_values], b.values[value:value + n_values]))
                info, value = info + count, value + n_values
            return None
        bundle = session.wait_for_message('/coalition/bundles', 'coalition_interfaces/msg/AgentMessageBundle',
                                          timeout=20.0, predicate=lambda m: any(values(b) is not None for b in m.batches))
        return next(values(b) for b in bundle.batches if values(b) is not None)

    pose, seen = streamed('F_G', [helper]), streamed('F_R', [NAV_LEADER, helper])
    c, s_ = math.cos(pose['yaw']), math.sin(pose['yaw'])
    x, y, _ = body_pose(session, NAV_LEADER)
    assert (pose['x'] + c * seen['x'] - s_ * seen['y'], pose['y'] + s_ * seen['x'] + c * seen['y']) == \
        pytest.approx((x, y), abs=0.05)
    # Streamed values are checked like every message: a malformed one is dropped with a message.
    publisher = session.observer.node.create_publisher(AgentMessage, '/coalition/channel', 10)
    deadline = time.monotonic() + 10.0
    while publisher.get_subscription_count() < 2:  # the leader and the spare (the helper too)
        assert time.monotonic() < deadline, 'the agents are not on /coalition/channel'
        time.sleep(0.05)
    publisher.publish(AgentMessage(message_id=7, sender=helper, receiver=NAV_LEADER, kind=8,
                                   instance=Information(type='F_G', referents=[helper]),
                                   coalition_id=first.coalition_id,
                                   values=[NamedValue(name='x', value=math.nan), NamedValue(name='y', value=0.0)]))
    leader_log = agents[NAV_LEADER].log_path
    deadline = time.monotonic() + 10.0
    while 'message.values.x: must be a finite number' not in leader_log.read_text():
        assert time.monotonic() < deadline, 'the malformed information message was not reported'
        time.sleep(0.1)
    # The same inside a batch on the batch topic: that message is dropped with a message naming
    # it, and a batch whose columns disagree is dropped whole; the leader keeps going.
    batches = session.observer.node.create_publisher(AgentMessageBatch, '/coalition/batches', 10)
    while batches.get_subscription_count() < 2:
        assert time.monotonic() < deadline + 10.0, 'the agents are not on /coalition/batches'
        time.sleep(0.05)
    bad_value = dict(sender=helper, recipient=NAV_LEADER, sequence=10 ** 9, kinds=[8], message_ids=[8],
                     conversation_ids=[0], in_reply_to=[0], costs=[0.0], hold_seconds=[0.0],
                     coalition_ids=[first.coalition_id], reasons=[''], information_counts=[1], chain_lengths=[0],
                     member_counts=[0], value_counts=[2], information_types=['F_G'], referent_counts=[1],
                     referents=[helper], value_names=['x', 'y'], values=[math.inf, 0.0])
    batches.publish(AgentMessageBatch(**bad_value))
    batches.publish(AgentMessageBatch(**{**bad_value, 'sequence': 10 ** 9 + 1, 'costs': []}))
    deadline = time.monotonic() + 10.0
    while not all(text in leader_log.read_text() for text in (
            'batch.messages[0].values.x: must be a finite number', 'batch.costs: 0 entries for 1 messages')):
        assert time.monotonic() < deadline, 'the malformed batch contents were not reported'
        time.sleep(0.1)
    # The helper stops: its stream goes stale, the leader releases the coalition and re-forms it
    # with the spare GPS robot that also sees it.
    session.stop(agents[helper].name)
    second = session.wait_for_message(
        f'/{NAV_LEADER}/coalition', STATUS, latched=True, timeout=60.0,
        predicate=lambda m: m.state in (AgentStatus.COMMITTED, AgentStatus.FAILED) and m.coalition_id != first.coalition_id)
    assert second.state == AgentStatus.COMMITTED, second.detail
    assert tuple(second.members) == (NAV_LEADER, spare)
    spare_status = session.wait_for_message(f'/{spare}/coalition', STATUS, latched=True, timeout=10.0,
                                            predicate=lambda m: m.state == AgentStatus.COMMITTED)
    assert spare_status.coalition_id == second.coalition_id
    log = leader_log.read_text()
    assert f're-forming (1/3) without {helper}' in log
    assert 'releasing it' in log
    # The spare took exactly one commitment (never two at a time).
    spare_log = agents[spare].log_path.read_text()
    assert len(re.findall(r'committed to coalition (\S+)', spare_log)) == 1


def test_the_leader_reports_failed_when_its_only_helper_stops(session, files, config_dir):
    scenario = config_dir / 'scenarios' / 'coalition_three_robots.yaml'
    session.start(bridge_spec(scenario, real_time_factor=1.0, start_paused=False, publish_camera=False,
                              ground_truth_rate=1.0))
    agents = {}
    for index, robot in enumerate((LEADER, HELPER, BYSTANDER)):
        params = {**files, 'task': 'navigation' if robot == LEADER else 'none',
                  'team_task': 'navigation', 'seed': 300 + index, 'search_time': 3.0, 'reform_timeout': 1.0,
                  'max_reforms': 1}
        agents[robot] = session.start(agent_spec(robot, params))
    first = session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=45.0,
                                     predicate=lambda m: m.state in (AgentStatus.COMMITTED, AgentStatus.FAILED))
    assert first.state == AgentStatus.COMMITTED and tuple(first.members) == (LEADER, HELPER), first.detail
    session.stop(agents[HELPER].name)
    # Nobody else can localise the leader (the bystander is seen by nobody): the re-formed search
    # finds nothing and the leader says so.
    final = session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=45.0,
                                     predicate=lambda m: m.state == AgentStatus.FAILED)
    assert 'no executable coalition could be set up' in final.detail
    assert final.coalition_id == ''


# --- several leaders in one team: capability sharing ------------------------------------------------

def test_a_column_in_which_every_robot_but_the_front_one_navigates(session, config_dir, tmp_path):
    """Fig. 9's column of four on the bridge (each robot sees only the robot ahead, robot_1 alone
    localises), but robot_2, robot_3 and robot_4 each run the navigation task: every coalition
    forms, the front robot serves three coalitions and robot_2 two besides its own (the same
    readings, streamed to every leader), and the conflict check reports sharing, not conflict."""
    from collab_tools.orchestration.node_process import NodeSpec as Spec
    from coalition_agents.core.sim_scenarios import (
        COLUMN_TYPES, SensorSettings, agent_parameter_file, bridge_scenario, capability_file, capability_text,
        column_placements,
    )
    from coalition_agents.experiments.coalition_bag import CoalitionRun, commitment_check, status_record
    placements = column_placements(4, 1.0)
    robots = [p.robot for p in placements]
    team = capability_file(placements, COLUMN_TYPES)
    scenario = tmp_path / 'column.yaml'
    scenario.write_text(yaml.safe_dump(bridge_scenario('leaders_column', placements, team['robot_types'],
                                                       SensorSettings(fiducial_fov_deg=60.0, fiducial_range_m=1.5))))
    session.start(bridge_spec(scenario, real_time_factor=1.0, start_paused=False, publish_camera=False,
                              ground_truth_rate=1.0))
    coalitions = config_dir / 'coalitions'
    common = {'capabilities': capability_text(team), 'schemas_file': str(coalitions / 'schemas.yaml'),
              'costs_file': str(coalitions / 'costs.yaml'), 'tasks_file': str(coalitions / 'tasks.yaml'),
              'task': 'none', 'team_task': 'navigation', 'search_time': 6.0, 'settle_time': 1.0, 'seed': 13}
    agents = tmp_path / 'agents.yaml'
    agents.write_text(yaml.safe_dump(agent_parameter_file(common, {r: {'task': 'navigation'} for r in robots[1:]})))
    session.start(Spec('coalition_agents', 'schema_agent_host', name='column_host',
                       parameters=[{'robots': robots, 'agent_parameters': str(agents)}]))
    final = {}
    for robot in robots[1:]:
        final[robot] = session.wait_for_message(
            f'/{robot}/coalition', STATUS, latched=True, timeout=90.0,
            predicate=lambda m: m.state in (AgentStatus.COMMITTED, AgentStatus.FAILED))
    for index, robot in enumerate(robots[1:], start=2):
        assert final[robot].state == AgentStatus.COMMITTED, final[robot].detail
        assert sorted(final[robot].members) == robots[:index] and final[robot].leader == robot
    own = {robot: final[robot].coalition_id for robot in robots[1:]}
    held = {'robot_1': 3, 'robot_2': 3, 'robot_3': 2, 'robot_4': 1}
    latest = [session.wait_for_message(f'/{robot}/coalition', STATUS, latched=True, timeout=15.0,
                                       predicate=lambda m, n=held[robot]: len(m.commitments) == n)
              for robot in robots]
    assert {c.coalition_id for c in latest[0].commitments} == set(own.values())
    assert latest[0].state == AgentStatus.COMMITTED and latest[1].state == AgentStatus.COMMITTED
    assert [c.coalition_id for c in latest[1].commitments][0] == own['robot_2']
    assert any(use.startswith('sensor:gps:') for c in latest[0].commitments for use in c.uses)
    check = commitment_check(CoalitionRun(statuses=[status_record(m) for m in latest]))
    assert check['conflicting'] == {} and check['robots_serving_several'] == 3
    assert sorted(check['shared']) == ['robot_1', 'robot_2', 'robot_3']
