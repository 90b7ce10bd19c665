"""Central computer: negotiation, qualification and assignment of the initial process roles.

Algorithm 1 lines 1-6 with Algorithm 3: negotiate (feasibility, per-type views, initial
paths), evaluate every reachable agent-role pair (Q = lambda F_gp + F_conf), assign by
GRA, and return each assigned agent's process role. The role-playing loop (lines 7-23)
belongs to the role players.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .assignment import AssignmentResult, group_role_assignment
from .environment import Environment
from .negotiation import Agent, NegotiationResult, Role, negotiate_roles
from .qualification import Evaluator, QualificationResult, path_length_evaluator, qualification_matrix


@dataclass
class RolePlan:
    """What the central computer publishes: who plays which role along which trajectory.

    ``feasible`` is False when negotiation or GRA found no workable assignment; ``reason``
    then says why and ``process_roles`` is empty.
    """

    feasible: bool
    reason: str
    negotiation: NegotiationResult
    qualification: QualificationResult | None
    assignment: AssignmentResult | None
    process_roles: dict[str, tuple[str, np.ndarray]]   # agent name -> (role name, (N+1, 4) states)


def plan_roles(agents: list[Agent], roles: list[Role], environment: Environment, *, total_time: float,
               num_intervals: int, lam: float = 1.0, epsilon: float = 0.05,
               evaluate: Evaluator = path_length_evaluator, use_emap: bool = True,
               corner_tolerance: float = 1.5) -> RolePlan:
    """Negotiate, evaluate and assign; never raises for an infeasible problem, only for bad input."""
    negotiation = negotiate_roles(agents, roles, environment, total_time=total_time,
                                  num_intervals=num_intervals, corner_tolerance=corner_tolerance,
                                  use_emap=use_emap)
    if not negotiation.feasible:
        return RolePlan(False, '; '.join(negotiation.reasons), negotiation, None, None, {})
    qualification = qualification_matrix(negotiation, evaluate=evaluate, lam=lam, epsilon=epsilon)
    assignment = group_role_assignment(qualification.q, agent_names=[a.name for a in negotiation.agents],
                                       role_names=[r.name for r in negotiation.roles])
    if not assignment.feasible:
        return RolePlan(False, assignment.reason, negotiation, qualification, assignment, {})
    process_roles = {negotiation.agents[i].name: (negotiation.roles[j].name, qualification.trajectories[(i, j)])
                     for i, j in assignment.pairs}
    return RolePlan(True, '', negotiation, qualification, assignment, process_roles)
