"""Reading a recorded coalition run: the agents' statuses and the channel traffic from its bag.

The recorder of a simulated run keeps ``/coalition/channel``, the bundle topic
``/coalition/bundles`` (every batch the agents send, AgentMessageBundle), the batch topic
``/coalition/batches`` (single batches from tools; older bags: every batch, and before that every
robot's inbox ``/coalition/channel/<robot>``) and every ``/<robot>/coalition`` status (AgentStatus);
:func:`read_coalition_bag` turns them into a :class:`CoalitionRun`, and the functions below
measure it (from the agents' own stamps: a status is stamped when it is published, a channel
message when it leaves the link model, i.e. after its sampled delay):

Statuses are read through their typed fields (``AgentStatus.state`` as
:class:`~..core.agent_state.AgentState`, the search's stamps), never through ``detail`` (human
text only). A zero stamp means "not (yet)" and is read as None.

* :func:`leader_timeline` -- a leader's search, as the paper's Fig. 9 measures it:

  - search start: the leader's ``search_started`` stamp (in every status after the start, so a
    recorder that subscribed late still has it), else its first SEARCHING status;
  - found: its ``coalition_found`` stamp, when the agent first instantiated an executable coalition
    (the paper's "time to find the coalition solution"). Without it, the first offer that, with
    the earlier ones, covers the members of the coalition it later set up;
  - formed: the leader's first COMMITTED status (negotiation done). The node negotiates once its
    cheapest coalition has not improved for ``settle_time``, or at ``search_time`` at the latest:
    formed - found is settle_time plus the negotiation's round trips.

* :func:`commitments`, :func:`conflicting_commitments`, :func:`shared_commitments`,
  :func:`commitment_check` -- which coalitions each robot held, and whether it held several at
  once that conflict. A robot may serve several coalitions at once where its schemas can serve
  them together (capability sharing: the same reading, the same communicated information); each
  status lists every coalition the robot holds and what its schemas do for each (``commitments``,
  ``uses``), and the core's rule (:func:`~..core.coalition_sharing.conflict`: one motor schema at a
  time, an aimed sensor on one referent) is applied to them from outside: pairs it refuses are
  conflicts, the others sharing. A status without that list (older bags) counts as holding its one
  ``coalition_id``: a new coalition id without a releasing status in between is a conflict;
* :func:`message_counts`, :func:`kind_totals` -- the channel traffic (Fig. 9's lower plots).
* :func:`coalition_outcome` -- the report's line for a bag (registered with scripts/report through the
  ament index resource ``collab_report_plots``): each leader's coalition, its cost and when it formed.
"""
from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from ..core.agent_state import AgentState
from ..core.coalition_sharing import CoalitionPart, conflicting_pairs
from ..core.transport.batch_columns import message_rows
from ..core.transport.codec import MessageKind

CHANNEL = '/coalition/channel'
#: the team's batch topic (every agent's batches, AgentMessageBatch columns); older bags have one
#: inbox topic per robot, ``/coalition/channel/<robot>``, of nested batches (read too)
BATCHES = '/coalition/batches'
#: the team's bundle topic: every batch the agents of one process send in one step (AgentMessageBundle)
BUNDLES = '/coalition/bundles'
STATUS_TYPE = 'coalition_interfaces/msg/AgentStatus'
#: States that release a robot from the coalition it was committed to.
RELEASED = (AgentState.IDLE, AgentState.FAILED, AgentState.SEARCHING)


def status_topic(robot: str) -> str:
    return f'/{robot}/coalition'


@dataclass(frozen=True)
class CommitmentRecord:
    """One entry of a status's ``commitments``: a coalition held, and what the robot's schemas do for it."""

    coalition_id: str
    leader: str
    members: tuple[str, ...] = ()
    uses: tuple[str, ...] = ()


@dataclass(frozen=True)
class StatusRecord:
    """One AgentStatus; stamps in s on the agent's clock, None where the message has a zero stamp."""

    stamp: float
    robot: str
    state: AgentState
    task: str
    coalition_id: str
    leader: str
    members: tuple[str, ...]
    cost: float
    detail: str = ''
    search_started: float | None = None
    coalition_found: float | None = None
    found_cost: float = 0.0
    coalition_formed: float | None = None
    task_finished: float | None = None
    potential_solution: int = 0
    reforms: int = 0
    #: every coalition held at once (its own first); () in bags of agents without the field
    commitments: tuple[CommitmentRecord, ...] = ()
    #: the agent's session (a restarted agent has a new one); 0 in bags of agents without the field
    session: int = 0

    def parts(self) -> list[CoalitionPart]:
        """The held coalitions as the core's parts (for :func:`~..core.coalition_sharing.conflict`)."""
        return [CoalitionPart.from_texts(self.robot, c.coalition_id, c.leader, c.uses) for c in self.commitments]


