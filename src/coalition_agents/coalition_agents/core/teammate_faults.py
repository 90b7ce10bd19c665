"""What a robot's coalition life cycle does when a teammate it works with dies or restarts (no ROS).

Issue 16 item 5. :mod:`.transport.liveness` tells the channel which teammates went silent (presumed
dead) and which came back with a new session (restarted: their earlier self, and whatever it held,
is gone); :class:`TeammateFaults` is the part of :class:`~.lifecycle.AgentLifecycle` that acts on
it:

* it names the teammates to watch (:meth:`TeammateFaults.watched_teammates`): the leaders of the
  coalitions it helps, the helpers of the coalition it leads while it runs, the helpers it
  negotiates with;
* a helper releases its commitment to a leader that is lost (silent or restarted) -- locally: the
  leader cannot be told -- so a restarted leader is admitted again;
* a leader whose helper is lost re-forms: a running coalition is released and searched again
  without the dead helper (as when its information stops, ``max_reforms`` at most), a negotiation
  with it fails (and the candidates with it are skipped); a search whose helper restarted starts
  again (its offers came from the earlier self); a leader that found nothing while a teammate was
  presumed dead searches again, excluding the dead ones, instead of failing at once, and a
  teammate that comes back (heard again, or restarted) is included again.
"""
from __future__ import annotations

from .agent_state import AgentState
from .coalition_execution import ExecutionCheck


class TeammateFaults:
    """Mixed into :class:`~.lifecycle.AgentLifecycle` (module docstring); it keeps ``lost_teammates``
    (robots presumed dead, excluded from its searches until they are heard again)."""

    lost_teammates: set[str]

    def watched_teammates(self) -> set[str]:
        """The teammates whose silence matters now (the channel's liveness watches them)."""
        watched = {held.leader for held in self.held.serving.values()}
        if self.own_active:
            watched.update(self.held.own.members)
        if self.state is AgentState.NEGOTIATING and self.negotiation is not None:
            watched.update(self.negotiation.helpers)
        watched.discard(self.robot)
        return watched

    def on_teammate_lost(self, robot: str, now: float, why: str, restarted: bool = False) -> None:
        """``robot`` is presumed dead (silent; ``why`` says for how long) or restarted."""
        if restarted:
            self.lost_teammates.discard(robot)
        else:
            self.lost_teammates.add(robot)
        for coalition_id, held in list(self.held.serving.items()):
            if held.leader == robot:  # its leader cannot release it any more: release it here
                self.channel.drop_commitment(coalition_id, robot)
                self._released(coalition_id, robot, f'its leader {why}')
        if self.agent.task is None or self.finished:
            return
        if self.own_active and self.execution is not None and robot in self.held.own.members:
            lost = () if restarted else (robot,)
            self._reform(now, ExecutionCheck(False, (f'{robot} {why}',), lost, 0.0, True))
        elif self.state is AgentState.NEGOTIATING and self.negotiation is not None \
                and robot in self.negotiation.helpers:
            if restarted:  # its offers came from its earlier self: search again, with the new one
                self.channel.release(self.negotiation.coalition_id, f'{robot} restarted')
                self.port.log('info', f'{self.robot}: {robot} restarted during the negotiation; searching again')
                self._search_again(now, exclude=tuple(self.lost_teammates))
            else:
                self.negotiation.rejected.setdefault(robot, why)
                self._lead(now)
        elif restarted:
            self._teammate_returned(robot, now, 'restarted')

    def on_teammate_back(self, robot: str, now: float) -> None:
        """``robot``, presumed dead, was heard again (its process had only stalled)."""
        if robot in self.lost_teammates:
            self.lost_teammates.discard(robot)
            self._teammate_returned(robot, now, 'heard again')

    def _teammate_returned(self, robot: str, now: float, how: str) -> None:
        if self.agent.task is None or self.finished:
            return
        if self.state is AgentState.SEARCHING:  # its offers (or its exclusion) are out of date
            self.port.log('info', f'{self.robot}: {robot} {how}; searching again')
            self._search_again(now, exclude=tuple(self.lost_teammates))
        elif self.state is AgentState.FAILED and self.finished_at is None \
                and self.reforms < self.settings['max_reforms']:
            self.reforms += 1
            self.port.log('info', f"{self.robot}: {robot} {how}; searching again "
                                  f"({self.reforms}/{self.settings['max_reforms']})")
            self.own_done = False
            self.held.task_open = True
            self._search_again(now, exclude=tuple(self.lost_teammates))

    def _retry_without_lost(self, now: float) -> bool:
        """No candidate left while teammates are presumed dead: search again without them (True)."""
        if not self.lost_teammates or self.reforms >= self.settings['max_reforms']:
            return False
        self.reforms += 1
        self.port.log('warning', f"{self.robot}: no coalition without {', '.join(sorted(self.lost_teammates))} "
                                 f"(presumed dead); searching again ({self.reforms}/{self.settings['max_reforms']})")
        self._search_again(now, exclude=tuple(self.lost_teammates))
        return True


__all__ = ['TeammateFaults']
