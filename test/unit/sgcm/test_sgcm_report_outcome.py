"""The report's outcome line of an SGCM bag: goal reached (or why the task ended) in how many rounds."""
from pathlib import Path

import numpy as np

from collab_tools.core.bag_analysis import summarize_bag
from collab_tools.core.bag_types import build_typestore
from collab_tools.core.bag_writer import BagWriter, QosSpec
from sgcm.experiments.report_plots import sgcm_outcome

WS = Path(__file__).resolve().parents[3]
GUIDANCE, REPORT = 'sgcm_interfaces/msg/Guidance', 'sgcm_interfaces/msg/FollowerReport'


LEADER = '/leader_arm/leader_planner'


def write_bag(path, prefix, rounds, final_status, deviated_round=None, sessions=(7,)):
    """``rounds`` rounds in each leader session of ``sessions`` (a restarted leader begins at round 1 again);
    the final guidance in the last one."""
    target = prefix / 'share' / 'sgcm_interfaces' / 'msg'
    target.mkdir(parents=True, exist_ok=True)
    for msg in (WS / 'interfaces' / 'sgcm_interfaces' / 'msg').glob('*.msg'):
        (target / msg.name).write_text(msg.read_text())
    store = build_typestore([GUIDANCE, REPORT], prefixes=[prefix])
    T = store.types
    move = lambda: T['sgcm_interfaces/msg/Move'](empty=False, source_cell=1, target_cell=2, colour='red')  # noqa: E731
    header = T['std_msgs/msg/Header'](stamp=T['builtin_interfaces/msg/Time'](sec=1, nanosec=0), frame_id='')
    grid = T['sgcm_interfaces/msg/GridState'](rows=1, cols=3, colours=['red'], counts=np.array([1, 0, 0], np.uint16))

    def guidance(number, session, complete=False, status='', sender=LEADER):
        return T[GUIDANCE](header=header, sender=sender, session=session, round=number, horizon=2, strategy='sgcm', state=grid, leader_move=move(),
                           leader_move_succeeded=True, leader_policy_moves=[], leader_policy_probabilities=np.zeros(0),
                           recommended_follower_move=move(), predicted_leader_value=1.0,
                           predicted_follower_value=1.0, stage_games=1, planning_seconds=0.01,
                           task_complete=complete, status=status)
    with BagWriter(path, store) as writer:
        writer.add_topic('/sgcm/guidance', GUIDANCE, [QosSpec('keep_last', 10, 'reliable', 'volatile')])
        writer.add_topic('/sgcm/follower_report', REPORT, [QosSpec('keep_last', 10, 'reliable', 'volatile')])
        time = 0
        for session in sessions:
            for number in range(1, rounds + 1):
                time += 10**9
                writer.write('/sgcm/guidance', time, bytes(store.serialize_cdr(guidance(number, session), GUIDANCE)))
                report = T[REPORT](header=header, sender='/follower_arm/follower_executor', session=3,
                                   leader_session=session, round=number, behaviour='obedient', move=move(),
                                   succeeded=True, deviated=number == deviated_round, message='')
                writer.write('/sgcm/follower_report', time + 1, bytes(store.serialize_cdr(report, REPORT)))
        # A stray publisher's round (another sender) is not part of the episode.
        writer.write('/sgcm/guidance', time + 2, bytes(store.serialize_cdr(guidance(1, 99, sender='/forger'), GUIDANCE)))
        if final_status is not None:
            final = guidance(rounds, sessions[-1], complete=final_status == 'goal reached', status=final_status)
            writer.write('/sgcm/guidance', time + 10**9, bytes(store.serialize_cdr(final, GUIDANCE)))
    return path


def test_goal_reached_with_rounds_and_deviations(tmp_path):
    bag = write_bag(tmp_path / 'bag', tmp_path / 'prefix', rounds=4, final_status='goal reached', deviated_round=2)
    outcome = sgcm_outcome(bag, summarize_bag(bag))
    assert (outcome.status, outcome.passed) == ('completed', True)
    assert outcome.summary == ('goal reached in 4 rounds (sgcm, T=2); 1 follower deviation, 0 failed moves')


def test_a_stuck_leader_or_no_ending_is_no_success(tmp_path):
    stuck = write_bag(tmp_path / 'stuck', tmp_path / 'prefix', rounds=3, final_status='stuck: state 5 came back')
    outcome = sgcm_outcome(stuck, summarize_bag(stuck))
    assert (outcome.status, outcome.passed, outcome.checks) == ('ended', False, {'goal_reached': False})
    assert outcome.summary.startswith('stuck: state 5 came back in 3 rounds')
    cut = write_bag(tmp_path / 'cut', tmp_path / 'prefix', rounds=2, final_status=None)
    assert sgcm_outcome(cut, summarize_bag(cut)).status == 'incomplete'


def test_a_restarted_leaders_rounds_follow_her_earlier_ones(tmp_path):
    """Two leader sessions of 2 rounds each (she restarted after round 2): 4 rounds, both deviations counted."""
    bag = write_bag(tmp_path / 'bag', tmp_path / 'prefix', rounds=2, final_status='goal reached', deviated_round=1,
                    sessions=(7, 2**64 - 1))
    outcome = sgcm_outcome(bag, summarize_bag(bag))
    assert outcome.summary == 'goal reached in 4 rounds (sgcm, T=2); 2 follower deviations, 0 failed moves'
