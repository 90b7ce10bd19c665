"""The rounds of a task without ROS: the stuck rule, the leader_planner's and the follower_executor's
behaviour classes (driven through fake ports), and the node's rounds ending as the episode loop's."""
import numpy as np
import pytest

from sgcm.core.episode import run_greedy, run_sgcm
from sgcm.core.follower_behaviour import Follower, FollowerSettings, greedy_action
from sgcm.core.follower_rounds import FollowerPhase, FollowerRounds, HeardGuidance
from sgcm.core.fse import FSEPlanner
from sgcm.core.leader_round import Ending, LeaderRound, TaskEnd
from sgcm.core.leader_rounds import LeaderPhase, LeaderRounds
from sgcm.core.rearrangement import EMPTY, FOLLOWER, LEADER
from sgcm.core.stuck_rule import MoveOutcome, RoundCertainty, StuckRule

STILL = MoveOutcome(attempted=False, took_effect=True)
MOVED = MoveOutcome(attempted=True, took_effect=True)
FAILED = MoveOutcome(attempted=True, took_effect=False)
A, B, C = np.array([1, 0]), np.array([0, 1]), np.array([1, 1])


def test_an_idle_round_is_stuck_whether_or_not_moves_can_fail():
    for moves_can_fail in (True, False):
        rule = StuckRule(moves_can_fail)
        assert rule.observe(A, 1) is None
        rule.round_ended(1, RoundCertainty(STILL, STILL))
        assert rule.observe(A, 2) == 'stuck: both arms idle in round 1'


def test_a_state_that_comes_back_is_stuck_only_when_nothing_was_left_to_chance():
    rule = StuckRule(moves_can_fail=False)
    for number, state in enumerate((A, B), start=1):
        assert rule.observe(state, number) is None
        rule.round_ended(number, RoundCertainty(MOVED, MOVED))
    assert rule.observe(A, 3).startswith('stuck: the state round 1 started from came back after round 2')
    # The same rounds when moves may fail, a move failed, the follower or the leader drew by chance,
    # or the follower's round is unknown: never stuck.
    for moves_can_fail, certainty in ((True, RoundCertainty(MOVED, MOVED)), (False, RoundCertainty(FAILED, MOVED)),
                                      (False, RoundCertainty(MOVED, MOVED, follower_by_chance=True)),
                                      (False, RoundCertainty(MOVED, STILL, leader_sampled=True)),
                                      (False, RoundCertainty(MOVED, None))):
        rule = StuckRule(moves_can_fail)
        for number, state in enumerate((A, B), start=1):
            assert rule.observe(state, number) is None
            rule.round_ended(number, certainty)
        assert rule.observe(A, 3) is None, (moves_can_fail, certainty)


def test_an_uncertain_round_forgets_the_states_before_it():
    rule = StuckRule(moves_can_fail=False)
    rule.observe(A, 1)
    rule.round_ended(1, RoundCertainty(MOVED, FAILED))
    rule.observe(B, 2)
    rule.round_ended(2, RoundCertainty(MOVED, MOVED))
    rule.observe(C, 3)
    rule.round_ended(3, RoundCertainty(MOVED, MOVED))
    assert rule.observe(A, 4) is None          # seen before the uncertain round only
    rule.round_ended(4, RoundCertainty(MOVED, MOVED))
    assert rule.observe(B, 5) is not None      # seen after it


class LeaderPort:
    def __init__(self):
        self.effects = []

    def execute(self, turn):
        self.effects.append(('execute', turn.round, turn.action))

    def announce(self, turn, succeeded):
        self.effects.append(('announce', turn.round, succeeded))

    def finish(self, end):
        self.effects.append(('finish', end.ending, end.reason))


def test_leader_rounds_go_through_their_phases(model, cases):
    port = LeaderPort()
    rounds = LeaderRounds(LeaderRound(model, 'sgcm', FSEPlanner(model), round_limit=1), port)
    start = model.state_of(cases[0])
    turn = rounds.table_seen(start)
    assert turn.round == 1 and turn.action != EMPTY and rounds.phase is LeaderPhase.EXECUTING
    assert port.effects == [('execute', 1, turn.action)]
    assert rounds.table_seen(start) is None                   # not observing: a frame changes nothing
    rounds.move_done(True)
    assert rounds.phase is LeaderPhase.AWAITING_FOLLOWER and port.effects[-1] == ('announce', 1, True)
    assert not rounds.follower_reported(0, True, True, 'obedient')   # a late report of another round
    assert rounds.follower_reported(1, True, True, 'obedient') and rounds.phase is LeaderPhase.OBSERVING
    assert not rounds.follower_reported(1, True, True, 'obedient')   # a duplicate
    end = rounds.table_seen(model.apply(start, LEADER, turn.action))
    assert isinstance(end, TaskEnd) and end.ending is Ending.ROUND_LIMIT and end.rounds == 1
    assert port.effects[-1] == ('finish', Ending.ROUND_LIMIT, 'round limit 1 reached')
    assert rounds.phase is LeaderPhase.DONE


def test_the_goal_ends_the_task_before_anything_is_planned(model, cases):
    port = LeaderPort()
    rounds = LeaderRounds(LeaderRound(model, 'sgcm', FSEPlanner(model)), port)
    end = rounds.table_seen(model.goal_state(model.state_of(cases[0])))
    assert end.complete and end.rounds == 0 and port.effects == [('finish', Ending.GOAL, 'goal reached')]


