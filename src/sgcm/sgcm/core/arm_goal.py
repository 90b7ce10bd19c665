"""A pick_and_place goal in flight, and when to give it up (issue 16 item 5).

An arm's move is a goal of the bridge's ``pick_and_place`` action. When the bridge crashes the
goal's response or result never comes: the leader waited in ``executing`` for over 400 s, the
follower stayed busy. :class:`GoalWatch` gives a goal up when

* its result has not come ``timeout`` s after it was sent, or
* the action server has been missing from the graph for ``server_lost_after`` s meanwhile (a
  killed bridge leaves the graph once DDS notices its participant is gone), or
* a new instance of the action server appeared in the graph meanwhile (an endpoint that was not
  there when the goal was sent: a restarted bridge, which can never finish a goal of the old one;
  the old one may stay listed until its DDS lease ends, 20 s by default, and a restarted simulation
  running as fast as possible may be past the old time before the node hears its clock go back);

both on the steady clock: a crashed bridge stops ``/clock``, so simulated time would never reach
either bound. A given-up move counts as not done; the node's rounds go on (the leader announces
it as failed and plans the next round from the table she sees once the arm and the camera are
back -- the restarted simulation may even have reset the table; the follower reports it). Each
goal has a token, so a late result of a goal given up is ignored.
"""
from __future__ import annotations

from dataclasses import dataclass

#: s (steady): a pick and place takes a few seconds of simulated time; the machine may be 3-5x slow.
GOAL_TIMEOUT = 120.0
#: s (steady) the action server may be missing from the graph while a goal is out.
SERVER_LOST_AFTER = 5.0


@dataclass
class _Goal:
    token: int
    sent_at: float
    servers: frozenset = frozenset()    # the action server's endpoints in the graph when it was sent
    missing_since: float | None = None


class GoalWatch:
    """At most one goal in flight; see the module docstring."""

    def __init__(self, timeout: float = GOAL_TIMEOUT, server_lost_after: float = SERVER_LOST_AFTER):
        self.timeout = timeout
        self.server_lost_after = server_lost_after
        self._goal: _Goal | None = None
        self._tokens = 0
        self.given_up = 0

    @property
    def busy(self) -> bool:
        return self._goal is not None

    def sent(self, now: float, servers: frozenset = frozenset()) -> int:
        """A goal was sent at ``now`` with the action server's endpoints ``servers`` (ids) in the graph; its
        token (any goal still out is forgotten)."""
        self._tokens += 1
        self._goal = _Goal(self._tokens, now, frozenset(servers))
        return self._tokens

    def finished(self, token: int) -> bool:
        """The goal ``token`` has its result (or was refused); False when it is not the goal out (given up)."""
        if self._goal is None or self._goal.token != token:
            return False
        self._goal = None
        return True

    def give_up(self) -> bool:
        """Forget the goal out now (the node knows it is lost); False when there is none."""
        if self._goal is None:
            return False
        self._goal = None
        self.given_up += 1
        return True

    def check(self, now: float, server_ready: bool, servers: frozenset | None = None) -> str | None:
        """Why the goal out is given up now (it is then forgotten), or None. ``servers``: the action
        server's endpoints in the graph now (None: not known)."""
        goal = self._goal
        if goal is None:
            return None
        if server_ready:
            goal.missing_since = None
        elif goal.missing_since is None:
            goal.missing_since = now
        reason = None
        if goal.servers and servers is not None and servers - goal.servers:
            reason = "a new instance of the arm's action server appeared (a restarted bridge cannot finish the goal)"
        elif goal.missing_since is not None and now - goal.missing_since >= self.server_lost_after:
            reason = f'the arm\'s action server left the graph ({now - goal.missing_since:.0f} s without it)'
        elif now - goal.sent_at >= self.timeout:
            reason = f'no result within {self.timeout:g} s'
        if reason is not None:
            self._goal = None
            self.given_up += 1
        return reason
