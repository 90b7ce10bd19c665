"""Who a Guidance or FollowerReport is from, and which of them a node follows (sessions; issue 16 item 4).

Every message names its sender (the node's fully qualified name) and the sender's *session*: a
non-zero 64-bit id the node draws at start (:func:`new_session`); a restarted node has a new one,
and rounds are numbered within a session (1, 2, ...). The id is random rather than "start time +
pid": after a crash the simulated clock restarts at 0, wall clocks of two hosts differ, pids repeat
in containers and on other hosts -- any of these could give a restarted node its old id, while 64
random bits collide with a chance of about 2^-64. Ids are therefore not ordered: which session is
current follows from the rules below, not from comparing ids.

The follower (:class:`FollowedLeader`) follows the current session of its leader:

* a message from another sender, or with no session (0), is refused;
* in the followed session a round is taken once and in order, and at most ``max_round_jump``
  rounds ahead of the last one heard (guidance is reliable, so a jump means lost messages, and a
  few may be): one forged round 2^32-1 cannot make every later round look old;
* another session is taken when it *begins* (round 1 .. ``max_round_jump``: a restarted leader's
  first guidance is round 1), or when it continues in sequence a session heard before, or when
  the followed session is *unconfirmed* (none yet, or only one message heard in it: a follower
  that has just (re)started joins the session under way, and one forged message cannot hold
  it). The follower switches, and its round ordering restarts;
* a session is *confirmed* by its second message in sequence; then every other session is
  ended and its late messages are refused. Until then the previous one may still continue (a
  forged "restart" is undone by the real leader's next round);
* the end of the task is taken only in the followed session, at or after its last round: a
  task-complete from another sender or session never stops the follower. (A leader that
  restarts and finds the goal at once ends a session the follower never followed: the follower
  keeps waiting, and the orchestration, which waits for the leader, stops it.)
* a refusal raises :class:`~collab_tools.core.input_checks.MalformedInput` with a kind, so the
  node's InputGuard drops, counts and logs it once per kind.

The leader (:class:`FollowerReports`) takes a report only from her follower, addressed to her own
session (``leader_session``: a report to her previous life is not about her rounds); the round
check stays with :class:`~.leader_rounds.LeaderRounds`. A follower that restarts has a new session:
she notes it and goes on.

What this cannot do: without DDS security (README, Security) any participant can write the
leader's name and a fresh session id; such a message is a restarted leader to the follower. The
rules stop stale, misdirected and out-of-order messages and one absurd round, not an attacker who
imitates the leader exactly.
"""
from __future__ import annotations

import secrets
from collections import deque
from dataclasses import dataclass

from collab_tools.core.input_checks import MalformedInput

#: Rounds a guidance may run ahead of the last one heard in its session (and the highest first round
#: of a new session): guidance is reliable, so more than a few lost rounds in a row means it is not ours.
MAX_ROUND_JUMP = 3
#: Ended sessions of the leader remembered (their late messages refused): restarts in one task.
REMEMBERED_SESSIONS = 16


def new_session() -> int:
    """A node's session id: random, non-zero, 64 bits (see the module docstring for why not time + pid)."""
    return secrets.randbits(64) or 1


@dataclass(frozen=True)
class Followed:
    """What the follower does with an accepted message."""

    session: int
    new_session: bool       # the message starts (or joins) a session: the round ordering restarts
    replaced: int | None    # the session it replaced (the leader restarted), or None


class FollowedLeader:
    """The follower's view of its leader's sessions; see the module docstring."""

    def __init__(self, leader: str, max_round_jump: int = MAX_ROUND_JUMP):
        self.leader = leader
        self.max_round_jump = max_round_jump
        self.session: int | None = None
        self.heard = 0                          # messages taken in the followed session since it was taken
        self.rounds: dict[int, int] = {}        # session -> last round heard, for the sessions not ended
        self.ended: deque[int] = deque(maxlen=REMEMBERED_SESSIONS)

    @property
    def last_round(self) -> int:
        """The last round heard in the followed session (0: none)."""
        return self.rounds.get(self.session, 0) if self.session is not None else 0

    @property
    def confirmed(self) -> bool:
        return self.heard >= 2

    def check(self, sender: str, session: int, round_number: int, final: bool = False) -> Followed:
        """The verdict on a Guidance's identity and round; MalformedInput (with a kind) when refused."""
        if sender != self.leader:
            raise MalformedInput(f"guidance.sender: '{sender[:80]}' is not the leader ({self.leader})",
                                 kind='guidance.sender: not the leader')
        if session == 0:
            raise MalformedInput('guidance.session: 0 (no session)', kind='guidance.session: none')
        if session in self.ended:
            raise MalformedInput(f'guidance.session: {session:#x} has ended (the leader restarted since)',
                                 kind='guidance.session: ended')
        if session != self.session:
            if final:
                raise MalformedInput(f'guidance: a task end from session {session:#x}, not the session followed',
                                     kind='guidance.session: task end of another session')
            return self._switch(session, round_number)
        last = self.rounds[session]
        if round_number < (last if final else last + 1):
            raise MalformedInput(f'guidance.round: {round_number} is not after round {last} of this session '
                                 '(a duplicate or a late copy)', kind='guidance.round: already heard')
        if round_number > last + self.max_round_jump:
            raise MalformedInput(f'guidance.round: {round_number} jumps more than {self.max_round_jump} rounds '
                                 f'ahead of round {last}', kind='guidance.round: too far ahead')
        self._heard(session, round_number)
        return Followed(session, new_session=False, replaced=None)

    def _switch(self, session: int, round_number: int) -> Followed:
        last = self.rounds.get(session)
        if last is None:
            in_order = 1 <= round_number <= self.max_round_jump           # a session beginning
        else:
            in_order = last < round_number <= last + self.max_round_jump  # a session heard before, going on
        if not (in_order or not self.confirmed):
            raise MalformedInput(f'guidance.session: {session:#x} is not the session followed, and its round '
                                 f'{round_number} neither begins nor continues it',
                                 kind='guidance.session: another, out of order')
        replaced, self.session, self.heard = self.session, session, 0
        self._heard(session, round_number)
        return Followed(session, new_session=True, replaced=replaced)

    def _heard(self, session: int, round_number: int) -> None:
        self.rounds[session] = round_number
        self.heard += 1
        if self.heard == 2:                     # confirmed: every other session has ended
            for other in [s for s in self.rounds if s != session]:
                del self.rounds[other]
                self.ended.append(other)
        elif len(self.rounds) > REMEMBERED_SESSIONS:     # unconfirmed ones pile up only under forgery
            oldest = next(s for s in self.rounds if s != session)
            del self.rounds[oldest]
            self.ended.append(oldest)


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
