"""Sessions: a node's id for one life, and following the current session of one sender (issue 16 item 4).

Every node that others follow draws a *session* when it starts (:func:`new_session`) and puts
it, with its node name (the *sender*), into what it publishes; rounds are numbered within a
session (1, 2, ...), so a restarted node has a new session that starts again at round 1. The
id is random rather than "start time + pid": after a crash the simulated clock restarts at 0,
the wall clocks of two hosts differ, pids repeat in containers and on other hosts -- any of
these could give a restarted node its old id, while 63 random bits collide with a chance of
about 2^-63. Ids are therefore not ordered: which session is current follows from the rules
below, not from comparing ids. One rule for the SGCM nodes, the role engines and the coalition
agents alike.

:class:`SessionFollowing` is one follower's view of the sessions of the node it follows (the
SGCM follower of his leader, a role player of its engine):

* a message from another sender, or with no session (0), is refused;
* a message of a session that has *ended* is refused;
* in the followed session a round is taken once and in order (an earlier or equal round is
  ``ALREADY_HEARD``: the caller decides whether that is an error or normal traffic), and at most
  ``max_round_jump`` rounds ahead of the last one taken: one forged round 2^32-1 cannot make
  every later round look old;
* another session is taken when it *begins* (round 1 .. ``max_round_jump``), or when it
  continues in sequence a session heard before and not ended; with ``joins_session_under_way``
  any round of another session is taken while the followed session is *unconfirmed* (a
  follower that has just (re)started joins the session under way);
* the followed session is *confirmed* by ``ends_others_after`` messages in sequence; then every
  other session has ended. 1: a new session ends the previous one at once; 2: until its second
  message the previous one may still go on (a forged "restart" is undone by the real sender's
  next round);
* a task end (``final``) is taken only in the followed session, at or after its last round: a
  task end of another session never stops the follower.

The rules that differ between the subsystems are a :class:`FollowingRules` each (see the SGCM
and role_engine ``core.sessions``); what a refusal is called (its kind, its text) is theirs too:
a refusal is a :class:`NotFollowed` with a :class:`Refusal` reason they translate.

:meth:`SessionFollowing.judge` only judges and :meth:`SessionFollowing.take` only follows, so a
node can convert the rest of a message between the two and drop it whole when that fails.

What this cannot do: without DDS security (README, Security) any participant can write the
sender's name and a fresh session id; such a message is a restarted sender to the follower.
The rules stop stale, misdirected and out-of-order messages and one absurd round, not an
attacker who imitates the sender exactly.
"""
from __future__ import annotations

import secrets
from collections import deque
from dataclasses import dataclass
from enum import Enum

from .input_checks import MalformedInput

#: Ended sessions remembered (their late messages refused): restarts within one task.
REMEMBERED_SESSIONS = 16
#: Session ids stay below 2^63: they fit the uint64 message fields and any signed 64-bit store alike.
SESSION_LIMIT = 2**63


def new_session() -> int:
    """A node's session id: random, non-zero, below 2^63 (module docstring: why not time + pid)."""
    return secrets.randbelow(SESSION_LIMIT - 1) + 1


@dataclass(frozen=True)
class FollowingRules:
    """The rules a subsystem chooses (module docstring)."""

    max_round_jump: int             # rounds a message may run ahead of the last one taken (and a new session's first)
    ends_others_after: int          # messages in sequence that confirm the followed session and end every other
    joins_session_under_way: bool   # an unconfirmed follower takes another session at any round

    def __post_init__(self) -> None:
        if self.max_round_jump < 1 or self.ends_others_after < 1:
            raise ValueError(f'max_round_jump and ends_others_after must be at least 1 (got {self})')