@dataclass(frozen=True)
class MessageRecord:
    stamp: float
    sender: str
    receiver: str
    kind: int
    members: tuple[str, ...] = ()
    cost: float = 0.0


@dataclass
class CoalitionRun:
    """The statuses and channel messages of one recorded run, in stamp order."""

    statuses: list[StatusRecord] = field(default_factory=list)
    #: logical channel messages (every message of a batch, every piggybacked ACK as kind 3)
    messages: list[MessageRecord] = field(default_factory=list)
    #: ROS messages on the channel topics (batches, single messages on the shared topic)
    ros_messages: int = 0

    def robots(self) -> list[str]:
        return sorted({s.robot for s in self.statuses})

    def leaders(self) -> list[str]:
        """Robots whose status names a task (they search; the others help)."""
        return sorted({s.robot for s in self.statuses if s.task and s.task != 'none'})

    def of(self, robot: str) -> list[StatusRecord]:
        return [s for s in self.statuses if s.robot == robot]

    def last_session(self, robot: str) -> list[StatusRecord]:
        """``robot``'s statuses since its agent last (re)started (all of them in bags without sessions)."""
        statuses = self.of(robot)
        session = statuses[-1].session if statuses else 0
        return [s for s in statuses if s.session == session] if session else statuses


def _stamp(header) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def _time(value) -> float | None:
    """A builtin_interfaces/Time field in s; None for the zero stamp ("not (yet)")."""
    return None if value.sec == 0 and value.nanosec == 0 else value.sec + value.nanosec * 1e-9


def status_record(msg) -> StatusRecord:
    """The record of one AgentStatus message."""
    return StatusRecord(_stamp(msg.header), msg.robot, AgentState(msg.state), msg.task, msg.coalition_id, msg.leader,
                        tuple(msg.members), float(msg.cost), msg.detail, _time(msg.search_started),
                        _time(msg.coalition_found), float(msg.found_cost), _time(msg.coalition_formed),
                        _time(msg.task_finished), int(msg.potential_solution), int(msg.reforms),
                        tuple(CommitmentRecord(c.coalition_id, c.leader, tuple(c.members), tuple(c.uses))
                              for c in getattr(msg, 'commitments', ())), int(getattr(msg, 'session', 0)))


def _add_batch(run: CoalitionRun, batch) -> None:
    """The logical messages of one AgentMessageBatch of columns (every piggybacked ACK as one)."""
    stamp = _stamp(batch.header)
    run.messages.extend(MessageRecord(stamp, batch.sender, batch.recipient, kind, members, cost)
                        for kind, members, cost in message_rows(batch))
    run.messages.extend(MessageRecord(stamp, batch.sender, batch.recipient, MessageKind.ACK)
                        for _ in batch.acked_ids)


def read_coalition_bag(bag: Path) -> CoalitionRun:
    """Statuses (``/<robot>/coalition``) and channel messages of a recorded run."""
    from collab_tools.core.bag_analysis import read_messages
    run = CoalitionRun()
    for topic, _, msg in read_messages(Path(bag)):
        if topic in (CHANNEL, BATCHES, BUNDLES) or topic.startswith(CHANNEL + '/'):  # + old inboxes
            run.ros_messages += 1
            stamp = _stamp(msg.header)
            if hasattr(msg, 'batches'):  # an AgentMessageBundle: its batches, each stamped when it left the link
                for batch in msg.batches:
                    _add_batch(run, batch)
            elif hasattr(msg, 'kinds'):  # an AgentMessageBatch of columns, stamped when it left the link
                _add_batch(run, msg)
            elif hasattr(msg, 'acked_ids'):  # an older bag's AgentMessageBatch of nested messages
                run.messages.extend(MessageRecord(stamp, m.sender, m.receiver, int(m.kind), tuple(m.members),
                                                  float(m.cost)) for m in msg.messages)
                run.messages.extend(MessageRecord(stamp, msg.sender, msg.recipient, MessageKind.ACK)
                                    for _ in msg.acked_ids)
            else:
                run.messages.append(MessageRecord(stamp, msg.sender, msg.receiver, int(msg.kind),
                                                  tuple(msg.members), float(msg.cost)))
        elif topic.endswith('/coalition') and hasattr(msg, 'state'):
            run.statuses.append(status_record(msg))
    run.statuses.sort(key=lambda s: s.stamp)
    run.messages.sort(key=lambda m: m.stamp)
    return run


