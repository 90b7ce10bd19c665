"""Tables III and IV beside the paper: the paper's values in their own columns, the claims compared in
kind, and the measurements that explain the differences (written to ``paper_notes.md``).

The paper (``role_engine_gp_inference``, Sec. V-A-1/2) prints one row per method and does not give
what sets the scale of its numbers (map size, trajectory duration, Q_c, lambda, epsilon, whether
"overall cost" sums or averages over the robots). So the numbers are compared in kind (which
method is better in each column) and every measured difference is explained by measurements made in
the same run:

- per assigned process role, beside :func:`.gp_sweep.assigned_measures`: the LM iterations under
  gtsam's default stopping rule (the paper's library, GPMP2, runs gtsam's Levenberg-Marquardt with
  its default tolerances: relative *and absolute* decrease 1e-5; ours stops on the relative rule
  only, :class:`~..core.gp_vectorised.LMSettings`), the two parts of q (lambda F_gp, F_conf), the
  error split by factor (GP prior vs obstacle) and the path length;
- a *scale probe*: the plotted problem of every environment solved again with twice the trajectory
  duration and with ten times Q_c, to show how far the cost moves with settings the paper does not
  state.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable, Iterable

import numpy as np

from ..core.assignment import AssignmentResult
from .config import ExperimentConfig
from .gp_sweep import Evaluated, number_text, percent

#: gtsam's LevenbergMarquardtParams defaults (relativeErrorTol, absoluteErrorTol), used by GPMP2.
GTSAM_RELATIVE_TOL = 1e-5
GTSAM_ABSOLUTE_TOL = 1e-5


#: Relative-decrease thresholds at which the iterations are also counted (the paper: "smaller than a
#: threshold", value not given); ours stops at 1e-5.
RELATIVE_TOLERANCES = (1e-3, 1e-2, 1e-1)


def accepted_steps_at(initial_cost: float, history: list[float], iterations: int, relative_tol: float,
                      absolute_tol: float = 0.0) -> int:
    """Accepted LM steps had the optimiser stopped at ``relative_tol`` / ``absolute_tol`` (gtsam's rule:
    relative or absolute decrease at most the tolerance); ``history`` is the cost after each outer
    iteration of our run (relative 1e-5, absolute 0), which takes the same steps up to any earlier stop.
    ``iterations`` when the history is empty."""
    errors = [float(initial_cost), *map(float, history)]
    if len(errors) == 1:
        return int(iterations)
    accepted = 0
    for previous, new in zip(errors, errors[1:]):
        accepted += new < previous
        decrease = previous - new
        if new <= 0.0 or decrease <= absolute_tol or (previous > 0 and decrease / previous <= relative_tol):
            break
    return accepted


def accepted_steps_at_gtsam_defaults(initial_cost: float, history: list[float], iterations: int) -> int:
    """:func:`accepted_steps_at` gtsam's defaults (relative and absolute 1e-5), which GPMP2 uses."""
    return accepted_steps_at(initial_cost, history, iterations, GTSAM_RELATIVE_TOL, GTSAM_ABSOLUTE_TOL)


def path_length(trajectory: np.ndarray) -> float:
    return float(np.sum(np.hypot(*np.diff(np.asarray(trajectory)[:, :2], axis=0).T)))


