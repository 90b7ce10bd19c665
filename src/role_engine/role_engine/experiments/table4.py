"""Table IV: Group Role Assignment (Hungarian on Q) vs nearest-neighbour association.

``scripts/experiment roles-table4 [--only env_1 ...]``: the robot groups of config/roles/experiments.yaml
(three small and three large robots), every environment and every ``sigma_obs``; both methods
share one E-Map negotiation and one evaluation (Q) per problem and sigma_obs, and differ only in
the assignment. The measures are defined in :mod:`.gp_sweep`. Writes ``table4.md``,
``table4_assignments.png``, ``table4_cost.png`` and ``paper_notes.md`` (every difference from the
paper's Table IV, measured in the same run: :mod:`.paper_comparison`).
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
from .paper_comparison import (GTSAM_ABSOLUTE_TOL, add_paper_measures, claims_markdown, fmt, lower, paper_measures,
                               probe_means, ratio_text, scale_probe, share_text, tolerance_table)
from .table_report import breakdown_markdown, closing_markdown, plot_examples, plot_per_environment

ASSOCIATIONS = ('gra', 'nn')
ASSOCIATION_LABEL = {'gra': 'GRA (Hungarian on Q)', 'nn': 'NN (nearest destination)'}
#: The paper's Table IV (feasibility, overall cost, converging time in iterations), reference data for the
#: side-by-side columns only.
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
        assignments = self.assign(evaluated, problem)
        run = {'Q': finite_or_none(evaluated.qualification.q) if evaluated.qualification else None,
               'all_pairs': all_pair_measures(evaluated)}
        for method in ASSOCIATIONS:
            run[method] = add_paper_measures(assigned_measures(evaluated, assignments[method]), evaluated,
                                             assignments[method], config.qualification_lambda)
        return run, {m: run[m] for m in ASSOCIATIONS}, (evaluated, assignments)

    @staticmethod
    def assign(evaluated, problem) -> dict:
        if evaluated.qualification is None:
            return {'gra': None, 'nn': None}
        q = evaluated.qualification.q
        return {'gra': group_role_assignment(q),
                'nn': nearest_neighbour_assignment(problem.sources, problem.destinations, q)}

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
        'paper_comparison': {
            'measures': paper_measures(outcome.problems, ASSOCIATIONS),
            'scale_probe': scale_probe(outcome.examples, config, probe_solve)},
        'wall_time_s': outcome.wall_time_s,
    }
    passed, message = table4_acceptance(results)
    _plot_examples(outcome.examples, config, run_dir / 'table4_assignments.png')
    plot_per_environment(results, ASSOCIATIONS, {'gra': 'GRA', 'nn': 'NN'}, 'cost', 'mean total cost (Eq. 13, log scale)',
                         'Table IV: assignment cost per environment (the paper\'s scale differs: paper_notes.md)',
                         run_dir / 'table4_cost.png', log_scale=True,
                         paper={m: PAPER_TABLE4[m][1] for m in ASSOCIATIONS})
    report = table4_markdown(results, message)
    (run_dir / 'paper_notes.md').write_text(table4_notes(results))
    log(f'[roles-table4] {message}; wall time {outcome.wall_time_s:.0f} s')
    return ExperimentResult(passed, message, report, {'message': message}, results, report_file='table4.md')


def probe_solve(problem, environment, config: ExperimentConfig, sigma: float) -> dict:
    """One problem under other settings (paper_comparison.scale_probe): both assignments of one evaluation."""
    table = Associations()
    evaluated = evaluate_problem(table.negotiate(problem, environment, config)[1], config, sigma)
    return {m: (evaluated, a) for m, a in table.assign(evaluated, problem).items()}


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
             'Ours beside the paper\'s Table IV ("paper" columns). The scales differ for reasons explained in '
             '**paper_notes.md** (same run directory); the claims are compared in kind below.', '',
             '| method | feasibility | paper | overall cost | paper | ours / paper | converging time (iterations) '
             '| paper | iterations at gtsam\'s default tolerances |', '|---|---|---|---|---|---|---|---|---|']
    measures = results.get('paper_comparison', {}).get('measures', {})
    for method in ASSOCIATIONS:
        r, paper = results[method], PAPER_TABLE4[method]
        gtsam = measures.get(method, {}).get('iterations_gtsam_tol')
        lines.append(f"| {ASSOCIATION_LABEL[method]} | {percent(r['feasibility'])} | {percent(paper[0])} | "
                     f"{number_text(r['cost'])} | {paper[1]:g} | {ratio_text(r['cost'], paper[1])} | "
                     f"{number_text(r['iterations'], 3)} | {paper[2]:g} | {number_text(gtsam, 3)} |")
    c = results['cost_comparison']
    lines += ['', f"GRA's cost is lower than NN's on {c['gra_lower']} problem runs, equal on {c['equal']} "
                  f"(NN picked the optimal assignment), higher on {c['gra_higher']}."]
    if lower(results['gra']['iterations'], results['nn']['iterations']) is False:
        lines += ['', '**Flag: GRA needs more iterations than NN here, the paper reports fewer (3.11 vs 3.53): a '
                      'difference in kind, explained in paper_notes.md section 3 (what an iteration is, the '
                      'stopping rule).**']
    lines += claims_markdown(table4_claims(results))
    lines += breakdown_markdown(results, ASSOCIATIONS, {'gra': 'GRA', 'nn': 'NN'}, 'cost')
    return '\n'.join(lines + closing_markdown(results, acceptance))


def table4_claims(results: dict) -> list[tuple]:
    """Table IV's claims (Sec. V-A-2: "both ... 100 %"; GRA "significantly improves the average cost and
    converging time"), each with the paper's numbers, ours and whether it holds here."""
    gra, nn = results['gra'], results['nn']
    measures = results.get('paper_comparison', {}).get('measures', {})
    gtsam = {m: measures.get(m, {}).get('iterations_gtsam_tol') for m in ASSOCIATIONS}
    (pg_f, pg_c, pg_i), (pn_f, pn_c, pn_i) = PAPER_TABLE4['gra'], PAPER_TABLE4['nn']
    both_full = None if gra['feasibility'] is None or nn['feasibility'] is None else (
        gra['feasibility'] == 1.0 and nn['feasibility'] == 1.0)
    return [
        ('both methods 100 % feasible (E-Map)', f'{percent(pg_f)} / {percent(pn_f)}',
         f"{percent(gra['feasibility'])} / {percent(nn['feasibility'])}", both_full),
        ('GRA overall cost below NN', f'{pg_c:g} < {pn_c:g}', f"{fmt(gra['cost'])} vs {fmt(nn['cost'])}",
         lower(gra['cost'], nn['cost'])),
        ('GRA converges in fewer iterations than NN', f'{pg_i:g} < {pn_i:g}',
         f"{fmt(gra['iterations'], 3)} vs {fmt(nn['iterations'], 3)}", lower(gra['iterations'], nn['iterations'])),
        ('... counted with gtsam\'s default tolerances', f'{pg_i:g} < {pn_i:g}',
         f"{fmt(gtsam['gra'], 3)} vs {fmt(gtsam['nn'], 3)}", lower(gtsam['gra'], gtsam['nn'])),
    ]


