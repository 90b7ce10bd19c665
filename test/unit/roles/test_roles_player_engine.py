"""The nodes' behaviours as pure classes: core.player.RolePlayer and core.engine.RoleEngine, driven with
typed events and a recording port (no ROS)."""
from pathlib import Path

import numpy as np
import pytest

from role_engine.core.conflict import SharedRole
from role_engine.core.engine import CameraView, EnginePhase, RoleEngine
from role_engine.core.environment import Environment, RobotType
from role_engine.core.formation_task import load_formation_task
from role_engine.core.initial_paths import straight_line_trajectory
from role_engine.core.node_settings import engine_settings_file
from role_engine.core.player import PlayerState, RolePlayer, RoundAssignment
from role_engine.core.tuning import EngineTuning, PlayerTuning

SETTINGS = Path(__file__).resolve().parents[3] / 'config' / 'roles' / 'formation_demo.yaml'
BURGER = RobotType('turtlebot3_burger', 0.105, max_linear_velocity=0.22, max_angular_velocity=2.84)


class Recorder:
    """A port of either behaviour that keeps what it was asked to do."""

    def __init__(self, robot_env=None):
        self.commands, self.published, self.rounds, self.lines = [], [], [], []
        self.robot_env = robot_env
        self.ended = 0

    def command(self, linear, angular):
        self.commands.append((linear, angular))

    def publish_role(self, published):
        self.published.append(published)

    def round_environment(self, round_):
        return self.robot_env

    def publish_round(self, outcome):
        self.rounds.append(outcome)

    def log(self, level, text, throttle=0.0):
        self.lines.append((level, text))

    def task_ended(self):
        self.ended += 1


def open_environment():
    return Environment(np.zeros((100, 100), dtype=bool), 0.05, (-2.5, -2.5))


def a_role(name, start, goal, start_time=2.0, total_time=10.0):
    return SharedRole(name, straight_line_trajectory(start, goal, total_time, 10), total_time, 0.105, start_time)


@pytest.fixture
def player():
    port = Recorder(open_environment().for_robot(BURGER))
    tuning = PlayerTuning.from_task(load_formation_task(SETTINGS, check_scenario=False), BURGER)
    return RolePlayer('burger_1', tuning, port), port


def assign(player, round_=1, status='assigned'):
    roles = {'burger_1': ('diamond_0', a_role('burger_1', (0.0, 0.0), (1.0, 0.0))),
             'burger_2': ('diamond_1', a_role('burger_2', (0.0, 1.0), (-1.0, 1.0)))}
    player.on_assignment(RoundAssignment(round_, status, 'initial negotiation', roles if status == 'assigned' else {}))


def test_a_player_waits_for_its_start_plays_and_arrives(player):
    player, port = player
    assign(player)
    assert player.state is PlayerState.WAITING and list(player.others) == ['burger_2']
    player.observe(1.0, (0.0, 0.0, 0.0))
    player.control(1.0)
    assert port.commands[-1] == (0.0, 0.0)                 # before the role's start: stand still
    player.observe(3.0, (0.05, 0.0, 0.0))
    player.control(3.0)
    assert player.state is PlayerState.PLAYING and port.commands[-1][0] > 0.0
    player.observe(12.5, (1.0, 0.01, 0.0))                # the role is over and the robot at its destination
    player.control(12.5)
    assert player.state is PlayerState.ARRIVED and player.arrived_at == 12.5 and port.commands[-1] == (0.0, 0.0)
    assert port.published[-1].arrived and port.published[-1].version == 1


def test_a_replan_publishes_a_new_version_and_the_heartbeat(player):
    player, port = player
    assign(player)
    assert player.replan(1.0) is None and port.published[-1].version == 1     # not started: heartbeat only
    player.observe(4.0, (0.2, 0.0, 0.0))
    result = player.replan(4.0)
    assert result is not None and result.trajectory is not None
    assert player.version == 1 and player.role.start_time == 4.0 and port.published[-1].role is player.role
    player.on_role('burger_2', 1, a_role('burger_2', (0.0, 1.0), (-1.0, 1.0), start_time=4.0))
    player.on_role('burger_2', 7, a_role('burger_2', (5.0, 5.0), (5.0, 6.0)))     # another round: ignored
    assert player.others['burger_2'].start_time == 4.0


def test_a_player_left_out_stops_and_a_stale_pose_stops_it(player):
    player, port = player
    assign(player)
    player.check_pose_age(3.0, timeout=1.0)
    assert port.commands[-1] == (0.0, 0.0) and port.lines[-1][0] == 'warn'    # started, never seen
    assign(player, round_=2, status='aborted')
    assert player.state is PlayerState.IDLE and player.role is None and port.commands[-1] == (0.0, 0.0)
    assign(player, round_=1)                                                     # an older round: ignored
    assert player.round == 2 and player.role is None


def engine(min_robots=3):
    task, _, team = engine_settings_file(str(SETTINGS))
    tuning = EngineTuning.from_task(task).with_values({'min_robots': min_robots})
    port = Recorder()
    return RoleEngine(task, team, tuning, port), port, team


def view(team, t=0.0, missing=()):
    positions = {m.name: (None if m.name in missing else (-1.5 + i, -1.8)) for i, m in enumerate(team)}
    return CameraView(t, positions, lambda robots: open_environment())


def test_the_engine_negotiates_once_everyone_is_seen_then_watches_and_completes():
    behaviour, port, team = engine()
    behaviour.tick(0.0, None)
    behaviour.tick(0.0, view(team, missing=('burger_2',)))
    assert behaviour.phase is EnginePhase.NEGOTIATE and not port.rounds and 'burger_2' in port.lines[-1][1]
    behaviour.tick(1.0, view(team, 1.0))
    (outcome,) = port.rounds
    assert outcome.status == 'assigned' and outcome.round == 1 and outcome.environment is not None
    assert sorted(r.robot for r in outcome.roles) == sorted(m.name for m in team)
    assert all(r.role.start_time == 1.0 + behaviour.tuning.start_delay for r in outcome.roles)
    assert behaviour.phase is EnginePhase.WATCH
    assert not behaviour.accepts('burger_1', 1, 0) and behaviour.accepts('burger_1', 1, 1)
    for r in outcome.roles:
        behaviour.heard(r.robot, 5.0, r.role, r.role_id, arrived=True)
    assert port.ended == 1 and port.lines[-1][1] == 'round 1: formation complete'


def test_a_silent_robot_is_excluded_and_too_few_robots_abort():
    behaviour, port, team = engine(min_robots=4)
    behaviour.tick(0.0, view(team))
    start = port.rounds[0].roles[0].role.start_time
    silent_after = start + behaviour.tuning.problems.silence_timeout + 0.5
    for r in port.rounds[0].roles:
        if r.robot != 'burger_2':
            behaviour.heard(r.robot, silent_after - 0.1, r.role, r.role_id, arrived=False)
    behaviour.tick(silent_after, view(team, silent_after))
    aborted = port.rounds[-1]
    assert behaviour.excluded == ['burger_2'] and aborted.status == 'aborted' and aborted.round == 2
    assert 'burger_2 went silent' in aborted.message and 'min_robots = 4' in aborted.message
    assert behaviour.phase is EnginePhase.DONE and port.ended == 1