def add_paper_measures(measures: dict, evaluated: Evaluated, assignment: AssignmentResult | None,
                       lam: float) -> dict:
    """Add, per assigned process role, what paper_notes.md needs (see the module docstring)."""
    extra = {'iterations_gtsam_tol': [], 'iterations_at_relative_tol': {f'{t:g}': [] for t in RELATIVE_TOLERANCES},
             'initial_error': [], 'q_prior': [], 'q_conflict': [], 'error_prior': [], 'error_obstacle': [],
             'path_length_m': []}
    if measures.get('assigned') and assignment is not None and evaluated.qualification is not None:
        for a, r in assignment.pairs:
            plan = evaluated.plan(a, r)
            extra['iterations_gtsam_tol'].append(
                accepted_steps_at_gtsam_defaults(plan.initial_cost, plan.cost_history, plan.iterations))
            for tol in RELATIVE_TOLERANCES:
                extra['iterations_at_relative_tol'][f'{tol:g}'].append(
                    accepted_steps_at(plan.initial_cost, plan.cost_history, plan.iterations, tol))
            extra['initial_error'].append(float(plan.initial_cost))
            extra['q_prior'].append(float(lam * evaluated.qualification.prior[a, r]))
            extra['q_conflict'].append(float(evaluated.qualification.conflict[a, r]))
            extra['error_prior'].append(float(plan.term_costs.get('gp_prior', 0.0)))
            extra['error_obstacle'].append(float(sum(v for k, v in plan.term_costs.items() if 'obstacle' in k)))
            extra['path_length_m'].append(path_length(plan.trajectory))
    measures.update(extra)
    return measures


def _mean(values: Iterable[float]) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def _median(values: Iterable[float]) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.median(values)) if values else None


def paper_measures(problems: list[dict], methods: tuple[str, ...]) -> dict:
    """Per method, over every problem and sigma_obs: the explanatory measures (None where a restored step
    from an older run lacks them)."""
    summary = {}
    for method in methods:
        runs = [run[method] for problem in problems for run in problem['runs'].values()]
        runs = [r for r in runs if r.get('assigned') and 'iterations_gtsam_tol' in r]
        roles = [(r, k) for r in runs for k in range(len(r['pairs']))]
        feasible = [(r, k) for r, k in roles if r['feasible'][k]]
        totals = [r['total_cost'] for r in runs]
        by_env: dict[str, list[float]] = {}
        for problem in problems:
            for run in problem['runs'].values():
                if run[method].get('assigned'):
                    by_env.setdefault(problem['environment'], []).append(run[method]['total_cost'])
        grand = sum(sum(v) for v in by_env.values())
        summary[method] = {
            'runs_measured': len(runs),
            'iterations_gtsam_tol': _mean(r['iterations_gtsam_tol'][k] for r, k in feasible),
            'iterations': _mean(r['iterations'][k] for r, k in feasible),
            'iterations_at_relative_tol': {f'{t:g}': _mean(r['iterations_at_relative_tol'][f'{t:g}'][k]
                                                           for r, k in feasible) for t in RELATIVE_TOLERANCES},
            'initial_error_mean': _mean(r['initial_error'][k] for r, k in roles),
            'problem_cost_mean': _mean(totals), 'problem_cost_median': _median(totals),
            'role_cost_mean': _mean(r['q'][k] for r, k in roles), 'role_cost_median': _median(r['q'][k] for r, k in roles),
            'q_prior_per_problem': _mean(sum(r['q_prior']) for r in runs),
            'q_conflict_per_problem': _mean(sum(r['q_conflict']) for r in runs),
            'error_mean': _mean(r['error'][k] for r, k in roles),
            'error_prior_mean': _mean(r['error_prior'][k] for r, k in roles),
            'error_obstacle_mean': _mean(r['error_obstacle'][k] for r, k in roles),
            'path_length_mean_m': _mean(r['path_length_m'][k] for r, k in roles),
            'cost_share_by_environment': {e: (sum(v) / grand if grand > 0 else None) for e, v in by_env.items()},
        }
    return summary


#: solve(problem, environment, config, sigma_obs) -> {method: (evaluated, assignment)}
Solve = Callable[[object, object, ExperimentConfig, float], dict[str, tuple[Evaluated, AssignmentResult | None]]]


