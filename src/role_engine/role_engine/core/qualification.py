"""Agent evaluation: the qualification matrix Q = lambda F_gp + F_conf (Eq. 13-15, Algorithm 3 lines 1-22).

``F_gp`` (Eq. 14) comes from whoever refines the process role: an *evaluator* callable
``evaluate(agent, role, initial_trajectory, robot_env) -> ProcessRoleEvaluation`` that
returns the (possibly optimised) trajectory and its prior cost. The GP planner plugs in
here; until then :func:`path_length_evaluator` keeps the initial trajectory and uses its
length. ``F_conf`` (Eq. 15) is computed here from the trajectory and the robot type's
SDF: the arc-length line integral of the workspace cost ``c`` (the hinge of Eq. 21).

Between states the trajectory is densified by cubic Hermite interpolation
(:mod:`.trajectory`, the GP prior's mean interpolation), so thin obstacles between two
states are not skipped.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from .errors import RoleEngineError
from .sdf import SignedDistanceField
from .trajectory import check_trajectory, densify

if TYPE_CHECKING:
    from .environment import RobotEnvironment
    from .negotiation import Agent, NegotiationResult, Role


@dataclass
class ProcessRoleEvaluation:
    """An evaluator's answer: the process role to use and its prior cost F_gp (Eq. 14)."""

    trajectory: np.ndarray
    prior_cost: float
    iterations: int = 0


Evaluator = Callable[['Agent', 'Role', np.ndarray, 'RobotEnvironment'], ProcessRoleEvaluation]


def hinge_cost(distance: np.ndarray, epsilon: float) -> np.ndarray:
    """Eq. 21: c(z) = epsilon - d(z) where d(z) <= epsilon, else 0."""
    distance = np.asarray(distance, dtype=float)
    return np.where(distance <= epsilon, epsilon - distance, 0.0)


def conflict_cost(trajectory: np.ndarray, total_time: float, sdf: SignedDistanceField, epsilon: float, *,
                  body_radius: float = 0.0, samples_per_interval: int = 4) -> float:
    """Eq. 15: integral over time of c(x(t)) * |dx/dt| (arc-length parameterised obstacle cost).

    ``sdf`` is the robot type's configuration-space SDF (``body_radius`` 0), or a
    workspace SDF with the disc's ``body_radius`` subtracted from the distance.
    """
    if not (math.isfinite(total_time) and total_time > 0):
        raise RoleEngineError(f'total_time: must be a finite number > 0 s (got {total_time})')
    if not (math.isfinite(epsilon) and epsilon >= 0):
        raise RoleEngineError(f'epsilon: must be a finite number >= 0 m (got {epsilon})')
    times, positions, velocities = densify(trajectory, total_time, samples_per_interval)
    cost = hinge_cost(sdf.distance(positions) - body_radius, epsilon)
    return float(np.trapezoid(cost * np.hypot(*velocities.T), times))


def path_length_evaluator(agent, role, trajectory: np.ndarray, robot_env) -> ProcessRoleEvaluation:
    """Stand-in F_gp until the GP planner plugs in: keep the initial path, cost = its length in m."""
    del agent, role, robot_env
    states = check_trajectory(trajectory)
    return ProcessRoleEvaluation(states, float(np.sum(np.hypot(*np.diff(states[:, :2], axis=0).T))))


def qualification(prior_cost: float, conflict: float, lam: float) -> float:
    """Eq. 13: q = lambda * F_gp + F_conf."""
    return lam * prior_cost + conflict


@dataclass
class QualificationResult:
    """Q with its two parts (m x n; inf where no initial path exists) and the process roles."""

    q: np.ndarray
    prior: np.ndarray
    conflict: np.ndarray
    trajectories: dict[tuple[int, int], np.ndarray]
    evaluations: dict[tuple[int, int], ProcessRoleEvaluation]


def qualification_matrix(negotiation: NegotiationResult, *, evaluate: Evaluator = path_length_evaluator,
                         lam: float = 1.0, epsilon: float = 0.05,
                         samples_per_interval: int = 4) -> QualificationResult:
    """Evaluate every agent for every role it can reach (Algorithm 3, lines 1-22)."""
    if not (math.isfinite(lam) and lam >= 0):
        raise RoleEngineError(f'lambda: must be a finite number >= 0 (got {lam})')
    m, n = len(negotiation.agents), len(negotiation.roles)
    q = np.full((m, n), math.inf)
    prior = np.full((m, n), math.inf)
    conflict = np.full((m, n), math.inf)
    trajectories, evaluations = {}, {}
    for (i, j), initial in negotiation.initial_trajectories.items():
        agent, role = negotiation.agents[i], negotiation.roles[j]
        robot_env = negotiation.robot_envs[agent.robot_type.name]
        evaluation = evaluate(agent, role, initial, robot_env)
        states = check_trajectory(evaluation.trajectory)
        prior_cost = float(evaluation.prior_cost)
        if math.isnan(prior_cost):
            raise RoleEngineError(f'evaluator: prior cost of {agent.name} -> {role.name} is NaN')
        prior[i, j] = prior_cost
        conflict[i, j] = conflict_cost(states, negotiation.total_time, robot_env.sdf, epsilon,
                                       samples_per_interval=samples_per_interval)
        q[i, j] = qualification(prior_cost, conflict[i, j], lam)
        trajectories[(i, j)] = states
        evaluations[(i, j)] = evaluation
    return QualificationResult(q, prior, conflict, trajectories, evaluations)
