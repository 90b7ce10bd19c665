"""Sessions and senders on the role topics (issue 16 item 4): which messages a role node follows.

Every role engine picks a *session* id when it starts
(:func:`collab_tools.core.session_following.new_session`) and puts its node name (the *sender*)
and the session into every assignment and initial process role; a player puts its own node name
and the engine session it plays into every process role it publishes. Round counters count within
a session: a restarted engine starts a new session at round 1.

A player follows the current session of its engine (:class:`SessionFollower`) with the shared
rules of :mod:`collab_tools.core.session_following`, chosen for assignments:

* an assignment whose sender is not its engine is ignored (``other sender``), one without a
  session too (``no session``);
* a later round of the current session is applied; an earlier or equal one is not: it is old,
  dropped quietly as normal traffic (unlike the SGCM guidance, where a repeat is refused);
* an assignment of a session the player has left is ignored (``old session``); one of a session
  it has not seen is a restarted engine: it is applied and replaces the current one *at once*,
  which is left for good, so a restarted engine's round 1 is not lost behind the old round 5;
* a round more than :data:`MAX_ROUND_JUMP` ahead of the current one, or a new session's first
  round outside 1 .. :data:`MAX_ROUND_JUMP` (a player without a session too), is refused
  (``round jump``): one forged round 2^32-1 cannot make every later round look old. A player may
  miss rounds (the latched assignment keeps only the newest, a restarted player sees the current
  round first), so the next round cannot be required to be +1; an engine opens a round per
  renegotiation (each excluding or re-including a robot), a few per task, so a jump of 64 is far
  beyond a real one and far below the counter's range.

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

from enum import Enum

from collab_tools.core.input_checks import MalformedInput
from collab_tools.core.session_following import FollowingRules, NotFollowed, Refusal, SessionFollowing

#: Largest accepted step of the round counter within a session (and first round of a new one).
MAX_ROUND_JUMP = 64
#: A new engine session ends the previous one at once; a player never joins a session past its first rounds.
ASSIGNMENT_RULES = FollowingRules(MAX_ROUND_JUMP, ends_others_after=1, joins_session_under_way=False)
#: Characters of a sender or robot name an error message echoes (forged names can be long).
NAME_ECHO = 60


def _name(value: str) -> str:
    return repr(value[:NAME_ECHO] + ('...' if len(value) > NAME_ECHO else ''))


def node_of_robot(sender: str, robot: str) -> bool:
    """Whether the node named ``sender`` (full name) runs in ``robot``'s namespace (``.../<robot>/<node>``)."""
    parts = sender.split('/')
    return len(parts) >= 3 and parts[0] == '' and parts[-2] == robot and bool(robot) and bool(parts[-1])


class Verdict(Enum):
    APPLY = 'apply'          # a new session or a later round: apply it
    OLD = 'old'              # an earlier or equal round of the current session: drop quietly


class SessionFollower(SessionFollowing):
    """A player's view of its engine's sessions (module docstring). ``engine``: the engine node's full name."""

    def __init__(self, engine: str):
        super().__init__(engine, ASSIGNMENT_RULES)
        self.engine = engine

    @property
    def round(self) -> int:
        """The current session's last round applied (0: none)."""
        return self.last_round

    def check_assignment(self, sender: str, session: int, round_: int) -> Verdict:
        """What to do with an assignment (nothing changes until :meth:`follow`); MalformedInput when refused."""
        try:
            self.judge(sender, session, round_)
        except NotFollowed as refused:
            if refused.reason is Refusal.ALREADY_HEARD:
                return Verdict.OLD
            raise self._malformed(refused) from None
        return Verdict.APPLY

    def follow(self, session: int, round_: int) -> bool:
        """Take an applied assignment's session and round; True when it started a new session."""
        return self.take(session, round_).new_session

    def _malformed(self, refused: NotFollowed) -> MalformedInput:
        session, round_ = refused.session, refused.round_number
        if refused.reason is Refusal.OTHER_SENDER:
            return MalformedInput(f'ignored an assignment from {_name(refused.sender)}: not the role engine '
                                  f'{self.engine}', kind='other sender')
        if refused.reason is Refusal.NO_SESSION:
            return MalformedInput('ignored an assignment without a session (session 0)', kind='no session')
        if refused.reason is Refusal.ENDED_SESSION:
            return MalformedInput(f'ignored an assignment (round {round_}) of session {session}, which this player '
                                  f'has left for session {self.session}', kind='old session')
        if refused.reason is Refusal.ROUND_JUMP:
            return MalformedInput(f'ignored assignment round {round_}: more than {MAX_ROUND_JUMP} rounds after '
                                  f'round {self.round} of this session', kind='round jump')
        # OUT_OF_ORDER: a new session's first round is not 1 .. MAX_ROUND_JUMP (an assignment never ends a task)
        return MalformedInput(f'ignored assignment round {round_} of a new session {session}: a session starts '
                              f'at round 1 (at most {MAX_ROUND_JUMP} when rounds were missed)', kind='round jump')

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