def table4_notes(results: dict) -> str:
    """paper_notes.md: every difference from the paper's Table IV that is not a reproduction failure."""
    config = results['config']
    gra, nn = results['gra'], results['nn']
    comparison = results.get('paper_comparison', {})
    m = comparison.get('measures', {})
    mg, mn = m.get('gra', {}), m.get('nn', {})
    probe = comparison.get('scale_probe', [])
    probe_gra = probe_means(probe, 'gra') if probe else {}
    base = probe_gra.get('as configured', {}).get('cost')
    moved = [(variant, v['cost']) for variant, v in probe_gra.items() if variant != 'as configured']
    moved_text = '; '.join(f'{variant}: {fmt(cost)} ({ratio_text(cost, base)} of the configured cost)'
                           for variant, cost in moved if base) or 'not measured'
    iteration_claim = lower(gra['iterations'], nn['iterations'])
    longer = lower(mn.get('path_length_mean_m'), mg.get('path_length_mean_m'))
    team = ', '.join(f"{g['count']} x r = {g['radius']:g} m" for g in results['robot_groups'])
    return f"""# Table IV beside the paper: what differs and why

Paper: role_engine_gp_inference, Sec. V-A-2 and Table IV (six robots, three of radius 0.02 m and three of
0.1 m; six environments x sigma_obs 0.05, 0.10, 0.15, 0.2 = 24 scenarios; E-Map initialisation for both).
This run: {team}; {len(config['environments'])} environments x {len(config['sigma_obs'])} sigma_obs,
{results['problems_per_environment']} problems per environment.

| | feasibility | overall cost | converging time (iterations) |
|---|---|---|---|
| paper GRA | {percent(PAPER_TABLE4['gra'][0])} | {PAPER_TABLE4['gra'][1]:g} | {PAPER_TABLE4['gra'][2]:g} |
| paper NN | {percent(PAPER_TABLE4['nn'][0])} | {PAPER_TABLE4['nn'][1]:g} | {PAPER_TABLE4['nn'][2]:g} |
| ours GRA | {percent(gra['feasibility'])} | {fmt(gra['cost'])} ({ratio_text(gra['cost'], PAPER_TABLE4['gra'][1])}) | {fmt(gra['iterations'], 3)} |
| ours NN | {percent(nn['feasibility'])} | {fmt(nn['cost'])} ({ratio_text(nn['cost'], PAPER_TABLE4['nn'][1])}) | {fmt(nn['iterations'], 3)} |

## 1. Different cases

The paper's environments are only drawn (its Fig. 9), with no dimensions, and it does not say how many
problems each scenario holds or how robots and destinations are placed. Ours are the project's own:
config/roles/maps/env_1..6 (5 m x 5 m, 0.025 m per pixel), problems drawn from a seeded generator
(config/roles/experiments.yaml, table4). The team and the sigma_obs values are the paper's. So the rows
can agree only in kind (which method is better), never number for number.

## 2. Overall cost: {ratio_text(gra['cost'], PAPER_TABLE4['gra'][1])} (GRA) and {ratio_text(nn['cost'], PAPER_TABLE4['nn'][1])} (NN) the paper's

{_cost_summary(results)}

Measured in this run:

- **Definition.** Ours is the sum of q = lambda F_gp + F_conf (Eq. 13) over the six assigned roles of a problem,
  averaged over problems; the paper says only "similar to Eq. (13)". Per role ours is
  {fmt(mg.get('role_cost_mean'))} (mean) / {fmt(mg.get('role_cost_median'))} (median) for GRA.
- **Where it comes from.** The median problem costs {fmt(mg.get('problem_cost_median'))} (GRA), the mean
  {fmt(mg.get('problem_cost_mean'))}; by environment the GRA cost comes from
  {share_text(mg.get('cost_share_by_environment', {}))}. The environments with a maze (env_4) and a narrow
  hallway (env_5) force long E-Map detours with many corners and runs close to the walls (mean assigned path
  {fmt(mg.get('path_length_mean_m'), 3)} m).
- **Which term.** Per problem, lambda F_gp = {fmt(mg.get('q_prior_per_problem'))} and F_conf =
  {fmt(mg.get('q_conflict_per_problem'))} (GRA). F_gp (Eq. 14, the constant-velocity GP prior) is not
  scale-free: it grows with the square of the distances (m) and falls steeply with the trajectory duration
  and Q_c. F_conf (Eq. 15) is an arc-length integral of the hinge epsilon - d (epsilon = {config['gp']['epsilon']:g} m),
  non-zero wherever a path runs closer than epsilon to the inflated obstacles; it does not depend on the
  duration or on Q_c.
- **Settings the paper does not give.** The plotted problem of each environment solved again (GRA, mean over
  the environments; configured: {fmt(base)}): {moved_text}. Duration ({config['total_time_s']:g} s here),
  Q_c ({config['gp']['qc']}), lambda ({config['qualification_lambda']:g}), epsilon and the map's size in metres
  are not stated in the paper, and each moves the cost by factors like these. The absolute value is
  therefore not comparable; the claim that holds or not is GRA < NN.

## 3. Converging time: GRA {'fewer' if iteration_claim else 'MORE'} iterations than NN ({fmt(gra['iterations'], 3)} vs {fmt(nn['iterations'], 3)}; the paper: 3.11 vs 3.53)

{'The paper claims fewer iterations for GRA, and so does this run.' if iteration_claim else
 '**A difference in kind**, flagged in table4.md: the paper reports fewer iterations for GRA, this run more.'}

- **Definition of an iteration.** Ours: accepted Levenberg-Marquardt steps per assigned process role,
  averaged over the feasible ones (the paper: "average number of iterations to converge"; its optimiser "is
  stopped if a maximum iteration is reached or if the relative decrease in error is smaller than a
  threshold", Sec. IV, threshold not given). Ours stops at a relative decrease of 1e-5 (absolute tolerance 0).
  GPMP2, the paper's library, runs gtsam's LM, whose defaults also stop on an *absolute* decrease below
  {GTSAM_ABSOLUTE_TOL:g}. The cost after every step is recorded, so the same runs are counted under other
  stopping rules (mean over the feasible assigned roles):

{chr(10).join(tolerance_table(m, ASSOCIATIONS))}

The count is set by the threshold: a few iterations, as in the paper, correspond to a coarse one. How far
an optimisation starts from its optimum counts too (mean initial error of an assigned role
  {fmt(mg.get('initial_error_mean'))} (GRA), the MAP objective of Eq. 11 with the obstacle factors weighted by
1 / sigma_obs^2): the E-Map paths have corners the GP prior must smooth.

{_gtsam_rule_text(mg, mn)}

- **Why GRA need not converge faster.** GRA minimises the total of Q (smoothness and obstacle cost of the
  optimised roles), not the work of getting there; the number of steps depends on how far each initial path
  is from its optimum. GRA's assigned roles are on average {fmt(mg.get('path_length_mean_m'), 3)} m long, NN's
  {fmt(mn.get('path_length_mean_m'), 3)} m{' (GRA longer: it trades some short, cornered paths for cheaper ones)' if longer else ''}.
  The paper gives no reason why GRA should converge faster, nor how it counted and averaged the
  iterations; its difference (0.42 iterations) is small beside what the stopping rule alone changes
  (table above). We report our count as measured and flag the difference rather than tune the rule.

## 4. Feasibility

The paper: 100 % for both "because of the E-Map". Ours: {percent(gra['feasibility'])} (GRA),
{percent(nn['feasibility'])} (NN); a role fails when its robot's centre enters the obstacles inflated by its
radius at a support state or a GP-interpolated instant (definitions in table4.md).
"""


