"""Following the current session of one sender (collab_tools.core.session_following), hand-worked cases for
both rule sets the subsystems use: a new session ends the old one at once (role players) or once it is
confirmed by its second message (SGCM follower); session ids shared by every node."""
import pytest

from collab_tools.core.input_checks import MalformedInput
from collab_tools.core.session_following import (REMEMBERED_SESSIONS, Followed, FollowingRules, NotFollowed,
                                                 Refusal, SessionFollowing, new_session)

SOURCE = '/team/leader'
A, B, C = 0xA, 0xB, 0xC
TOP = 2**32 - 1
AT_ONCE = FollowingRules(max_round_jump=3, ends_others_after=1, joins_session_under_way=False)
ON_CONFIRMATION = FollowingRules(max_round_jump=3, ends_others_after=2, joins_session_under_way=True)


def refused(follower, *args, reason):
    with pytest.raises(NotFollowed) as error:
        follower.judge(*args)
    assert error.value.reason is reason, str(error.value)


def taken(follower, session, round_number, final=False):
    """Judge, then take: what a node does with a message it can convert."""
    judged = follower.judge(SOURCE, session, round_number, final)
    assert follower.take(session, round_number) == judged
    return judged


def following(rules, session=A, rounds=3):
    follower = SessionFollowing(SOURCE, rules)
    for number in range(1, rounds + 1):
        taken(follower, session, number)
    return follower


def test_session_ids_are_random_non_zero_and_below_2_to_the_63():
    ids = {new_session() for _ in range(1000)}
    assert len(ids) == 1000 and all(0 < s < 2**63 for s in ids)


def test_rules_need_a_round_jump_and_a_confirmation_of_at_least_one():
    with pytest.raises(ValueError, match='at least 1'):
        FollowingRules(max_round_jump=0, ends_others_after=1, joins_session_under_way=False)
    with pytest.raises(ValueError, match='at least 1'):
        FollowingRules(max_round_jump=3, ends_others_after=0, joins_session_under_way=False)


def test_judging_changes_nothing_and_a_refusal_is_a_malformed_input_of_its_reason():
    follower = SessionFollowing(SOURCE, AT_ONCE)
    assert follower.judge(SOURCE, A, 1) == Followed(A, new_session=True, replaced=None)
    assert (follower.session, follower.last_round, follower.rounds) == (0, 0, {})
    with pytest.raises(MalformedInput) as error:
        follower.judge('/someone/else', A, 1)
    assert error.value.kind == 'other sender' and 'round 1 of session 0xa' in str(error.value)


@pytest.mark.parametrize('rules', [AT_ONCE, ON_CONFIRMATION], ids=['at once', 'on confirmation'])
def test_other_senders_and_no_session_are_refused_under_both_rules(rules):
    follower = following(rules)
    refused(follower, '/someone/else', A, 4, reason=Refusal.OTHER_SENDER)
    refused(follower, SOURCE, 0, 4, reason=Refusal.NO_SESSION)
    refused(SessionFollowing(SOURCE, rules), SOURCE, 0, 1, reason=Refusal.NO_SESSION)   # even with none followed
    assert follower.judge(SOURCE, A, 4) == Followed(A, new_session=False, replaced=None)


@pytest.mark.parametrize('rules', [AT_ONCE, ON_CONFIRMATION], ids=['at once', 'on confirmation'])
def test_rounds_of_the_followed_session_are_taken_once_in_order_and_at_most_the_jump_ahead(rules):
    follower = following(rules, rounds=2)                   # last round 2, jump 3: rounds 3, 4, 5 are taken
    refused(follower, SOURCE, A, 2, reason=Refusal.ALREADY_HEARD)
    refused(follower, SOURCE, A, 1, reason=Refusal.ALREADY_HEARD)
    refused(follower, SOURCE, A, 6, reason=Refusal.ROUND_JUMP)      # 2 + 4
    refused(follower, SOURCE, A, TOP, reason=Refusal.ROUND_JUMP)    # cannot make every later round look old
    assert taken(follower, A, 5) == Followed(A, new_session=False, replaced=None)       # 2 rounds lost
    assert follower.last_round == 5 and follower.heard == 3


