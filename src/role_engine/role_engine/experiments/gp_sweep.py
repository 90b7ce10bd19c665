"""The sweep Tables III and IV share: every environment, every seeded problem, every sigma_obs,
each method evaluated by GP inference and measured (paper Sec. V-A, Algorithms 1-3).

One problem, one scenario: negotiate (Algorithm 2; with or without the E-Map), optimise the
process role of every agent-role pair by GP inference from its initial path (Algorithm 3 lines
7-19), build Q = lambda F_gp + F_conf (Eq. 13-15), assign, and measure the assigned process roles.
What differs between the tables -- which negotiations, which assignments, which columns -- is a
:class:`TableMethods` each table module gives :func:`sweep_tables`.

Measures (where the paper is terse, what is measured here):

- *feasibility*: share of the assigned process roles that are collision-free. A process role
  fails when "there is at least a point on the graph where the center of the robot touches the
  obstacle" (Sec. V-A-1): the planner's ``collision_free``, i.e. the robot type's
  configuration-space SDF (obstacles inflated by the radius) is >= 0 at every support state and
  at GP-interpolated instants between them. A scenario whose roles cannot be assigned at all
  counts all its process roles as failures.
- *average error* (Table III): the final value of the MAP objective of Eq. 11 that GP inference
  minimises (GP prior + obstacle hinge + start / goal constraints: ``0.5 sum ||W e||^2``, what
  GPMP2's optimiser reports as its error, gtsam's ``graph.error``), averaged over all assigned
  process roles, failed ones included. It is not a distance to the goal: the goal is a
  constraint of the optimisation (sigma 1e-4) and every plan ends there.
- *cost* (Table IV, "overall cost, similar to Eq. 13"): the total qualification sum of
  Q[a, T(a)] over the assignment, averaged over problems.
- *converging time*: LM iterations (accepted steps) of the assigned process roles, averaged over
  the feasible ones only ("only the converging times for the feasible cases ... are considered").

results.json (beside the schema's keys): the tables' own ``problem_seed`` (the schema's ``seed`` is
the command line's) and ``paper_rows`` (the paper's values; ``paper`` is the reference), the
per-method summaries, ``per_environment``, ``per_sigma``, ``scenarios`` and every problem's detail.

Choices where the paper is silent: process roles start and end with the velocity of their
initial path (GPMP2 fixes start and goal velocities; zeros made the E-Map paths' corners far
harder to keep); the LM starts with GPMP2's damping (``gp.lambda_initial``); the same problems
are solved at every ``sigma_obs``.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Protocol

import numpy as np

from collab_tools.experiments.sweep import Steps

from ..core.assignment import AssignmentResult
from ..core.environment import Environment, RobotEnvironment, load_map_file
from ..core.gp_planner import GPPlanner, GPPlannerConfig, GPPlanResult
from ..core.negotiation import Agent, NegotiationResult, Role
from ..core.qualification import ProcessRoleEvaluation, QualificationResult, qualification_matrix
from .config import ExperimentConfig, TableSettings
from .problems import Problem, draw_problem

Log = Callable[[str], None]


class GPProcessRoleEvaluator:
    """Evaluator of :func:`~role_engine.core.qualification.qualification_matrix` that optimises by GP inference.

    Algorithm 3 lines 7-19: the process role of an agent for a role is the GP planner's solution
    from the pair's initial path, on the agent type's configuration-space SDF; F_gp (Eq. 14) is
    its GP prior cost. Every plan is kept in ``plans[(agent name, role name)]``.
    """

    def __init__(self, config: GPPlannerConfig, total_time: float):
        self.config = config
        self.total_time = float(total_time)
        self.plans: dict[tuple[str, str], GPPlanResult] = {}
        self.seconds: dict[tuple[str, str], float] = {}
        self._planners: dict[str, GPPlanner] = {}

    def __call__(self, agent: Agent, role: Role, initial: np.ndarray,
                 robot_env: RobotEnvironment) -> ProcessRoleEvaluation:
        name = robot_env.robot_type.name
        if name not in self._planners:
            self._planners[name] = GPPlanner(self.config, robot_env.sdf)
        began = time.perf_counter()
        result = self._planners[name].plan(initial, self.total_time)
        self.seconds[(agent.name, role.name)] = time.perf_counter() - began
        self.plans[(agent.name, role.name)] = result
        return ProcessRoleEvaluation(result.trajectory, result.term_costs['gp_prior'], result.iterations)


@dataclass
class Evaluated:
    """One problem at one sigma_obs: every pair's plan and the qualification matrix."""

    negotiation: NegotiationResult
    qualification: QualificationResult | None
    evaluator: GPProcessRoleEvaluator
    seconds: float

    def plan(self, agent: int, role: int) -> GPPlanResult:
        return self.evaluator.plans[(self.negotiation.agents[agent].name, self.negotiation.roles[role].name)]


