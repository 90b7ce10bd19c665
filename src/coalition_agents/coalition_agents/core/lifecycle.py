"""One robot's coalition life cycle (paper Algorithm 2, Section V), as a pure state machine.

:class:`~.agent.SchemaAgent` reasons (requests, offers, executable coalitions);
:class:`AgentLifecycle` decides what the robot does with it, driven by events that carry the
time (``on_tick``, ``reasoning_step``, ``on_message``, ``on_stream_timer``,
``on_teammate_status``) and acting through two ports: :class:`LifecyclePort` (status, velocity
commands, log, "done", "reason again") and :class:`CoalitionChannel` (negotiation, release,
streaming). The schema_agent node implements both on ROS; unit tests use fakes.

States (:class:`~.agent_state.AgentState`): a robot with a task goes IDLE -> SEARCHING ->
NEGOTIATING -> COMMITTED (-> COMPLETED when it drives its task to the goal) or FAILED; a robot
without one goes IDLE -> HELPING (first request) -> COMMITTED (a leader's commitment) -> IDLE
(released from every coalition it helps). Its state is its own task's: helping others never
changes a leader's state (it keeps searching for its own coalition).

* Start: once every teammate's agent listens on the channel (or after ``team_wait``) a robot with
  a task starts the search.
* Settle rule: it negotiates its least-cost coalition once it has an executable coalition whose
  cost has not improved for ``settle_time`` (no cheaper coalition came from the offers since), or
  at ``search_time`` at the latest (``settle_time`` >= ``search_time``: always the whole search
  time, the paper's rule). The moment the first executable coalition appears is reported
  (``coalition_found``), so "found" and "formed" are both in the status.
* Negotiation fallback: the candidates are the cheapest coalition per set of members, in
  non-descending cost; if one helper refuses or cannot be reached, the next. None left: FAILED
  (a driving leader searches again instead, robots free up when other tasks end).
* Commitment: the leader keeps the sensors of its coalition active (and those of the answers it
  gives itself, footnote 10). Any robot, a leader too, commits to every coalition its schemas can
  serve at once and declines a conflicting one with the reason (capability sharing:
  :class:`~.coalition_serving.Commitments`); its status lists them all (``commitments``). A leader
  never drops its task for another's coalition; refusals are in its FAILED detail.
* Execution (:class:`~.coalition_runner.CoalitionRunner`): helpers stream what they serve (each
  value once per receiver, whatever number of coalitions it serves); a
  driving leader runs its task's motor schema, a driving helper maintain_relative_position. When
  the MS is done the leader stops, releases its helpers and reports COMPLETED (FAILED after
  ``task_time_limit``).
* Re-forming (``reform_timeout`` > 0; :class:`~.coalition_execution.CoalitionExecution`): when a
  source of the chosen solution has had no current value for ``reform_timeout``, the leader stops,
  releases the coalition and searches again without the helpers that stopped, at most
  ``max_reforms`` times, then reports FAILED.
* Dead and restarted teammates (:mod:`.teammate_faults`, :mod:`.transport.liveness`): a helper
  releases a leader that went silent or restarted; a leader re-forms without a dead helper.
* ``exit_when_done``: the port's ``finish`` once the coalition is set up or failed (a driving
  leader: once its task is completed or failed and the robots in ``exit_after`` report theirs
  too) / the helper released.
"""
from __future__ import annotations

import math
from typing import Sequence

from .agent import FeasibleCoalition, SchemaAgent
from .agent_state import AgentState, StatusReport
from .coalition_execution import CoalitionExecution, ExecutionCheck
from .coalition_ports import CoalitionChannel, LifecyclePort
from .coalition_runner import CoalitionRunner
from .coalition_serving import Commitments
from .errors import CoalitionError
from .information_values import ValueUnavailable
from .motor_schema import STOP
from .settings import AgentSettings
from .teammate_faults import TeammateFaults
from .transport.codec import ChannelMessage, MessageKind
from .transport.commitments import Negotiation
from .transport.reliable_channel import Received


