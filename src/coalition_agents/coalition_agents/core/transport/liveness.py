"""Which teammates are alive: their sessions and their silence (no ROS).

Issue 16 item 5: a helper committed to a crashed leader never released it, a leader waited for or
kept a dead helper, and a restarted agent could not be told from its earlier self. Both sides of
a coalition therefore follow each other here:

* Sessions. Every batch carries its sender's session, a random non-zero id its agent draws at
  start (:func:`new_session`). :meth:`PeerLiveness.heard` follows the current session of every
  teammate: a new session of a known teammate means it *restarted* -- its earlier self and
  everything that self held (commitments, offers, negotiations) is gone -- and a batch of a session
  it has left is *stale* and dropped. Session 0 (a tool's batch) is accepted, judging nothing,
  only while the teammate's own session is unknown; after that it is out of session (dropped).
  Per batch this is one dict lookup and one dict update (the whole per-message cost). Sessions are
  not authentication: a forger who claims a new session makes the teammate look restarted (issue
  16 item 9: the wheels have no DDS security).
* Silence. The teammates a robot works with are *watched* (the life cycle says which: its leader,
  its helpers, the helpers it negotiates with). A watched teammate from which no batch has come for
  ``silence_s`` (since the later of its last batch and the start of the watch) is presumed dead --
  reported once, until it is heard again (then reported back). Each robot sends a watched teammate
  a heartbeat (an empty batch) when nothing else went to it for ``heartbeat_s``, so a live teammate
  is never silent for long. Time this robot did not check (its process was busy for more than
  ``stall_s``) is not counted against anyone, as in the reliable channel: their batches wait unread.

Choices (the paper assumes robots never fail): the silence bound is a parameter
(``liveness_timeout``; 0 = never presume), at least twice the heartbeat period. A teammate is
judged only while watched, so an idle team sends nothing.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable

from collab_tools.core.session_following import new_session

from ..errors import ConfigError

#: what :meth:`PeerLiveness.heard` makes of a batch
CURRENT, FIRST, RESTARTED, STALE = 'current', 'first', 'restarted', 'stale'


@dataclass(frozen=True)
class LivenessCheck:
    """``heartbeats``: watched teammates to send an empty batch now; ``lost``: watched teammates newly
    presumed dead (with their silence, s); ``back``: teammates presumed dead that were heard again."""

    heartbeats: tuple[str, ...] = ()
    lost: tuple[tuple[str, float], ...] = ()
    back: tuple[str, ...] = ()


@dataclass
class LivenessStats:
    restarts: int = 0        # teammates seen with a new session
    stale_batches: int = 0   # batches of a session its sender has left, or without one (dropped)
    presumed_dead: int = 0   # watched teammates presumed dead after silence_s
    heartbeats: int = 0      # empty batches asked for
    stalls: int = 0          # checks after a gap longer than stall_s (not counted against teammates)


@dataclass
class PeerLiveness:
    """One robot's view of its teammates' sessions and silence (module docstring)."""

    robot: str
    silence_s: float
    heartbeat_s: float
    stall_s: float = 0.5
    #: teammate -> its current session; teammate -> when its last batch came
    sessions: dict[str, int] = field(default_factory=dict)
    heard_at: dict[str, float] = field(default_factory=dict)
    stats: LivenessStats = field(default_factory=LivenessStats)

    def __post_init__(self) -> None:
        for name in ('silence_s', 'heartbeat_s', 'stall_s'):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value >= 0:
                raise ConfigError(f'{name}: must be a number >= 0 (got {value!r})')
        if self.heartbeat_s <= 0:
            raise ConfigError(f'heartbeat_s: must be > 0 (got {self.heartbeat_s!r})')
        self._left: dict[str, set[int]] = {}        # teammate -> sessions it has left
        self._watched: dict[str, float] = {}        # teammate -> since when it is watched
        self._sent_at: dict[str, float] = {}        # teammate -> when the last batch went to it
        self._dead: dict[str, float] = {}           # teammate -> when it was presumed dead
        self._last_check: float | None = None

    # --- per batch -------------------------------------------------------------------------------
    def heard(self, sender: str, session: int, now: float) -> str:
        """A batch of ``sender`` with ``session`` arrived at ``now``: :data:`CURRENT`, :data:`FIRST`
        (its first session seen), :data:`RESTARTED` (a new session: its earlier self is gone) or
        :data:`STALE` (a session it has left: drop the batch)."""
        if self.sessions.get(sender) == session:
            self.heard_at[sender] = now
            return CURRENT
        if not session:  # no session: a tool's batch, accepted until the teammate's own session is known
            if sender in self.sessions:
                self.stats.stale_batches += 1
                return STALE
            return CURRENT
        if session in self._left.get(sender, ()):
            self.stats.stale_batches += 1
            return STALE
        known = self.sessions.get(sender)
        self.sessions[sender] = session
        self.heard_at[sender] = now
        if known is None:
            return FIRST
        self._left.setdefault(sender, set()).add(known)
        self.stats.restarts += 1
        return RESTARTED

    def sent(self, recipient: str, now: float) -> None:
        """A batch went to ``recipient`` (no heartbeat is needed before ``heartbeat_s`` from now)."""
        self._sent_at[recipient] = now

    # --- periodic --------------------------------------------------------------------------------
    def presumed_dead(self) -> frozenset[str]:
        return frozenset(self._dead)

    def silence(self, robot: str, now: float) -> float:
        """How long a watched ``robot`` has been silent (0 if it is not watched)."""
        since = self._watched.get(robot)
        return 0.0 if since is None else now - max(since, self.heard_at.get(robot, since))

    def check(self, now: float, watched: Iterable[str]) -> LivenessCheck:
        """Follow the ``watched`` teammates at ``now``: heartbeats due, teammates newly presumed
        dead, presumed-dead ones heard again (see :class:`LivenessCheck`)."""
        if self._last_check is not None and now - self._last_check > self.stall_s:
            gap = now - self._last_check  # this robot was not listening: their batches wait unread
            self.stats.stalls += 1
            self._watched = {robot: since + gap for robot, since in self._watched.items()}
            for robot in self._watched:
                if robot in self.heard_at and robot not in self._dead:
                    self.heard_at[robot] += gap
        self._last_check = now
        back = tuple(robot for robot, when in self._dead.items() if self.heard_at.get(robot, -1.0) > when)
        for robot in back:
            del self._dead[robot]
        current = set(watched)
        current.discard(self.robot)
        self._watched = {robot: self._watched.get(robot, now) for robot in current}
        heartbeats, lost = [], []
        for robot, since in self._watched.items():
            if now - self._sent_at.get(robot, -1e18) >= self.heartbeat_s:
                heartbeats.append(robot)
            if self.silence_s > 0 and robot not in self._dead:
                silent = now - max(since, self.heard_at.get(robot, since))
                if silent >= self.silence_s:
                    self._dead[robot] = now
                    lost.append((robot, silent))
        self.stats.heartbeats += len(heartbeats)
        self.stats.presumed_dead += len(lost)
        return LivenessCheck(tuple(heartbeats), tuple(lost), back)


__all__ = ['CURRENT', 'FIRST', 'LivenessCheck', 'LivenessStats', 'PeerLiveness', 'RESTARTED', 'STALE', 'new_session']