def scale_probe(examples: dict, config: ExperimentConfig, solve: Solve) -> list[dict]:
    """The plotted problem of each environment at plot_sigma, solved as configured, with twice the
    trajectory duration and with ten times Q_c: per method the total cost (Eq. 13) with its two parts and
    the mean final error (Eq. 11) of the assigned roles."""
    variants = (('as configured', config),
                (f'total_time x2 ({2 * config.total_time:g} s)', replace(config, total_time=2 * config.total_time)),
                ('Q_c x10', replace(config, gp={**config.gp, 'qc': _scaled_qc(config.gp.get('qc', 1.0), 10.0)})))
    rows = []
    for env, (environment, problem, _kept) in examples.items():
        for label, variant in variants:
            row = {'environment': env, 'variant': label}
            for method, (evaluated, assignment) in solve(problem, environment, variant, config.plot_sigma).items():
                if assignment is None or not assignment.feasible:
                    row[method] = None
                    continue
                q = evaluated.qualification
                row[method] = {'cost': float(assignment.total_cost),
                               'prior': float(sum(variant.qualification_lambda * q.prior[a, r] for a, r in assignment.pairs)),
                               'conflict': float(sum(q.conflict[a, r] for a, r in assignment.pairs)),
                               'error': float(np.mean([evaluated.plan(a, r).cost for a, r in assignment.pairs]))}
            rows.append(row)
    return rows


def _scaled_qc(qc, factor: float):
    return [float(v) * factor for v in qc] if isinstance(qc, (list, tuple)) else float(qc) * factor


def probe_means(rows: list[dict], method: str) -> dict[str, dict]:
    """Mean cost (and parts) per variant of :func:`scale_probe` over the environments."""
    means = {}
    for variant in dict.fromkeys(r['variant'] for r in rows):
        values = [r[method] for r in rows if r['variant'] == variant and r.get(method)]
        means[variant] = {k: _mean(v.get(k) for v in values) for k in ('cost', 'prior', 'conflict', 'error')}
    return means


def ratio_text(ours: float | None, paper: float) -> str:
    if ours is None or not paper:
        return '-'
    return f'{ours / paper:.3g}x'


def verdict(holds: bool | None) -> str:
    return '-' if holds is None else ('yes' if holds else '**NO: differs in kind**')


def lower(a: float | None, b: float | None) -> bool | None:
    return None if a is None or b is None else a < b


def claims_markdown(claims: list[tuple[str, str, str, bool | None]]) -> list[str]:
    """The paper's claims, ours beside them: (claim, paper, ours, holds)."""
    lines = ['', '## The paper\'s claims, compared in kind', '',
             '| claim | paper | ours | holds here |', '|---|---|---|---|']
    lines += [f'| {claim} | {paper} | {ours} | {verdict(holds)} |' for claim, paper, ours, holds in claims]
    return lines


def share_text(shares: dict[str, float | None]) -> str:
    ranked = sorted(((v, e) for e, v in shares.items() if v is not None), reverse=True)
    return ', '.join(f'{e} {percent(v)}' for v, e in ranked)


def tolerance_table(measures: dict, methods: tuple[str, ...]) -> list[str]:
    """Mean iterations of the feasible roles per stopping rule, one column per method."""
    lines = ['| stopping rule | ' + ' | '.join(m.upper() for m in methods) + ' |', '|---|' + '---|' * len(methods)]
    rules = [('relative decrease <= 1e-5 (ours, as run)', 'iterations'),
             ("gtsam's defaults: relative or absolute decrease <= 1e-5 (GPMP2)", 'iterations_gtsam_tol')]
    rules += [(f'relative decrease <= {t:g}', ('iterations_at_relative_tol', f'{t:g}')) for t in RELATIVE_TOLERANCES]
    for label, key in rules:
        cells = []
        for m in methods:
            value = measures.get(m, {})
            value = value.get(key[0], {}).get(key[1]) if isinstance(key, tuple) else value.get(key)
            cells.append(number_text(value, 3))
        lines.append(f'| {label} | ' + ' | '.join(cells) + ' |')
    return lines


def fmt(value: float | None, digits: int = 4) -> str:
    return number_text(value, digits)


__all__ = ['GTSAM_ABSOLUTE_TOL', 'GTSAM_RELATIVE_TOL', 'RELATIVE_TOLERANCES', 'accepted_steps_at',
           'accepted_steps_at_gtsam_defaults', 'add_paper_measures',
           'claims_markdown', 'fmt', 'tolerance_table', 'lower', 'paper_measures', 'path_length', 'probe_means',
           'ratio_text', 'scale_probe', 'share_text', 'verdict']