class AgentLifecycle(TeammateFaults):
    """One robot's coalition life cycle (module docstring)."""

    def __init__(self, agent: SchemaAgent, settings: AgentSettings, port: LifecyclePort, channel: CoalitionChannel):
        self.agent, self.settings, self.port, self.channel = agent, settings, port, channel
        self.robot = agent.robot
        self.team = agent.team
        self.runner = CoalitionRunner(agent, settings)
        self.state = AgentState.IDLE
        self.started_at: float | None = None      # the current search's start (every agent: the first tick)
        self.first_clock: float | None = None
        self.task_started_at: float | None = None
        self.found_at: float | None = None
        self.found_cost = 0.0
        self.formed_at: float | None = None
        self.finished_at: float | None = None
        self.helping_since: float | None = None
        self.goal_distance = math.nan
        self.candidates: list[FeasibleCoalition] = []
        self.negotiation: Negotiation | None = None
        self.chosen: FeasibleCoalition | None = None
        self.held = Commitments(agent, settings)  # the coalitions it leads and helps; its admission rule
        channel.admit_with(self.held.admit)
        self.refusals: list[str] = []  # why candidates were refused in this search (the FAILED detail)
        self.execution: CoalitionExecution | None = None
        self.ms_phase = ''
        self.task_complete = False
        self.reforms = 0
        self.attempts = 0
        self.lost_teammates: set[str] = set()
        self.others_done: set[str] = set()
        self.own_done = False
        self.finished = False
        self._best_cost: float | None = None
        self._best_since: float | None = None
        self._last_unavailable = ''
        #: the detail text without and with the motor schema's progress (human text only)
        self._summary = ''
        self._progress = ''

    # --- status ---------------------------------------------------------------------------------
    @property
    def detail(self) -> str:
        return f'{self._summary}; executing {self._progress}' if self._progress else self._summary

    def _note(self, summary: str) -> None:
        self._summary, self._progress = summary, ''

    @property
    def own_active(self) -> bool:
        """Whether the coalition it leads is set up and running (not yet released)."""
        return self.held.own is not None and self.state is AgentState.COMMITTED

    def report(self) -> StatusReport:
        primary = self.held.own if self.agent.task is not None else self.held.primary()
        coalition_id, leader, members, cost = ((primary.coalition_id, primary.leader, primary.members, primary.cost)
                                               if primary is not None else ('', '', (), 0.0))
        formed = self.formed_at if self.agent.task is not None or primary is None else primary.since
        return StatusReport(
            self.robot, self.state, self.settings.task_name, coalition_id, leader, tuple(members), float(cost),
            search_started=self.started_at if self.agent.task is not None else None,
            coalition_found=self.found_at, found_cost=self.found_cost if self.found_at is not None else 0.0,
            coalition_formed=formed, task_finished=self.finished_at,
            potential_solution=0 if self.chosen is None or self.formed_at is None
            else self.chosen.potential_solution.rank + 1,
            reforms=self.reforms, goal_distance=self.goal_distance, requests_sent=self.agent.requests_sent,
            offers_received=self.agent.offers_received, detail=self.detail,
            commitments=tuple(held.report() for held in self.held.held(self.own_active)))

    def publish(self) -> None:
        self.port.publish_status(self.report())

    # --- dynamic settings -----------------------------------------------------------------------
    def set_max_speed(self, value: float) -> None:
        self.runner.set_max_speed(value)

    def set_goal_tolerance(self, value: float) -> None:
        self.runner.set_goal_tolerance(value)

    def set_tick_period(self, value: float) -> None:
        self.runner.tick_period = value

    # --- events -----------------------------------------------------------------------------------
    def on_message(self, message: ChannelMessage, received: Received, now: float) -> None:
        """A message the channel delivered; a malformed one is logged and dropped."""
        try:
            self._handle(message, received, now)
        except (CoalitionError, ValueError) as exc:
            self.port.log('warning', f'{self.robot}: dropped {message}: {exc}')

    def _handle(self, message: ChannelMessage, received: Received, now: float) -> None:
        kind = message.kind
        if kind is MessageKind.REQUEST:
            if self.helping_since is None:
                self.helping_since = now
                if self.state is AgentState.IDLE and self.agent.task is None:
                    self.state = AgentState.HELPING
                    self.publish()
            self.agent.on_request(message.request, message)
            self.port.request_reasoning()
        elif kind is MessageKind.OFFER:
            self.agent.on_offer(message.offer)
            self.port.request_reasoning()
        elif kind is MessageKind.INFORMATION:
            if self.held.accepts(message.coalition_id, message.sender, self.own_active):  # its coalitions' members
                self.runner.stream.update(message.sender, message.instance, dict(message.values), message.message_id,
                                          now)
        elif kind is MessageKind.COMMIT_REQUEST and received.accepted is False:
            self.port.log('warning', f'{self.robot}: declined coalition {message.coalition_id} of {message.sender}: '
                                     f'{received.reason}')
        elif kind is MessageKind.COMMIT_REQUEST and received.accepted:
            self._serve(message, now)
        elif kind in (MessageKind.COMMIT_ACCEPT, MessageKind.COMMIT_REJECT):
            if self.state is AgentState.NEGOTIATING:
                self._lead(now)  # the negotiation may be decided: do not wait for the tick
        elif kind is MessageKind.RELEASE:
            self._released(message.coalition_id, message.sender)

    def _released(self, coalition_id: str, leader: str, why: str = '') -> None:
        """The coalition ``coalition_id`` this robot helps ``leader`` with ended (its RELEASE, or
        the leader was lost: ``why``)."""
        if self.held.release(coalition_id, leader) is None:
            return
        self.port.log('info', f'{self.robot}: released from coalition {coalition_id}' + (f' ({why})' if why else ''))
        if self.agent.task is None and not self.held.serving:
            self.state = AgentState.IDLE
            self.runner.follow = None
            self.port.command(STOP)
        elif self.held.motor_leader() is None:
            self.runner.follow = None
        self._keep_sensors()
        self.publish()
        if self.settings['exit_when_done'] and self.agent.task is None and not self.held.serving:
            self._finish()

    def _serve(self, message: ChannelMessage, now: float) -> None:
        """A COMMIT_REQUEST this robot admitted: it helps that coalition too."""
        first = not self.held.serving
        self.held.serve(message.coalition_id, message.sender, message.members, message.cost, now)
        if self.agent.task is None:
            if first:  # a pure helper's first coalition: what it streamed or followed before is stale
                self.runner.stream.forget()
                self.runner.follow = None
                self.formed_at = now
            self.state = AgentState.COMMITTED
        self._keep_sensors()
        self.port.log('info', f'{self.robot}: committed to coalition {message.coalition_id} of {message.sender} '
                              f"({', '.join(message.members)}, cost {message.cost:g}; "
                              f'{len(self.held.held(self.own_active))} held)')
        self.publish()

    def _keep_sensors(self) -> None:
        searching = self.agent.task is not None and self.state in (AgentState.SEARCHING, AgentState.NEGOTIATING)
        self.held.keep_sensors(searching, self.chosen if self.own_active else None)

    def reasoning_step(self, now: float) -> bool:
        """The agent's inputs changed: evaluate, one ``reasoning_slice`` per step; True while work is left."""
        if self.started_at is None:
            return False  # the periodic tick starts the search
        more = self.agent.tick(now, budget_s=self.settings['reasoning_slice'])
        if self.agent.task is not None and self.state in (AgentState.SEARCHING, AgentState.NEGOTIATING):
            self._lead(now)
        return more

    def on_tick(self, now: float) -> None:
        """The periodic tick: start the search, catch changed readings and deadlines, execute."""
        if self.started_at is None and not self._start(now):
            return
        self.port.request_reasoning()  # readings and deadlines change with time
        if self.agent.task is not None:
            self._lead(now)
            if self.state is AgentState.COMMITTED and self.execution is not None:
                self._execute(now)
        elif self.settings['drive'] and self.state is AgentState.COMMITTED and self.held.motor_leader():
            command, note = self.runner.helper_step(self.held.motor_leader(), now)
            if note:
                self.port.log('info', note)
            if command is not None:
                self.port.command(command)
        elif (self.settings['exit_when_done'] and not self.held.serving and self.helping_since is not None
              and now >= self.helping_since + 3 * self.settings['search_time'] and not self.finished):
            self.agent.keep_only(())
            self._finish()

    def _start(self, now: float) -> bool:
        """Start when every teammate listens on the channel (a request sent before would only be
        retried), or after team_wait without them; False while waiting."""
        if self.first_clock is None:
            self.first_clock = now
        listening = 1 + self.port.teammates_listening()
        team_wait = self.settings['team_wait']
        if listening < len(self.team) and now - self.first_clock < team_wait:
            return False
        if listening < len(self.team):
            self.port.log('warning', f'{self.robot}: {listening} of {len(self.team)} agents on the channel '
                                     f'after {team_wait:g} s; starting anyway')
        self.started_at = now
        self.task_started_at = now
        self.channel.announce()  # teammates learn its (new) session: a restarted robot is told apart
        if self.agent.task is not None:
            self.state = AgentState.SEARCHING
            self.agent.start()
            self.publish()
        return True

    def on_stream_timer(self, now: float) -> None:
        """Send the current value of every instance this robot serves its coalition (helpers; a
        leader serves itself locally)."""
        if self.started_at is None:
            return
        sent: set = set()
        for held in self.held.held(self.own_active):
            for requester, answer, value in self.runner.served_values(held.members, now):
                if (requester, answer) not in sent:  # one value per receiver, whatever it serves
                    sent.add((requester, answer))
                    self.channel.stream(requester, held.coalition_id, answer, value)

    def on_teammate_status(self, robot: str, state: AgentState) -> None:
        if state.finished:
            self.others_done.add(robot)
            self._maybe_finish()

    # --- the search and the negotiation -----------------------------------------------------------
    def _settled(self, now: float) -> bool:
        """Track the cheapest executable coalition; True once it is time to negotiate: it has
        not improved for settle_time, or the search time is over."""
        best = self.agent.cheapest(now)  # not every coalition sorted at every step
        if best is not None:
            cost = best.cost
            if self.found_at is None:
                self.found_at, self.found_cost = now, cost
                self._note(f'search started at {self.started_at:.3f} s; first executable coalition at '
                           f'{now:.3f} s ({now - self.started_at:.3f} s, cost {cost:g})')
                self.port.log('info', f'{self.robot}: {self.detail}')
                self.publish()
            if self._best_cost is None or cost < self._best_cost:
                self._best_cost, self._best_since = cost, now
        if now >= self.started_at + self.settings['search_time']:
            return True
        # Settled only while the coalition is executable now: readings that lapsed for a moment
        # (a busy executor) must not end the search before search_time with nothing to propose.
        return (best is not None and self._best_since is not None
                and now - self._best_since >= self.settings['settle_time'])

    def _lead(self, now: float) -> None:
        if self.state is AgentState.SEARCHING and self._settled(now):
            seen: set = set()
            self.candidates = []
            for coalition in self.agent.coalitions(now):
                if frozenset(coalition.members) not in seen:
                    seen.add(frozenset(coalition.members))
                    self.candidates.append(coalition)
            self.port.log('info', f'{self.robot}: {len(self.candidates)} executable coalition(s) after '
                                  f'{now - self.started_at:.2f} s'
                                  + ''.join(f'\n{c.describe()}' for c in self.candidates[:3]))
            self._propose_next(now)
        elif self.state is AgentState.NEGOTIATING and self.negotiation is not None:
            state = self.negotiation.state(now)
            if state == 'established':
                self._established(now)
            elif state in ('failed', 'expired'):
                self.port.log('warning', f'{self.robot}: coalition {self.negotiation.coalition_id} {state}: '
                                         f'{self.negotiation.rejected}')
                self.refusals += [f'{robot}: {why}' for robot, why in self.negotiation.rejected.items()]
                self.channel.release(self.negotiation.coalition_id, 'negotiation failed')
                self._propose_next(now)

    def _search_again(self, now: float, exclude: Sequence[str] = ()) -> None:
        self.started_at = now
        self.state = AgentState.SEARCHING
        self.found_at = self._best_cost = self._best_since = self.formed_at = None
        self.refusals = []
        self.agent.restart(exclude=exclude)
        self.publish()

    def _propose_next(self, now: float) -> None:
        if (not self.candidates and self.settings['drive'] and self.attempts
                and self.reforms < self.settings['max_reforms']):
            # A driving leader whose candidates were all refused (their robots busy) searches again:
            # robots free up when other tasks end.
            self.reforms += 1
            self.port.log('warning', f'{self.robot}: no coalition could be set up; searching again '
                                     f"({self.reforms}/{self.settings['max_reforms']})")
            self._search_again(now)
            return
        while self.candidates:
            candidate = self.candidates.pop(0)
            if self.lost_teammates.intersection(candidate.members):
                continue  # a member is presumed dead
            self.attempts += 1
            coalition_id = f'{self.robot}/{self.channel.new_id()}'
            self.held.proposing = candidate  # its part in the coalition it proposes (the admission rule)
            negotiation, reason = self.channel.propose(coalition_id, candidate.members, candidate.cost,
                                                       self.settings['hold_seconds'])
            if negotiation is None:
                self.port.log('warning', f'{self.robot}: cannot lead {coalition_id}: {reason}')
                self.refusals.append(f'{self.robot}: {reason}')
                continue
            self.negotiation, self.chosen, self.state = negotiation, candidate, AgentState.NEGOTIATING
            self.publish()
            if negotiation.state(now) == 'established':  # no helpers to wait for
                self._established(now)
            return
        if self._retry_without_lost(now):
            return
        refused = '; '.join(dict.fromkeys(self.refusals[-3:]))
        self._fail(f'no executable coalition could be set up after {now - self.started_at:.2f} s '
                   f'({self.attempts} negotiation(s))' + (f'; refused: {refused}' if refused else ''))

    def _fail(self, why: str) -> None:
        self.state = AgentState.FAILED
        self.held.task_open = False
        self._note(why)
        self.port.log('error', f'{self.robot}: {why}')
        self._keep_sensors()
        self.publish()
        self.own_done = True
        self._maybe_finish()

    def _established(self, now: float) -> None:
        chosen, negotiation = self.chosen, self.negotiation
        self.formed_at = now
        self.state = AgentState.COMMITTED
        self.held.lead(negotiation.coalition_id, chosen.members, chosen.cost, now)
        # Its own sensors, those of the answers it gives itself (footnote 10 self-requests) and
        # those of the coalitions it helps.
        self._keep_sensors()
        self.execution = CoalitionExecution(chosen.lcs, now, self.settings['reform_timeout'] or math.inf)
        start = self.started_at
        found = '' if self.found_at is None else \
            f'first executable coalition at {self.found_at:.3f} s ({self.found_at - start:.3f} s); '
        self._note(f'search started at {start:.3f} s; {found}formed at {now:.3f} s ({now - start:.3f} s); '
                   f'potential solution {chosen.potential_solution.rank + 1}')
        self.port.log('info', f'{self.robot}: coalition {negotiation.coalition_id} established: {chosen.describe()}')
        self.publish()
        if not self.settings['drive']:  # a driving leader is done when its task is
            self.own_done = True
            self._maybe_finish()

    # --- execution ------------------------------------------------------------------------------
    def _execute(self, now: float) -> None:
        """The leader: re-form when the coalition's information stops flowing, else run the MS."""
        runner = self.runner
        check = self.execution.check(now, lambda p, i: runner.streamed(p, i, now) is not None,
                                     lambda s, i: runner.reading(i, now) is not None)
        if check.reform:
            self._reform(now, check)
            return
        if not self.settings['drive']:
            return
        limit = self.settings['task_time_limit']
        if limit > 0 and now - self.task_started_at > limit:
            self._finish_task(now, AgentState.FAILED, f'time limit: {self._progress or self.detail}')
            return
        try:
            step = runner.leader_step(self.chosen, now)
            self.goal_distance = step.goal_distance
            self._phase(step.phase, step.progress)
            command = step.command
        except ValueUnavailable as exc:
            command = STOP
            if str(exc) != self._last_unavailable:
                self._last_unavailable = str(exc)
                self.port.log('warning', f'{self.robot}: motor schema waits: {exc}')
        self.port.command(command)
        if self.task_complete:
            self._finish_task(now, AgentState.COMPLETED, self._progress or self.detail)

    def _phase(self, phase: str, progress: str) -> None:
        if phase == self.ms_phase:
            return
        self.ms_phase = phase
        self.task_complete = phase == 'done'
        self.port.log('info', f'{self.robot}: motor schema {self.agent.task.motor_schema}: {phase} ({progress})')
        self._progress = f'{phase}: {progress}'
        self.publish()

    def _finish_task(self, now: float, state: AgentState, why: str) -> None:
        """The task is over (done, or out of time): stop, release the helpers, report."""
        coalition_id = self.held.own.coalition_id  # type: ignore[union-attr]
        self.port.command(STOP)
        self.channel.release(coalition_id, f'task {state.label}')
        self.execution = None
        self.state = state
        self.held.task_open = False
        self.finished_at = now
        self._note(f'{self._summary}; task {state.label} at {now:.3f} s ({why})')
        self.port.log('info' if state is AgentState.COMPLETED else 'error',
                      f'{self.robot}: task {self.settings.task_name} {state.label}: {why}; '
                      f'coalition {coalition_id} released')
        self._keep_sensors()
        self.publish()
        self.own_done = True
        self._maybe_finish()

    def _reform(self, now: float, check: ExecutionCheck) -> None:
        coalition_id = self.held.own.coalition_id  # type: ignore[union-attr]
        self.port.command(STOP)
        self.port.log('warning', f'{self.robot}: coalition {coalition_id} infeasible for {check.infeasible_for:.2f} s '
                                 f"({'; '.join(check.missing)}): releasing it")
        self.channel.release(coalition_id, 'information stopped: ' + '; '.join(check.missing))
        self.held.own, self.execution, self.chosen, self.negotiation = None, None, None, None
        self.runner.stream.forget()
        self.ms_phase = ''
        if self.reforms >= self.settings['max_reforms']:
            self._fail(f'coalition {coalition_id} lost ({"; ".join(check.missing)}); {self.reforms} re-form(s) used')
            return
        self.reforms += 1
        self.port.log('info', f"{self.robot}: re-forming ({self.reforms}/{self.settings['max_reforms']})"
                              + (f" without {', '.join(check.lost_helpers)}" if check.lost_helpers else ''))
        self._search_again(now, exclude=check.lost_helpers)

    # --- done -------------------------------------------------------------------------------------
    def _maybe_finish(self) -> None:
        if self.settings['exit_when_done'] and self.own_done and self.others_done >= set(self.settings['exit_after']):
            self._finish()

    def _finish(self) -> None:
        if not self.finished:
            self.finished = True
            if self.held.serving:
                self.port.log('warning', f"{self.robot}: finishing (exit_when_done) while it helps coalition(s) "
                                         f"{', '.join(self.held.serving)}: their leaders will see its information stop")
            self.port.finish()


__all__ = ['AgentLifecycle', 'CoalitionChannel', 'LifecyclePort']