def evaluate_problem(negotiation: NegotiationResult, config: ExperimentConfig, sigma_obs: float) -> Evaluated:
    """GP inference for every reachable agent-role pair and Q (Eq. 13); None Q when negotiation failed."""
    evaluator = GPProcessRoleEvaluator(config.gp_config(sigma_obs), config.total_time)
    began = time.perf_counter()
    qualification = None
    if negotiation.feasible:
        # F_conf (Eq. 15) uses the planner's own hinge (Eq. 21): the same safety distance epsilon.
        qualification = qualification_matrix(negotiation, evaluate=evaluator, lam=config.qualification_lambda,
                                              epsilon=evaluator.config.epsilon,
                                              samples_per_interval=config.samples_per_interval)
    return Evaluated(negotiation, qualification, evaluator, time.perf_counter() - began)


def assigned_measures(evaluated: Evaluated, assignment: AssignmentResult | None) -> dict:
    """Per assigned process role: feasible, error (Eq. 11), iterations, clearance, q (Eq. 13)."""
    agents = len(evaluated.negotiation.agents)
    roles = len(evaluated.negotiation.roles)
    if assignment is None or not assignment.feasible:
        if not evaluated.negotiation.feasible:
            reason = 'negotiation infeasible: ' + '; '.join(evaluated.negotiation.reasons)
        else:
            reason = assignment.reason if assignment is not None else 'no assignment'
        return {'assigned': False, 'reason': reason, 'pairs': [], 'feasible': [False] * min(agents, roles),
                'error': [], 'iterations': [], 'converged': [], 'min_clearance_m': [], 'q': [], 'total_cost': None}
    plans = [evaluated.plan(a, r) for a, r in assignment.pairs]
    q = evaluated.qualification.q
    return {
        'assigned': True, 'reason': '', 'pairs': [[int(a), int(r)] for a, r in assignment.pairs],
        'feasible': [bool(p.collision_free) for p in plans],
        'error': [float(p.cost) for p in plans],
        'iterations': [int(p.iterations) for p in plans],
        'converged': [bool(p.converged) for p in plans],
        'min_clearance_m': [float(p.min_clearance) for p in plans],
        'q': [float(q[a, r]) for a, r in assignment.pairs],
        'total_cost': float(assignment.total_cost),
    }


def all_pair_measures(evaluated: Evaluated) -> dict:
    """Every agent-role pair's plan (not only the assigned ones), for the per-problem detail."""
    plans = list(evaluated.evaluator.plans.values())
    if not plans:
        return {'pairs': 0}
    return {'pairs': len(plans), 'feasibility': sum(p.collision_free for p in plans) / len(plans),
            'error_mean': float(np.mean([p.cost for p in plans])),
            'iterations_mean': float(np.mean([p.iterations for p in plans])),
            'plan_seconds_total': float(sum(evaluated.evaluator.seconds.values()))}


class MeasureTotals:
    """Accumulates assigned process roles into the tables' numbers."""

    def __init__(self):
        self.feasible: list[bool] = []
        self.errors: list[float] = []
        self.feasible_iterations: list[int] = []
        self.costs: list[float] = []
        self.unassigned = 0

    def add(self, measures: dict) -> None:
        self.feasible.extend(measures['feasible'])
        self.errors.extend(measures['error'])
        self.feasible_iterations.extend(i for i, ok in zip(measures['iterations'], measures['feasible']) if ok)
        if measures['total_cost'] is not None:
            self.costs.append(measures['total_cost'])
        else:
            self.unassigned += 1

    def summary(self) -> dict:
        return {
            'feasibility': (sum(self.feasible) / len(self.feasible)) if self.feasible else None,
            'error': float(np.mean(self.errors)) if self.errors else None,
            'cost': float(np.mean(self.costs)) if self.costs else None,
            'iterations': float(np.mean(self.feasible_iterations)) if self.feasible_iterations else None,
            'process_roles': len(self.feasible), 'feasible_process_roles': int(sum(self.feasible)),
            'unassigned_problems': self.unassigned,
        }


class Tally:
    """:class:`MeasureTotals` of each method overall, per environment, per sigma_obs and per scenario."""

    def __init__(self, methods: tuple[str, ...], environments: tuple[str, ...], sigmas: tuple[float, ...]):
        self.methods = methods
        self.groups = {('all',): None, **{('environment', e): e for e in environments},
                       **{('sigma', sigma_key(s)): s for s in sigmas},
                       **{('scenario', e, sigma_key(s)): (e, s) for e in environments for s in sigmas}}
        self.totals = {group: {m: MeasureTotals() for m in methods} for group in self.groups}

    def add(self, environment: str, sigma: float, method: str, measures: dict) -> None:
        key = sigma_key(sigma)
        for group in (('all',), ('environment', environment), ('sigma', key), ('scenario', environment, key)):
            self.totals[group][method].add(measures)

    def _summaries(self, group) -> dict:
        return {m: self.totals[group][m].summary() for m in self.methods}

    def report(self) -> dict:
        """The results.json sections: one summary per method, then the breakdowns."""
        return {
            **self._summaries(('all',)),
            'per_environment': {g[1]: self._summaries(g) for g in self.groups if g[0] == 'environment'},
            'per_sigma': {g[1]: self._summaries(g) for g in self.groups if g[0] == 'sigma'},
            'scenarios': [{'environment': e, 'sigma_obs': float(s), **self._summaries(g)}
                          for g, (e, s) in ((g, v) for g, v in self.groups.items() if g[0] == 'scenario')],
        }


