"""Table III: GP inference initialised from the E-Map (our method) vs from a straight line (plain GPMP).

``scripts/experiment roles-table3 [--only env_1 ...]``: ``robots`` homogeneous robots per problem
(radius ``robot_radii[p % len]``), every environment and every ``sigma_obs`` of
config/roles/experiments.yaml; both initialisations are assigned by GRA. The measures are
defined in :mod:`.gp_sweep`. Writes ``table3.md``, ``table3_examples.png`` and
``table3_feasibility.png``.
"""
from __future__ import annotations

from pathlib import Path

from collab_tools.experiments.api import ExperimentRequest, ExperimentResult

from ..core.assignment import group_role_assignment
from ..core.negotiation import negotiate_roles
from .config import INITIALISATIONS, ExperimentConfig, request_config
from .gp_sweep import (Log, all_pair_measures, assigned_measures, evaluate_problem, finite_or_none, number_text,
                       percent, sweep_tables)
from .table_report import breakdown_markdown, closing_markdown, plot_examples, plot_per_environment

INIT_LABEL = {'emap': 'Our method (E-Map initialisation)', 'straight': 'GPMP (straight-line initialisation)'}
#: The paper's rows (feasibility, average error, iterations), printed under the table for comparison.
PAPER_TABLE3 = {'emap': (1.0, 0.00052, 3.31), 'straight': (0.5714, 0.01346, 7.49)}
DEFINITIONS = {
    'feasibility': 'share of assigned process roles whose robot centre never enters the inflated '
                   'obstacles (support states and GP-interpolated instants)',
    'error': 'final value of the Eq. 11 objective (0.5 sum of squared whitened errors, = gtsam '
             'graph.error) of the assigned process roles, averaged over all of them',
    'iterations': 'LM iterations of the assigned process roles, averaged over the feasible ones'}


class Initialisations:
    """Table III's methods: negotiate with and without the E-Map, assign both by GRA."""

    methods = INITIALISATIONS
    second = 'error'

    def negotiate(self, problem, environment, config: ExperimentConfig):
        return {init: negotiate_roles(problem.agents, problem.roles, environment, total_time=config.total_time,
                                      num_intervals=config.states - 1, use_emap=(init == 'emap'))
                for init in INITIALISATIONS}

    def solve(self, negotiations, config: ExperimentConfig, sigma: float):
        run, measures, kept = {}, {}, {}
        for init in INITIALISATIONS:
            evaluated = evaluate_problem(negotiations[init], config, sigma)
            assignment = (group_role_assignment(evaluated.qualification.q)
                          if evaluated.qualification is not None else None)
            measures[init] = assigned_measures(evaluated, assignment)
            run[init] = {**measures[init], 'all_pairs': all_pair_measures(evaluated),
                         'Q': finite_or_none(evaluated.qualification.q) if evaluated.qualification else None}
            kept[init] = (evaluated, assignment)
        return run, measures, kept

    def describe(self, problem) -> str:
        return f'r = {problem.agents[0].robot_type.radius:g} m, {problem.formation}'


def run(request: ExperimentRequest) -> ExperimentResult:
    return run_table3(request_config(request), request.run_dir, request.log, steps=request.progress)