def test_a_silent_follower_ends_the_round_as_uncertain(model, cases):
    port = LeaderPort()
    rounds = LeaderRounds(LeaderRound(model, 'greedy', moves_can_fail=False), port)
    state = model.state_of(cases[0])
    turn = rounds.table_seen(state)
    rounds.move_done(False)   # her move did not happen: the state stays
    assert port.effects[-1] == ('announce', 1, False)
    rounds.follower_timed_out()
    assert rounds.phase is LeaderPhase.OBSERVING
    # Neither a failed move nor an unknown follower round lets the same state count as stuck.
    again = rounds.table_seen(state)
    assert not isinstance(again, TaskEnd) and again.round == 2 and again.action == turn.action


def test_both_arms_idle_ends_the_task_as_stuck(model, cases):
    port = LeaderPort()
    leader = LeaderRound(model, 'greedy', moves_can_fail=True)
    rounds = LeaderRounds(leader, port)
    state = model.state_of(cases[0])
    # Greedy leader and follower until a round in which neither moves (case_1 ends so, see Table I).
    for _ in range(model.task.round_limit):
        turn = rounds.table_seen(state)
        if isinstance(turn, TaskEnd):
            break
        after = model.apply(state, LEADER, turn.action) if turn.action != EMPTY else state
        rounds.move_done(True)
        answer = greedy_action(model, after, FOLLOWER)
        rounds.follower_reported(turn.round, answer != EMPTY, True, 'zero_trust')
        state = model.apply(after, FOLLOWER, answer) if answer != EMPTY else after
    assert turn.ending is Ending.STUCK and turn.reason.startswith('stuck: both arms idle in round')


@pytest.mark.parametrize('strategy', ['sgcm', 'greedy'])
def test_the_node_rounds_end_as_the_episode_loop(model, cases, strategy):
    """The leader_planner's rounds, fed the abstract game's outcomes, stop where run_sgcm/run_greedy stop."""
    planner = FSEPlanner(model)
    for case in cases[:5]:
        start = model.state_of(case)
        if strategy == 'sgcm':
            episode = run_sgcm(model, start, planner=planner)
            follower = Follower(model, FollowerSettings('obedient'))
        else:
            episode = run_greedy(model, start)
            follower = Follower(model, FollowerSettings('zero_trust'))
        rounds = LeaderRounds(LeaderRound(model, strategy, planner, moves_can_fail=False), LeaderPort())
        state = start
        while True:
            turn = rounds.table_seen(state)
            if isinstance(turn, TaskEnd):
                break
            leader_ok = turn.action == EMPTY or model.can_apply(state, LEADER, turn.action)
            after = model.apply(state, LEADER, turn.action) if turn.action != EMPTY and leader_ok else state
            rounds.move_done(leader_ok)
            choice = follower.choose(turn.round, after, state, turn.action,
                                     EMPTY if turn.recommended is None else turn.recommended)
            ok = choice.action == EMPTY or model.can_apply(after, FOLLOWER, choice.action)
            rounds.follower_reported(turn.round, choice.action != EMPTY, ok, follower.settings.behaviour)
            state = model.apply(after, FOLLOWER, choice.action) if choice.action != EMPTY and ok else after
        assert (turn.rounds, turn.complete, turn.ending is Ending.STUCK) == \
            (episode.rounds, episode.completed, episode.stuck), case.name
        assert state.tolist() == episode.final_state


class FollowerPort:
    def __init__(self):
        self.effects = []

    def execute(self, number, choice):
        self.effects.append(('execute', number, choice.action))

    def report(self, number, choice, succeeded, message, leader_session=0):
        self.effects.append(('report', number, choice.action, succeeded, message))
        self.sessions = getattr(self, 'sessions', []) + [leader_session]


def test_follower_rounds_report_every_round_once(model, cases):
    port = FollowerPort()
    rounds = FollowerRounds(Follower(model, FollowerSettings('obedient')), port)
    state = model.state_of(cases[0])
    move = int(model.feasible(state, FOLLOWER)[1])
    assert rounds.table_seen(state) is None                      # nothing heard yet
    assert rounds.guidance_heard(HeardGuidance(1, 0.0, state, EMPTY, move))
    assert not rounds.guidance_heard(HeardGuidance(1, 0.0, state, EMPTY, move))   # a duplicate
    assert rounds.phase is FollowerPhase.SETTLING
    assert rounds.table_seen(state).action == move and port.effects == [('execute', 1, move)]
    # The next round's guidance may come while his arm is busy: it is handled after the report.
    assert rounds.guidance_heard(HeardGuidance(2, 1.0, state, EMPTY, EMPTY))
    assert rounds.phase is FollowerPhase.EXECUTING
    rounds.move_done(True, 'placed')
    assert port.effects[-1] == ('report', 1, move, True, 'placed') and rounds.phase is FollowerPhase.SETTLING
    assert rounds.table_seen(state).action == EMPTY
    assert port.effects[-1] == ('report', 2, EMPTY, True, 'no move') and rounds.phase is FollowerPhase.WAITING
    rounds.task_ended()
    assert not rounds.guidance_heard(HeardGuidance(3, 2.0, state, EMPTY, EMPTY))
    assert rounds.phase is FollowerPhase.DONE
