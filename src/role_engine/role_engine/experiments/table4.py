"""Table IV: Group Role Assignment (Hungarian on Q) vs nearest-neighbour association.

``scripts/experiment roles-table4 [--only env_1 ...]``: the robot groups of config/roles/experiments.yaml
(three small and three large robots), every environment and every ``sigma_obs``; both methods
share one E-Map negotiation and one evaluation (Q) per problem and sigma_obs, and differ only in
the assignment. The measures are defined in :mod:`.gp_sweep`. Writes ``table4.md``,
``table4_assignments.png`` and ``table4_cost.png``.
"""
from __future__ import annotations

import math
from pathlib import Path

from collab_tools.experiments.api import ExperimentRequest, ExperimentResult

from ..core.assignment import group_role_assignment, nearest_neighbour_assignment
from ..core.negotiation import negotiate_roles
from .config import ExperimentConfig, request_config
from .gp_sweep import (Log, all_pair_measures, assigned_measures, evaluate_problem, finite_or_none, number_text,
                       percent, sweep_tables)
from .table_report import breakdown_markdown, closing_markdown, plot_examples, plot_per_environment

ASSOCIATIONS = ('gra', 'nn')
ASSOCIATION_LABEL = {'gra': 'GRA (Hungarian on Q)', 'nn': 'NN (nearest destination)'}
#: The paper's rows (feasibility, overall cost, iterations), printed under the table for comparison.
PAPER_TABLE4 = {'gra': (1.0, 0.000869, 3.11), 'nn': (1.0, 0.001749, 3.53)}
DEFINITIONS = {
    'feasibility': 'share of assigned process roles whose robot centre never enters its type\'s '
                   'inflated obstacles (a problem that cannot be assigned counts as all failed)',
    'cost': 'total qualification sum Q[a, T(a)] of the assignment (Eq. 13, Q = lambda F_gp + F_conf), '
            'averaged over problems',
    'iterations': 'LM iterations of the assigned process roles, averaged over the feasible ones',
    'nn': 'each destination goes to the closest free robot, closest pair first (straight-line distance)'}


class Associations:
    """Table IV's methods: one E-Map negotiation and one Q, assigned by GRA and by nearest neighbour."""

    methods = ASSOCIATIONS
    second = 'cost'

    def negotiate(self, problem, environment, config: ExperimentConfig):
        return problem, negotiate_roles(problem.agents, problem.roles, environment, total_time=config.total_time,
                                        num_intervals=config.states - 1, use_emap=True)

    def solve(self, negotiated, config: ExperimentConfig, sigma: float):
        problem, negotiation = negotiated
        evaluated = evaluate_problem(negotiation, config, sigma)
        assignments = {'gra': None, 'nn': None}
        if evaluated.qualification is not None:
            q = evaluated.qualification.q
            assignments['gra'] = group_role_assignment(q)
            assignments['nn'] = nearest_neighbour_assignment(problem.sources, problem.destinations, q)
        run = {'Q': finite_or_none(evaluated.qualification.q) if evaluated.qualification else None,
               'all_pairs': all_pair_measures(evaluated)}
        for method in ASSOCIATIONS:
            run[method] = assigned_measures(evaluated, assignments[method])
        return run, {m: run[m] for m in ASSOCIATIONS}, (evaluated, assignments)

    def describe(self, problem) -> str:
        return problem.formation


def run(request: ExperimentRequest) -> ExperimentResult:
    return run_table4(request_config(request), request.run_dir, request.log, steps=request.progress)


def run_table4(config: ExperimentConfig, run_dir, log: Log = print, steps=None) -> ExperimentResult:
    run_dir = Path(run_dir)
    settings = config.table4
    outcome = sweep_tables('roles-table4', Associations(), config, settings, log, steps=steps)
    comparisons = {'gra_lower': 0, 'equal': 0, 'gra_higher': 0, 'not_comparable': 0}
    for problem in outcome.problems:
        for run_detail in problem['runs'].values():
            comparisons[compare_costs(run_detail['gra']['total_cost'], run_detail['nn']['total_cost'])] += 1
    results = {
        'config': config.summary(), 'problems_per_environment': settings.problems_per_environment,
        'problem_seed': settings.seed,
        'robot_groups': [{'name': g.name, 'count': g.count, 'radius': g.radius} for g in settings.robot_groups],
        'definitions': DEFINITIONS, **outcome.tally.report(), 'cost_comparison': comparisons,
        'problems': outcome.problems,
        'paper_rows': {m: dict(zip(('feasibility', 'cost', 'iterations'), PAPER_TABLE4[m])) for m in ASSOCIATIONS},
        'wall_time_s': outcome.wall_time_s,
    }
    passed, message = table4_acceptance(results)
    _plot_examples(outcome.examples, config, run_dir / 'table4_assignments.png')
    plot_per_environment(results, ASSOCIATIONS, ASSOCIATION_LABEL, 'cost', 'mean total cost (Eq. 13)',
                         'Table IV: assignment cost per environment', run_dir / 'table4_cost.png')
    report = table4_markdown(results, message)
    (run_dir / 'table4.md').write_text(report)
    log(f'[roles-table4] {message}; wall time {outcome.wall_time_s:.0f} s')
    return ExperimentResult(passed, message, report, {'message': message}, results)