def run_table3(config: ExperimentConfig, run_dir, log: Log = print, steps=None) -> ExperimentResult:
    run_dir = Path(run_dir)
    settings = config.table3
    outcome = sweep_tables('roles-table3', Initialisations(), config, settings, log,
                           describe_extra=lambda problem: {'robot_radius': problem.agents[0].robot_type.radius},
                           steps=steps)
    results = {
        'config': config.summary(), 'problems_per_environment': settings.problems_per_environment,
        'robots': settings.robots, 'robot_radii': list(settings.robot_radii), 'problem_seed': settings.seed,
        'definitions': DEFINITIONS, **outcome.tally.report(), 'problems': outcome.problems,
        'paper_rows': {init: dict(zip(('feasibility', 'error', 'iterations'), PAPER_TABLE3[init]))
                  for init in INITIALISATIONS},
        'wall_time_s': outcome.wall_time_s,
    }
    passed, message = table3_acceptance(results)
    _plot_examples(outcome.examples, config, run_dir / 'table3_examples.png')
    plot_per_environment(results, INITIALISATIONS, INIT_LABEL, 'feasibility', 'feasibility (%)',
                         'Table III: feasibility per environment', run_dir / 'table3_feasibility.png', as_percent=True)
    report = table3_markdown(results, message)
    (run_dir / 'table3.md').write_text(report)
    log(f'[roles-table3] {message}; wall time {outcome.wall_time_s:.0f} s')
    return ExperimentResult(passed, message, report, {'message': message}, results)


def table3_acceptance(results: dict) -> tuple[bool, str]:
    """E-Map initialisation 100 % feasible and better than the straight line (feasibility, then error)."""
    emap, straight = results['emap'], results['straight']
    full = emap['feasibility'] == 1.0
    beats = (emap['feasibility'] > straight['feasibility']
             or (emap['feasibility'] == straight['feasibility'] and emap['error'] < straight['error']))
    message = (f"E-Map feasibility {percent(emap['feasibility'])} vs straight line "
               f"{percent(straight['feasibility'])}, error {number_text(emap['error'])} vs "
               f"{number_text(straight['error'])}")
    return full and beats, message + ('' if full and beats else ' (acceptance NOT met: E-Map must be 100 % '
                                                                'feasible and beat the straight line)')


def table3_markdown(results: dict, acceptance: str) -> str:
    config = results['config']
    lines = ['# Table III: E-Map initialisation vs straight-line GPMP', '',
             f"{len(config['environments'])} environments x {len(config['sigma_obs'])} sigma_obs "
             f"({', '.join(f'{s:g}' for s in config['sigma_obs'])}) = "
             f"{len(config['environments']) * len(config['sigma_obs'])} scenarios, "
             f"{results['problems_per_environment']} problems of {results['robots']} robots each "
             f"({results['emap']['process_roles']} assigned process roles per method).", '',
             '| method | feasibility | average error | average converging time (iterations) |',
             '|---|---|---|---|']
    for init in INITIALISATIONS:
        r = results[init]
        lines.append(f"| {INIT_LABEL[init]} | {percent(r['feasibility'])} | {number_text(r['error'])} | "
                     f"{number_text(r['iterations'], 3)} |")
    lines += ['', 'The paper: ' + '; '.join(
        f"{INIT_LABEL[i]} {percent(v[0])}, {v[1]}, {v[2]}" for i, v in PAPER_TABLE3.items()) + '.']
    lines += breakdown_markdown(results, INITIALISATIONS, {'emap': 'E-Map', 'straight': 'straight'}, 'error')
    return '\n'.join(lines + closing_markdown(results, acceptance))


def _plot_examples(examples: dict, config: ExperimentConfig, path) -> None:
    """One problem per environment at plot_sigma: the E-Map row above the straight-line row."""
    envs = [e for e in config.environments if e in examples]
    if not envs:
        return
    panels = []
    for init in INITIALISATIONS:
        row = []
        for env in envs:
            environment, problem, kept = examples[env]
            evaluated, assignment = kept[init]
            free = sum(evaluated.plan(a, r).collision_free for a, r in assignment.pairs) if assignment else 0
            row.append((environment, problem, evaluated, assignment,
                        f'{env} r={problem.agents[0].robot_type.radius:g}: {free}/{len(problem.roles)} free'))
        panels.append(row)
    plot_examples(panels, [INIT_LABEL[i].split(' (')[1].rstrip(')') for i in INITIALISATIONS],
                  f'Process roles after GP inference, sigma_obs = {config.plot_sigma:g} (one problem per '
                  'environment; green: sources, blue: destinations, x: in collision)', path)