@dataclass(frozen=True)
class LeaderTimeline:
    """One leader's search: its stamps (s, its own clock) and the coalition it set up."""

    robot: str
    search_start: float | None
    found: float | None
    formed: float | None
    #: its last state's label ('committed', ...), 'absent' without any status
    state: str
    members: tuple[str, ...]
    cost: float | None
    coalition_id: str

    @property
    def found_s(self) -> float | None:
        return None if self.found is None or self.search_start is None else self.found - self.search_start

    @property
    def formed_s(self) -> float | None:
        return None if self.formed is None or self.search_start is None else self.formed - self.search_start

    def to_dict(self) -> dict:
        rounded = lambda v: None if v is None else round(v, 4)  # noqa: E731
        return {'robot': self.robot, 'state': self.state, 'members': list(self.members), 'cost': self.cost,
                'coalition_id': self.coalition_id, 'found_s': rounded(self.found_s),
                'formed_s': rounded(self.formed_s)}


def leader_timeline(run: CoalitionRun, leader: str) -> LeaderTimeline:
    """When ``leader`` started searching, found and set up its coalition (see the module docstring)."""
    statuses = run.last_session(leader)  # a restarted leader: its last search
    # The agent's own record of its search start (its first SEARCHING status may be missed by
    # a recorder that subscribes to the latched status topic late), else that status's stamp.
    start = next((s.search_started for s in statuses if s.search_started is not None), None)
    if start is None:
        start = next((s.stamp for s in statuses if s.state is AgentState.SEARCHING), None)
    final = statuses[-1] if statuses else None
    committed = next((s for s in statuses if s.state is AgentState.COMMITTED and s.leader == leader), None)
    found = next((s.coalition_found for s in statuses if s.coalition_found is not None), None)
    if committed is not None and found is None:
        helpers = set(committed.members) - {leader}
        covered: set[str] = set()
        for message in run.messages:
            if message.kind != MessageKind.OFFER or message.receiver != leader:
                continue
            provided = ({message.sender} | set(message.members)) - {leader}
            covered |= provided
            if provided == helpers or helpers <= covered:
                found = message.stamp
                break
        if not helpers:
            found = committed.stamp
    return LeaderTimeline(leader, start, found, None if committed is None else committed.stamp,
                          final.state.label if final else 'absent',
                          committed.members if committed else (), committed.cost if committed else None,
                          committed.coalition_id if committed else '')


def commitments(run: CoalitionRun) -> dict[str, list[str]]:
    """robot -> the distinct coalitions it was committed to, in order (from ``coalition_id`` of its
    COMMITTED statuses and from every status's ``commitments``)."""
    found: dict[str, list[str]] = defaultdict(list)
    for status in run.statuses:
        ids = [c.coalition_id for c in status.commitments]
        if status.state is AgentState.COMMITTED and status.coalition_id:
            ids.insert(0, status.coalition_id)
        for coalition_id in ids:
            if coalition_id and coalition_id not in found[status.robot]:
                found[status.robot].append(coalition_id)
    return dict(found)


def _conflicts(run: CoalitionRun) -> dict[str, dict[tuple[str, str], str]]:
    """robot -> (coalition, coalition) -> why it could not serve both (see the module docstring)."""
    found: dict[str, dict[tuple[str, str], str]] = {}
    for robot in run.robots():
        current = ''
        for status in run.of(robot):
            if status.commitments:
                for a, b, reason in conflicting_pairs(status.parts()):
                    found.setdefault(robot, {}).setdefault((a, b), reason)
                current = status.coalition_id if status.state is AgentState.COMMITTED else ''
            elif status.state is AgentState.COMMITTED and status.coalition_id:
                if current and status.coalition_id != current:
                    found.setdefault(robot, {}).setdefault(
                        (current, status.coalition_id), 'committed to a new coalition without being released')
                current = status.coalition_id
            elif status.state in RELEASED:
                current = ''
    return found


def conflicting_commitments(run: CoalitionRun) -> dict[str, list[str]]:
    """robot -> the coalitions it held at once although they conflict (module docstring), in order."""
    result: dict[str, list[str]] = {}
    for robot, pairs in _conflicts(run).items():
        ids: list[str] = []
        for pair in pairs:
            ids.extend(c for c in pair if c not in ids)
        result[robot] = ids
    return result


