"""Sessions and senders on the role topics (issue 16 item 4): which messages a role node follows.

Every role engine picks a *session* id when it starts (:func:`new_session`, a random non-zero
64-bit number) and puts its node name (the *sender*) and the session into every assignment and
initial process role; a player puts its own node name and the engine session it plays into every
process role it publishes. Round counters count within a session: a restarted engine starts a
new session at round 1.

A player follows the current session of its engine (:class:`SessionFollower`):

* an assignment whose sender is not its engine is ignored (``other sender``);
* a later round of the current session is applied; an earlier or equal one is not (it is old);
* an assignment of a session the player has left is ignored (``old session``); one of a session
  it has not seen is a restarted engine: it is applied (the new session replaces the current one,
  which is left for good), so a restarted engine's round 1 is not lost behind the old round 5;
* a round more than :data:`MAX_ROUND_JUMP` ahead of the current one (or a new session's first
  round above it) is refused (``round jump``): one forged round 2^32-1 cannot make every later
  round look old. A player may miss rounds (the latched assignment keeps only the newest, a
  restarted player sees the current round first), so the next round cannot be required to be
  +1; an engine opens a round per renegotiation (each excluding or re-including a robot), a few
  per task, so a jump of 64 is far beyond a real one and far below the counter's range.

Process roles on the channel (:meth:`SessionFollower.channel_verdict` for a player,
:func:`engine_channel_verdict` for the engine) count when they are of the current session
and come from the robot's own node (a node in the robot's namespace: its player) or, for the
initial roles, from the engine; a role naming a robot whose namespace its sender is not in is a
forged sender and ignored (``forged sender``), one of another session too (``other session``).
A robot's player announces itself while it plays no role (role_interfaces/PlayerAnnouncement);
:func:`check_announcement_sender` checks the same sender rule.

What is refused raises :class:`~collab_tools.core.input_checks.MalformedInput` with its kind, so a
node's input guard counts it and logs the first of each kind; what is merely old (an earlier
round, a node's own message) returns False and is dropped quietly, as normal traffic.

These rules separate sessions, restarted nodes, other teams' and misconfigured nodes; they do not
authenticate: any participant of the ROS domain can write any sender and session (the pinned Fast
DDS wheels have no security plugins; README "Security").
"""
from __future__ import annotations

import secrets
from collections import deque
from enum import Enum

from collab_tools.core.input_checks import MalformedInput

#: Largest accepted step of the round counter within a session (and first round of a new one).
MAX_ROUND_JUMP = 64
#: Sessions a follower remembers having left (older ones are long gone from any latched topic).
LEFT_SESSIONS = 16
#: Characters of a sender or robot name an error message echoes (forged names can be long).
NAME_ECHO = 60


def new_session() -> int:
    """A random non-zero session id (uint64): two starts of an engine never share one in practice."""
    return secrets.randbelow(2**64 - 1) + 1


def _name(value: str) -> str:
    return repr(value[:NAME_ECHO] + ('...' if len(value) > NAME_ECHO else ''))


def node_of_robot(sender: str, robot: str) -> bool:
    """Whether the node named ``sender`` (full name) runs in ``robot``'s namespace (``.../<robot>/<node>``)."""
    parts = sender.split('/')
    return len(parts) >= 3 and parts[0] == '' and parts[-2] == robot and bool(robot) and bool(parts[-1])


class Verdict(Enum):
    APPLY = 'apply'          # a new session or a later round: apply it
    OLD = 'old'              # an earlier or equal round of the current session: drop quietly


class SessionFollower:
    """A player's view of its engine's sessions (module docstring). ``engine``: the engine node's full name."""

    def __init__(self, engine: str):
        self.engine = engine
        self.session = 0              # 0: no session yet
        self.round = 0
        self.left: deque[int] = deque(maxlen=LEFT_SESSIONS)

    def check_assignment(self, sender: str, session: int, round_: int) -> Verdict:
        """What to do with an assignment (nothing changes until :meth:`follow`); MalformedInput when refused."""
        if sender != self.engine:
            raise MalformedInput(f'ignored an assignment from {_name(sender)}: not the role engine {self.engine}',
                                 kind='other sender')
        if session == 0:
            raise MalformedInput('ignored an assignment without a session (session 0)', kind='no session')
        if session in self.left:
            raise MalformedInput(f'ignored an assignment (round {round_}) of session {session}, which this player '
                                 f'has left for session {self.session}', kind='old session')
        if session == self.session:
            if round_ <= self.round:
                return Verdict.OLD
            if round_ - self.round > MAX_ROUND_JUMP:
                raise MalformedInput(f'ignored assignment round {round_}: more than {MAX_ROUND_JUMP} rounds after '
                                     f'round {self.round} of this session', kind='round jump')
        elif not 1 <= round_ <= MAX_ROUND_JUMP:
            raise MalformedInput(f'ignored assignment round {round_} of a new session {session}: a session starts '
                                 f'at round 1 (at most {MAX_ROUND_JUMP} when rounds were missed)', kind='round jump')
        return Verdict.APPLY

    def follow(self, session: int, round_: int) -> bool:
        """Take an applied assignment's session and round; True when it started a new session."""
        new = session != self.session
        if new and self.session:
            self.left.append(self.session)
        self.session, self.round = session, round_
        return new

    def channel_verdict(self, sender: str, session: int, robot: str, round_: int) -> bool:
        """Whether a process role on the channel (of another robot than the player's: the node drops its
        own robot's) is of the current session and round; MalformedInput for a forged sender (this node's
        own name on another robot's role included) or another session."""
        if self.session == 0:
            return False                          # no session to compare with yet
        check_role_sender(self.engine, sender, robot)
        if session != self.session:
            raise MalformedInput(f'ignored a process role of {_name(robot)} of session {session} (following '
                                 f'session {self.session})', kind='other session')
        return round_ == self.round


def check_role_sender(engine: str, sender: str, robot: str) -> None:
    """MalformedInput ``forged sender`` unless a process role of ``robot`` comes from its node or the engine."""
    if sender != engine and not node_of_robot(sender, robot):
        raise MalformedInput(f'ignored a process role of {_name(robot)} sent by {_name(sender)}: neither a node of '
                             f'that robot nor the role engine {engine}', kind='forged sender')


def engine_channel_verdict(engine: str, session: int, sender: str, msg_session: int, robot: str) -> bool:
    """Whether the engine (name ``engine``, session ``session``) takes a process role from the channel:
    False for its own; MalformedInput for another session or a sender that is not the robot's node."""
    if sender == engine:
        return False
    if not node_of_robot(sender, robot):
        raise MalformedInput(f'ignored a process role of {_name(robot)} sent by {_name(sender)}: not a node of '
                             'that robot', kind='forged sender')
    if msg_session != session:
        raise MalformedInput(f'ignored a process role of {_name(robot)} of session {msg_session} (this engine '
                             f'runs session {session})', kind='other session')
    return True


def check_announcement_sender(sender: str, robot: str) -> None:
    """MalformedInput ``forged sender`` unless a player announcement comes from a node of its robot."""
    if not node_of_robot(sender, robot):
        raise MalformedInput(f'ignored an announcement of {_name(robot)} sent by {_name(sender)}: not a node of '
                             'that robot', kind='forged sender')