class Refusal(Enum):
    """Why a message is not followed (the subsystem names it: kind and text)."""

    OTHER_SENDER = 'other sender'
    NO_SESSION = 'no session'
    ENDED_SESSION = 'ended session'
    TASK_END_OF_ANOTHER_SESSION = 'task end of another session'
    ALREADY_HEARD = 'already heard'               # an earlier or equal round of the followed session
    ROUND_JUMP = 'round jump'                     # too far ahead in the followed session
    OUT_OF_ORDER = 'another session, out of order'  # another session that neither begins nor goes on


class NotFollowed(MalformedInput):
    """A refused message: ``reason`` and the message's sender, session and round (its kind is the reason's
    value, so a node that does not translate it still counts it)."""

    def __init__(self, reason: Refusal, sender: str, session: int, round_number: int):
        super().__init__(f'not followed ({reason.value}): round {round_number} of session {session:#x}',
                         kind=reason.value)
        self.reason, self.sender, self.session, self.round_number = reason, sender, session, round_number


@dataclass(frozen=True)
class Followed:
    """What the follower does with a message it takes."""

    session: int
    new_session: bool       # the message starts (or joins) a session: the round ordering restarts
    replaced: int | None    # the session it replaced (the sender restarted), or None (there was none)


class SessionFollowing:
    """One follower's view of the sessions of ``source`` (the followed node's full name); module docstring."""

    def __init__(self, source: str, rules: FollowingRules):
        self.source = source
        self.rules = rules
        self.session = 0                        # the followed session (0: none yet)
        self.heard = 0                          # messages taken in the followed session since it was taken
        self.rounds: dict[int, int] = {}        # session -> last round taken, for the sessions not ended
        self.ended: deque[int] = deque(maxlen=REMEMBERED_SESSIONS)

    @property
    def last_round(self) -> int:
        """The last round taken in the followed session (0: none)."""
        return self.rounds.get(self.session, 0)

    @property
    def confirmed(self) -> bool:
        return self.heard >= self.rules.ends_others_after

    def judge(self, sender: str, session: int, round_number: int, final: bool = False) -> Followed:
        """What taking this message would do; :class:`NotFollowed` when it is refused. Changes nothing."""
        def refuse(reason: Refusal) -> NotFollowed:
            return NotFollowed(reason, sender, session, round_number)

        if sender != self.source:
            raise refuse(Refusal.OTHER_SENDER)
        if session == 0:
            raise refuse(Refusal.NO_SESSION)
        if session in self.ended:
            raise refuse(Refusal.ENDED_SESSION)
        jump = self.rules.max_round_jump
        if session != self.session:
            if final:
                raise refuse(Refusal.TASK_END_OF_ANOTHER_SESSION)
            last = self.rounds.get(session)
            if last is None:
                in_order = 1 <= round_number <= jump               # a session beginning
            else:
                in_order = last < round_number <= last + jump      # a session heard before, going on
            if not in_order and not (self.rules.joins_session_under_way and not self.confirmed):
                raise refuse(Refusal.OUT_OF_ORDER)
            return Followed(session, new_session=True, replaced=self.session or None)
        last = self.rounds[session]
        if round_number < (last if final else last + 1):      # a task end repeats the last round
            raise refuse(Refusal.ALREADY_HEARD)
        if round_number > last + jump:
            raise refuse(Refusal.ROUND_JUMP)
        return Followed(session, new_session=False, replaced=None)

    def take(self, session: int, round_number: int) -> Followed:
        """Follow a message (judged first, or known to be good): its session and round become the current ones."""
        new = session != self.session
        followed = Followed(session, new_session=new, replaced=(self.session or None) if new else None)
        if new:
            self.session, self.heard = session, 0
        self.rounds[session] = round_number
        self.heard += 1
        if self.heard == self.rules.ends_others_after:          # confirmed: every other session has ended
            for other in [s for s in self.rounds if s != session]:
                self._end(other)
        elif len(self.rounds) > REMEMBERED_SESSIONS:              # unconfirmed ones pile up only under forgery
            self._end(next(s for s in self.rounds if s != session))
        return followed

    def _end(self, session: int) -> None:
        del self.rounds[session]
        self.ended.append(session)