def _cost_summary(results: dict) -> str:
    """The short answer of section 2, from this run's numbers."""
    c = results['cost_comparison']
    m = results.get('paper_comparison', {}).get('measures', {}).get('gra', {})
    prior, conflict = m.get('q_prior_per_problem'), m.get('q_conflict_per_problem')
    shares = sorted((v for v in (m.get('cost_share_by_environment') or {}).values() if v is not None), reverse=True)
    verdict = (f"Not a failure of GRA: its cost is never above NN's here (lower on {c['gra_lower']}, equal on "
               f"{c['equal']} problem runs)" if c['gra_higher'] == 0 else
               f"GRA's cost is above NN's on {c['gra_higher']} problem runs (a reproduction failure where it happens)")
    parts = []
    if prior is not None and conflict is not None and prior + conflict > 0:
        parts.append(f'the GP prior term lambda F_gp is {100 * prior / (prior + conflict):.0f} % of our cost '
                     'and its size is set by settings the paper does not state (duration, Q_c, distances in metres)')
    if len(shares) >= 2:
        parts.append(f'two of the six environments carry {100 * (shares[0] + shares[1]):.0f} % of the mean')
    if m.get('problem_cost_median') is not None:
        parts.append(f"the median problem is {ratio_text(m['problem_cost_median'], PAPER_TABLE4['gra'][1])} the "
                     "paper's GRA cost, the mean " + ratio_text(results['gra']['cost'], PAPER_TABLE4['gra'][1]))
    return verdict + '. The number itself is on another scale' + (': ' + '; '.join(parts) if parts else '') + '.'


def _gtsam_rule_text(gra: dict, nn: dict) -> str:
    """Whether the paper's ordering of the iterations comes back under gtsam's default stopping rule."""
    ordered = lower(gra.get('iterations_gtsam_tol'), nn.get('iterations_gtsam_tol'))
    if ordered is None:
        return ''
    if ordered:
        return ("Under gtsam's default rule (the paper's library) GRA takes fewer iterations than NN "
                f"({fmt(gra['iterations_gtsam_tol'], 3)} vs {fmt(nn['iterations_gtsam_tol'], 3)}), as in the paper: "
                'the ordering depends on the stopping rule, i.e. on what counts as an iteration.')
    return ("Under gtsam's default rule (the paper's library) GRA still takes more iterations than NN "
            f"({fmt(gra['iterations_gtsam_tol'], 3)} vs {fmt(nn['iterations_gtsam_tol'], 3)}).")


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