def compare_costs(gra_cost: float | None, nn_cost: float | None) -> str:
    if gra_cost is None or nn_cost is None:
        return 'not_comparable'
    if math.isclose(gra_cost, nn_cost, rel_tol=1e-12, abs_tol=1e-15):
        return 'equal'
    return 'gra_lower' if gra_cost < nn_cost else 'gra_higher'


def table4_acceptance(results: dict) -> tuple[bool, str]:
    """GRA's mean total cost below NN's, and never above it on any problem."""
    gra, nn, comparisons = results['gra'], results['nn'], results['cost_comparison']
    passed = (gra['cost'] is not None and nn['cost'] is not None and gra['cost'] < nn['cost']
              and comparisons['gra_higher'] == 0)
    message = (f"GRA mean cost {number_text(gra['cost'])} vs NN {number_text(nn['cost'])} "
               f"(GRA lower on {comparisons['gra_lower']}, equal on {comparisons['equal']}, higher on "
               f"{comparisons['gra_higher']} problem runs); feasibility GRA {percent(gra['feasibility'])}, "
               f"NN {percent(nn['feasibility'])}")
    return passed, message + ('' if passed else ' (acceptance NOT met: GRA cost must be below NN)')


def table4_markdown(results: dict, acceptance: str) -> str:
    config = results['config']
    team = ', '.join(f"{g['count']} {g['name']} (r = {g['radius']:g} m)" for g in results['robot_groups'])
    lines = ['# Table IV: GRA vs nearest-neighbour association (E-Map initialisation for both)', '',
             f"{team}; {len(config['environments'])} environments x {len(config['sigma_obs'])} sigma_obs = "
             f"{len(config['environments']) * len(config['sigma_obs'])} scenarios, "
             f"{results['problems_per_environment']} problems each.", '',
             '| method | feasibility | overall cost | converging time (iterations) |', '|---|---|---|---|']
    for method in ASSOCIATIONS:
        r = results[method]
        lines.append(f"| {ASSOCIATION_LABEL[method]} | {percent(r['feasibility'])} | {number_text(r['cost'])} | "
                     f"{number_text(r['iterations'], 3)} |")
    c = results['cost_comparison']
    lines += ['', f"GRA's cost is lower than NN's on {c['gra_lower']} problem runs, equal on {c['equal']} "
                  f"(NN picked the optimal assignment), higher on {c['gra_higher']}.", '',
              'The paper: ' + '; '.join(f"{m.upper()} {percent(v[0])}, {v[1]}, {v[2]}"
                                        for m, v in PAPER_TABLE4.items()) + '.']
    lines += breakdown_markdown(results, ASSOCIATIONS, {'gra': 'GRA', 'nn': 'NN'}, 'cost')
    return '\n'.join(lines + closing_markdown(results, acceptance))


def _plot_examples(examples: dict, config: ExperimentConfig, path: Path) -> None:
    """One problem per environment at plot_sigma: GRA's assignment above NN's."""
    envs = [e for e in config.environments if e in examples]
    if not envs:
        return
    panels = []
    for method in ASSOCIATIONS:
        row = []
        for env in envs:
            environment, problem, (evaluated, assignments) = examples[env]
            cost = assignments[method].total_cost if assignments[method] else math.inf
            row.append((environment, problem, evaluated, assignments[method], f'{env}: cost {cost:.4g}'))
        panels.append(row)
    plot_examples(panels, [m.upper() for m in ASSOCIATIONS],
                  f'GRA vs NN, sigma_obs = {config.plot_sigma:g} (one problem per environment; green discs: '
                  'robots at their sources, sized by radius; blue: destinations)', path)