def finite_or_none(matrix: np.ndarray) -> list:
    return [[float(v) if math.isfinite(v) else None for v in row] for row in np.asarray(matrix, dtype=float)]


def sigma_key(sigma: float) -> str:
    return f'{sigma:g}'


def percent(value: float | None) -> str:
    return '-' if value is None else f'{100.0 * value:.2f}%'


def number_text(value: float | None, digits: int = 5) -> str:
    return '-' if value is None else f'{value:.{digits}g}'


def _mean_or_none(values) -> float | None:
    values = list(values)
    return float(np.mean(values)) if values else None


def _run_text(name: str, measures: dict, second: str) -> str:
    """Progress text of one method: collision-free count and the table's second column."""
    feasible = measures['feasible']
    iterations = [i for i, ok in zip(measures['iterations'], feasible) if ok]
    value = _mean_or_none(measures['error']) if second == 'error' else measures['total_cost']
    return (f'{name} {sum(feasible)}/{len(feasible)} collision-free, {second} {number_text(value, 4)}, '
            f'{number_text(_mean_or_none(iterations), 3)} it')



# ---------------------------------------------------------------------------------------- the sweep
class TableMethods(Protocol):
    """What one table does with a problem (the rest of the sweep is shared)."""

    #: The compared methods, in table order (the tally's columns).
    methods: tuple[str, ...]
    #: The table's second column: 'error' (Table III) or 'cost' (Table IV).
    second: str

    def negotiate(self, problem: Problem, environment: Environment, config: ExperimentConfig) -> Any:
        """Algorithm 2 for the problem, once for every sigma_obs (whatever the table needs)."""

    def solve(self, negotiated: Any, config: ExperimentConfig, sigma: float) -> tuple[dict, dict[str, dict], Any]:
        """Evaluate and assign at one sigma_obs: (the run's detail, each method's measures, the example kept
        for the table's plot)."""

    def describe(self, problem: Problem) -> str:
        """The problem in the progress line."""


@dataclass
class SweepOutcome:
    tally: Tally
    problems: list[dict]           # per problem: its description and, per sigma_obs, the run's detail
    examples: dict[str, Any]       # environment -> the plotted problem's example (at plot_sigma)
    wall_time_s: float


def sweep_tables(label: str, table: TableMethods, config: ExperimentConfig, settings: TableSettings, log: Log,
                 describe_extra: Callable[[Problem], dict] = lambda problem: {},
                 steps: Callable[[str, int], Steps] | None = None) -> SweepOutcome:
    """Every environment x problem x sigma_obs of ``settings``: ``table`` negotiates each problem once and
    solves it at every sigma_obs; one progress line per step.

    ``steps``: the run's loop helper (``ExperimentRequest.progress``): each finished step is checkpointed
    and a resumed run restores it instead of solving it again -- except the plotted example of each
    environment, solved again for its figure (its restored numbers are the ones kept)."""
    count = settings.problems_per_environment
    total = len(config.environments) * count * len(config.sigma_obs)
    tally = Tally(table.methods, config.environments, config.sigma_obs)
    problems, examples = [], {}
    started = time.perf_counter()
    with (steps or (lambda name, n: Steps(name, n, log=log, bar=False)))(label, total) as progress:
        for env_index, env_name in enumerate(config.environments):
            environment = load_map_file(config.map_file(env_name))
            example = env_index % count     # the plotted problem; varies the robot size between panels
            for p in range(count):
                problem = draw_problem(environment, env_index, p, settings)
                negotiated = None           # negotiated only when a step of this problem has to run
                detail = {**problem.describe(), **describe_extra(problem), 'runs': {}}
                for sigma in config.sigma_obs:
                    key = f'{env_name}|{p}|{sigma_key(sigma)}'
                    plotted = p == example and math.isclose(sigma, config.plot_sigma)
                    restored = progress.has(key)
                    if restored and not plotted:
                        run, measures = progress.value(key)['run'], progress.value(key)['measures']
                    else:
                        if negotiated is None:
                            negotiated = table.negotiate(problem, environment, config)
                        began = time.perf_counter()
                        run, measures, kept = table.solve(negotiated, config, sigma)
                        if plotted:
                            examples[env_name] = (environment, problem, kept)
                        if restored:
                            run, measures = progress.value(key)['run'], progress.value(key)['measures']
                        else:
                            progress.finish(key, {'run': run, 'measures': measures},
                                            f'{env_name} problem {p + 1}/{count} ({table.describe(problem)}) '
                                            f'sigma_obs={sigma:g}: ' + '; '.join(
                                                _run_text(m, measures[m], table.second) for m in table.methods)
                                            + f' ({time.perf_counter() - began:.1f} s)')
                    for method in table.methods:
                        tally.add(env_name, sigma, method, measures[method])
                    detail['runs'][sigma_key(sigma)] = run
                problems.append(detail)
    return SweepOutcome(tally, problems, examples, time.perf_counter() - started)