def test_at_once_a_new_session_ends_the_followed_one_and_must_begin():
    follower = following(AT_ONCE, A, rounds=5)
    refused(follower, SOURCE, B, 4, reason=Refusal.OUT_OF_ORDER)     # a new session begins at 1 .. 3
    refused(follower, SOURCE, B, 0, reason=Refusal.OUT_OF_ORDER)
    assert taken(follower, B, 1) == Followed(B, new_session=True, replaced=A)          # 1 < 5: a restart
    assert list(follower.ended) == [A] and follower.rounds == {B: 1}
    refused(follower, SOURCE, A, 6, reason=Refusal.ENDED_SESSION)    # the old one is not followed back
    fresh = SessionFollowing(SOURCE, AT_ONCE)                          # no session yet: still must begin
    refused(fresh, SOURCE, A, 4, reason=Refusal.OUT_OF_ORDER)
    assert taken(fresh, A, 3) == Followed(A, new_session=True, replaced=None)


def test_on_confirmation_the_old_session_ends_at_the_new_ones_second_message():
    follower = following(ON_CONFIRMATION, A, rounds=3)
    assert taken(follower, B, 1) == Followed(B, new_session=True, replaced=A)
    assert follower.rounds == {A: 3, B: 1} and not follower.ended                 # B unconfirmed: A may go on
    assert taken(follower, B, 2) == Followed(B, new_session=False, replaced=None)   # B confirmed: A ended
    assert follower.rounds == {B: 2} and list(follower.ended) == [A]
    refused(follower, SOURCE, A, 4, reason=Refusal.ENDED_SESSION)


def test_on_confirmation_a_forged_restart_is_undone_by_the_real_senders_next_round():
    follower = following(ON_CONFIRMATION, A, rounds=3)
    refused(follower, SOURCE, C, 9, reason=Refusal.OUT_OF_ORDER)      # confirmed: C neither begins nor goes on
    assert taken(follower, C, 1) == Followed(C, new_session=True, replaced=A)        # looks like a restart
    assert taken(follower, A, 4) == Followed(A, new_session=True, replaced=C)        # A heard before, 3 < 4 <= 6
    assert taken(follower, A, 5) == Followed(A, new_session=False, replaced=None)    # A confirmed again: C ended
    refused(follower, SOURCE, C, 2, reason=Refusal.ENDED_SESSION)


def test_joining_under_way_one_forged_round_cannot_hold_a_fresh_follower():
    follower = SessionFollowing(SOURCE, ON_CONFIRMATION)
    assert taken(follower, C, TOP) == Followed(C, new_session=True, replaced=None)   # the first thing it hears
    assert taken(follower, A, 12) == Followed(A, new_session=True, replaced=C)       # unconfirmed: any round joins
    taken(follower, A, 13)
    refused(follower, SOURCE, C, TOP, reason=Refusal.ENDED_SESSION)
    refused(follower, SOURCE, B, 12, reason=Refusal.OUT_OF_ORDER)    # A confirmed: no more joining


def test_a_task_end_is_taken_only_in_the_followed_session_at_or_after_its_last_round():
    follower = following(ON_CONFIRMATION, A, rounds=3)
    refused(follower, SOURCE, B, 3, True, reason=Refusal.TASK_END_OF_ANOTHER_SESSION)
    refused(follower, SOURCE, B, 1, True, reason=Refusal.TASK_END_OF_ANOTHER_SESSION)   # even one that begins
    refused(SessionFollowing(SOURCE, ON_CONFIRMATION), SOURCE, A, 0, True,
            reason=Refusal.TASK_END_OF_ANOTHER_SESSION)                                    # none followed yet
    refused(follower, SOURCE, A, 2, True, reason=Refusal.ALREADY_HEARD)
    refused(follower, SOURCE, A, 7, True, reason=Refusal.ROUND_JUMP)                      # 3 + 4
    assert taken(follower, A, 3, final=True) == Followed(A, new_session=False, replaced=None)  # repeats round 3


def test_unconfirmed_sessions_piling_up_under_forgery_end_oldest_first():
    follower = SessionFollowing(SOURCE, ON_CONFIRMATION)
    for session in range(1, REMEMBERED_SESSIONS + 2):       # 17 sessions, each heard once: none confirmed
        taken(follower, session, 1)
    assert list(follower.ended) == [1] and sorted(follower.rounds) == list(range(2, 18))
    refused(follower, SOURCE, 1, 2, reason=Refusal.ENDED_SESSION)
    assert follower.judge(SOURCE, 2, 2) == Followed(2, new_session=True, replaced=17)   # heard before, going on