def shared_commitments(run: CoalitionRun) -> dict[str, list[str]]:
    """robot -> the coalitions it served at once without a conflict (capability sharing), in order."""
    conflicting = _conflicts(run)
    result: dict[str, list[str]] = {}
    for status in run.statuses:
        if len(status.commitments) < 2:
            continue
        bad = conflicting.get(status.robot, {})
        ids = [c.coalition_id for c in status.commitments]
        for index, a in enumerate(ids):
            for b in ids[index + 1:]:
                if (a, b) not in bad and (b, a) not in bad:
                    held = result.setdefault(status.robot, [])
                    held.extend(c for c in (a, b) if c not in held)
    return result


def commitment_check(run: CoalitionRun) -> dict:
    """The commitments of a run: ``conflicting`` (robot -> coalitions held at once that conflict),
    ``conflict_reasons``, ``shared`` (robot -> coalitions served at once, sharing),
    ``robots_serving_several`` (robots that held two or more coalitions at once) and
    ``max_coalitions_per_robot``."""
    conflicts = _conflicts(run)
    several = {s.robot for s in run.statuses if len(s.commitments) > 1} | set(conflicts)
    return {'conflicting': conflicting_commitments(run),
            'conflict_reasons': {robot: sorted(set(pairs.values())) for robot, pairs in conflicts.items()},
            'shared': shared_commitments(run), 'robots_serving_several': len(several),
            'max_coalitions_per_robot': max([len(s.commitments) for s in run.statuses]
                                            + [1 if s.coalition_id else 0 for s in run.statuses] + [0])}


def message_counts(run: CoalitionRun, robots: Sequence[str], start: float, end: float,
                   bin_s: float) -> dict:
    """Messages each robot sent and received (addressed to it) per time bin after ``start``."""
    if not bin_s > 0:
        raise ValueError(f'bin_s: must be > 0 (got {bin_s})')
    bins = max(1, int(math.ceil((end - start) / bin_s)))
    sent = {robot: [0] * bins for robot in robots}
    received = {robot: [0] * bins for robot in robots}
    for message in run.messages:
        index = int((message.stamp - start) // bin_s)
        if not 0 <= index < bins:
            continue
        if message.sender in sent:
            sent[message.sender][index] += 1
        if message.receiver in received:
            received[message.receiver][index] += 1
    return {'bin_s': bin_s, 'times_s': [round(i * bin_s, 6) for i in range(bins)], 'sent': sent,
            'received': received}


def _kind_name(kind: int) -> str:
    try:
        return MessageKind(kind).text
    except ValueError:
        return str(kind)


def kind_totals(run: CoalitionRun) -> dict[str, int]:
    totals: dict[str, int] = defaultdict(int)
    for message in run.messages:
        totals[_kind_name(message.kind)] += 1
    return dict(totals)



__all__ = ['BATCHES', 'BUNDLES', 'CHANNEL', 'CoalitionRun', 'CommitmentRecord', 'LeaderTimeline', 'MessageRecord', 'RELEASED', 'STATUS_TYPE',
           'StatusRecord', 'commitment_check', 'commitments', 'conflicting_commitments', 'kind_totals',
           'leader_timeline', 'message_counts', 'read_coalition_bag', 'shared_commitments', 'status_record',
           'status_topic']


def coalition_outcome(bag: Path, summary=None):
    """formed (every leader set up a coalition; completed when a driving leader's task ended so),
    each leader's members, cost and time to form; None for a bag without agent statuses."""
    from collab_tools.core.run_outcome import Outcome
    run = read_coalition_bag(bag)
    leaders = run.leaders()
    if not leaders:
        return None
    timelines = [leader_timeline(run, leader) for leader in leaders]
    formed = all(t.formed is not None for t in timelines)
    completed = formed and all(t.state == AgentState.COMPLETED.label for t in timelines)
    parts = []
    for t in timelines:
        if t.formed is None:
            parts.append(f'{t.robot}: no coalition ({t.state})')
        else:
            when = f', formed {t.formed_s:.2f} s after its search started' if t.formed_s is not None else ''
            parts.append(f"{t.robot} with {', '.join(m for m in t.members if m != t.robot) or 'nobody'} "
                         f'(cost {t.cost:g}{when}; now {t.state})')
    return Outcome('coalitions', 'completed' if completed else 'formed' if formed else 'not formed',
                   '; '.join(parts), passed=formed,
                   figures={'leaders': [t.to_dict() for t in timelines], 'messages': len(run.messages)},
                   checks={'formed': formed})


def _register_outcome() -> None:
    from collab_tools.core.run_outcome import register_outcome
    register_outcome('coalitions', {STATUS_TYPE}, coalition_outcome)


_register_outcome()
