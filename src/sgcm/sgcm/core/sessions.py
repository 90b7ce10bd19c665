"""Who a Guidance or FollowerReport is from, and which of them a node follows (sessions; issue 16 item 4).

Every message names its sender (the node's fully qualified name) and the sender's session
(:func:`collab_tools.core.session_following.new_session`, drawn at start); rounds are numbered
within a session (1, 2, ...).

The follower (:class:`FollowedLeader`) follows the current session of its leader with the
shared rules of :mod:`collab_tools.core.session_following`, chosen for guidance:

* rounds may run at most ``max_round_jump`` (3) ahead: guidance is reliable, so a jump means
  lost messages, and a few may be;
* a repeated or earlier round is refused (``guidance.round: already heard``): on a reliable
  stream it is a duplicate or a late copy, never normal traffic;
* another session ends the previous one only once it is *confirmed* by its second message in
  sequence, and an unconfirmed follower joins another session at any round: a follower that has
  just (re)started joins the session under way, one forged message cannot hold it, and a forged
  "restart" is undone by the real leader's next round;
* the end of the task (a Guidance with ``task_complete`` or a status) is taken only in the
  followed session, at or after its last round: a task-complete from another sender or session
  never stops the follower. (A leader that restarts and finds the goal at once ends a session
  the follower never followed: the follower keeps waiting, and the orchestration, which waits
  for the leader, stops it.)
* a refusal raises :class:`~collab_tools.core.input_checks.MalformedInput` with a kind, so the
  node's InputGuard drops, counts and logs it once per kind.

The leader (:class:`FollowerReports`) takes a report only from her follower, addressed to her own
session (``leader_session``: a report to her previous life is not about her rounds); the round
check stays with :class:`~.leader_rounds.LeaderRounds`. A follower that restarts has a new session:
she notes it and goes on.

What this cannot do: without DDS security (README, Security) any participant can write the
leader's name and a fresh session id; such a message is a restarted leader to the follower.
"""
from __future__ import annotations

from collab_tools.core.input_checks import MalformedInput
from collab_tools.core.session_following import Followed, FollowingRules, NotFollowed, Refusal, SessionFollowing

#: Rounds a guidance may run ahead of the last one heard in its session (and the highest first round
#: of a new session): guidance is reliable, so more than a few lost rounds in a row means it is not ours.
MAX_ROUND_JUMP = 3
#: Messages in sequence that confirm a leader session and end the others (see the module docstring).
CONFIRMING_GUIDANCE = 2


class FollowedLeader(SessionFollowing):
    """The follower's view of its leader's sessions; see the module docstring."""

    def __init__(self, leader: str, max_round_jump: int = MAX_ROUND_JUMP):
        super().__init__(leader, FollowingRules(max_round_jump, ends_others_after=CONFIRMING_GUIDANCE,
                                                joins_session_under_way=True))
        self.leader = leader

    def check(self, sender: str, session: int, round_number: int, final: bool = False) -> Followed:
        """Take a Guidance's identity and round; MalformedInput (with a kind) when refused."""
        try:
            self.judge(sender, session, round_number, final)
        except NotFollowed as refused:
            raise self._malformed(refused) from None
        return self.take(session, round_number)

    def _malformed(self, refused: NotFollowed) -> MalformedInput:
        sender, session, number = refused.sender, refused.session, refused.round_number
        last, jump = self.last_round, self.rules.max_round_jump
        text, kind = {
            Refusal.OTHER_SENDER: (f"guidance.sender: '{sender[:80]}' is not the leader ({self.leader})",
                                   'guidance.sender: not the leader'),
            Refusal.NO_SESSION: ('guidance.session: 0 (no session)', 'guidance.session: none'),
            Refusal.ENDED_SESSION: (f'guidance.session: {session:#x} has ended (the leader restarted since)',
                                    'guidance.session: ended'),
            Refusal.TASK_END_OF_ANOTHER_SESSION: (
                f'guidance: a task end from session {session:#x}, not the session followed',
                'guidance.session: task end of another session'),
            Refusal.ALREADY_HEARD: (f'guidance.round: {number} is not after round {last} of this session '
                                    '(a duplicate or a late copy)', 'guidance.round: already heard'),
            Refusal.ROUND_JUMP: (f'guidance.round: {number} jumps more than {jump} rounds ahead of round {last}',
                                 'guidance.round: too far ahead'),
            Refusal.OUT_OF_ORDER: (f'guidance.session: {session:#x} is not the session followed, and its round '
                                   f'{number} neither begins nor continues it',
                                   'guidance.session: another, out of order'),
        }[refused.reason]
        return MalformedInput(text, kind=kind)


class FollowerReports:
    """The leader's check of a FollowerReport's identity; see the module docstring."""

    def __init__(self, follower: str, leader_session: int):
        self.follower = follower
        self.leader_session = leader_session
        self.follower_session: int | None = None

    def check(self, sender: str, session: int, leader_session: int) -> int | None:
        """None, or the follower's previous session when this report shows he restarted;
        MalformedInput (with a kind) when the report is not from him or not to this leader session."""
        if sender != self.follower:
            raise MalformedInput(f"follower_report.sender: '{sender[:80]}' is not the follower ({self.follower})",
                                 kind='follower_report.sender: not the follower')
        if session == 0:
            raise MalformedInput('follower_report.session: 0 (no session)', kind='follower_report.session: none')
        if leader_session != self.leader_session:
            raise MalformedInput(f'follower_report.leader_session: {leader_session:#x} is not this leader\'s '
                                 f'session ({self.leader_session:#x})',
                                 kind='follower_report.leader_session: not this leader')
        previous, self.follower_session = self.follower_session, session
        return previous if previous is not None and previous != session else None
