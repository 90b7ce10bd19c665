"""Episodes rebuilt from what the nodes published (Guidance and FollowerReport), so the
simulation's tables are computed from the recorded bags with the same accounting as
the abstract game (see episode.py).

Input per round, in order: the leader's guidance (round state as she estimated it from
the camera, her move and its outcome) and the follower's report (his move and outcome);
the end of the task is the guidance with ``task_complete`` or a ``status``.

Rounds are numbered within a leader session (sgcm.core.sessions): a leader that restarted
begins again at round 1. :func:`rounds_in_order` puts a recording's rounds in the order they
were played -- sessions in the order they first appear, rounds in order within each, a report
paired with the round of the session it answers -- and keeps only the messages of the sender
that ended the task (a forged or stray publisher on the topic is not part of the episode).
Recordings from before sessions existed (no ``session`` fields) read as one session.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .episode import EpisodeResult, RoundRecord
from .rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel


@dataclass(frozen=True)
class LoggedRound:
    round: int
    state: np.ndarray             # at the round's start (leader's estimate)
    leader_action: int
    leader_succeeded: bool
    recommended_action: int
    follower_action: int | None   # None: no report recorded for this round
    follower_succeeded: bool
    follower_deviated: bool
    planning_seconds: float = 0.0
    predicted_leader_value: float | None = None
    predicted_follower_value: float | None = None


def episode_from_log(model: RearrangementModel, method: str, rounds: list[LoggedRound],
                     final_state: np.ndarray, complete: bool, stuck: bool) -> EpisodeResult:
    """Stage-wise utilities of logged rounds: r(next observed state) - both attempted costs."""
    records = []
    for index, logged in enumerate(rounds):
        next_state = rounds[index + 1].state if index + 1 < len(rounds) else final_state
        state = logged.state
        leader_cost = 0.0
        if logged.leader_action != EMPTY and (logged.leader_succeeded or model.task.charge_failed_actions):
            leader_cost = float(model.cost(state, LEADER, logged.leader_action))
        after_leader = (model.apply(state, LEADER, logged.leader_action)
                        if logged.leader_succeeded and model.can_apply(state, LEADER, logged.leader_action)
                        else state)
        follower = EMPTY if logged.follower_action is None else logged.follower_action
        follower_cost = 0.0
        if follower != EMPTY and model.can_apply(after_leader, FOLLOWER, follower) and (
                logged.follower_succeeded or model.task.charge_failed_actions):
            follower_cost = float(model.cost(after_leader, FOLLOWER, follower))
        reward = float(model.reward(next_state))
        records.append(RoundRecord(
            round=logged.round, state=state.tolist(), reward=reward,
            leader_action=model.describe(LEADER, logged.leader_action),
            leader_succeeded=logged.leader_succeeded,
            recommended_action=model.describe(FOLLOWER, logged.recommended_action) if method == 'sgcm' else '',
            follower_action=model.describe(FOLLOWER, follower), follower_succeeded=logged.follower_succeeded,
            follower_deviated=logged.follower_deviated, leader_cost=leader_cost, follower_cost=follower_cost,
            stage_utility=reward - leader_cost - follower_cost,
            predicted_leader_value=logged.predicted_leader_value,
            predicted_follower_value=logged.predicted_follower_value,
            planning_seconds=logged.planning_seconds, next_state=np.asarray(next_state).tolist()))
    return EpisodeResult(method, completed=complete, stuck=stuck, rounds=len(rounds), records=records,
                         final_state=np.asarray(final_state).tolist())


def is_final(guidance: Any) -> bool:
    """The guidance that ends the task."""
    return bool(guidance.task_complete or guidance.status)


def rounds_in_order(guidance: Iterable[Any], reports: Iterable[Any]) -> tuple[list[tuple[Any, Any]], Any]:
    """([(round guidance, its report or None)] in the order played, the final guidance or None); see the
    module docstring. Messages are Guidance / FollowerReport as recorded (ROS or bag objects)."""
    guidance = list(guidance)
    finals = [g for g in guidance if is_final(g)]
    final = finals[-1] if finals else None
    leader = getattr(final, 'sender', '') if final is not None else ''
    sessions: dict[int, dict[int, Any]] = {}          # in the order of first appearance
    for g in guidance:
        if is_final(g) or (leader and getattr(g, 'sender', '') != leader):
            continue
        sessions.setdefault(getattr(g, 'session', 0), {})[g.round] = g
    answered = {(getattr(r, 'leader_session', 0), r.round): r for r in reports}
    rounds = [(rounds_of[number], answered.get((session, number)))
              for session, rounds_of in sessions.items() for number in sorted(rounds_of)]
    return rounds, final
