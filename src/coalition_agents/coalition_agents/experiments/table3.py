"""``coalition-table3``: the potential solutions of the navigation task (IQ-ASyMTRe, Table III).

Paper: Section V-A-1 and Table III (paper ``iq_asymtre_coalitions``, CITATION.cff): the potential
solutions for F_G(local) of the navigation MS on a robot with a fiducial, a laser and a GPS, in
non-descending cost (costs: RPS 0.5, ES-EPS 1, CS 2, MS 4). Ours are generated in the core
(:class:`~..core.SolutionSpaceGenerator`, Algorithm 1) and listed next to the paper's printed rows;
which ones the dominance rule of Section V-A-1 removes; the Generality Imposition reading that
reproduces the table (notes.md); a drawing of the and-or solution space (solution_space.png).

Acceptance: eleven solutions whose costs and leaves (read as notes.md explains) match the paper's
rows (``matches_paper``).
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from collab_tools.experiments.api import ExperimentRequest, ExperimentResult

from ..core import (
    Constraints, PotentialSolution, SchemaKind, SolutionSpace, SolutionSpaceGenerator, load_capability_file,
)
from .configuration import COALITIONS, CoalitionConfig
from .solution_space_plot import plot_solution_space

#: Table III's robot and requirement.
TABLE3_CAPABILITIES = 'capabilities/table3_robot.yaml'
TABLE3_ROBOT_TYPE = 'table3'
TABLE3_TASK = 'navigation'
TABLE3_REQUIREMENT = 'F_G(local)'


@dataclass(frozen=True)
class PaperRow:
    """One row of the paper's Table III: as printed, our reading of it (F_G typos fixed), cost."""

    row: int
    printed: str
    reading: str
    cost: float


_ROW7 = 'CS: F_G(X), CS: F_R(local, Z), CS: F_R(X, Z)'
#: Table III as printed in the paper (reference data for the side-by-side comparison only).
PAPER_TABLE3 = (
    PaperRow(1, 'EPS: F_G(local)', 'EPS: F_G(local)', 5.0),
    PaperRow(2, 'CS: F_G(X), EPS: F_G(X, local)', 'CS: F_G(X), EPS: F_R(X, local)', 8.0),
    PaperRow(3, 'CS: F_G(X), CS: F_G(local, X)', 'CS: F_G(X), CS: F_R(local, X)', 8.5),
    PaperRow(4, 'CS: F_G(X), CS: F_G(X, local)', 'CS: F_G(X), CS: F_R(X, local)', 9.0),
    PaperRow(5, 'CS: F_G(X), CS: F_R(local, X)', 'CS: F_G(X), CS: F_R(local, X)', 9.5),
    PaperRow(6, 'CS: F_G(X), EPS: F_R(Z, local), CS: F_R(X, Z)', 'CS: F_G(X), EPS: F_R(Z, local), CS: F_R(X, Z)', 10.5),
    PaperRow(7, _ROW7, _ROW7, 11.0),
    PaperRow(8, _ROW7, _ROW7, 11.5),
    PaperRow(9, 'CS: F_G(X), CS: F_R(Z, local), CS: F_R(X, Z)', 'CS: F_G(X), CS: F_R(Z, local), CS: F_R(X, Z)', 11.5),
    PaperRow(10, _ROW7, _ROW7, 12.0),
    PaperRow(11, _ROW7, _ROW7, 12.0),
)

_LEAF_PATTERN = re.compile(r'(EPS|CS|PRIOR): (F_\w+(?:\([^)]*\))?)')


def leaf_texts(solution: PotentialSolution) -> list[str]:
    """The leaves as Table III prints them: kind and instance, without the sensor's name."""
    return sorted(f'{leaf.kind.short}: {leaf.output}' for leaf in solution.leaves)


def paper_leaf_texts(text: str) -> list[str]:
    return sorted(f'{kind}: {instance}' for kind, instance in _LEAF_PATTERN.findall(text))


def table3_space(config: CoalitionConfig, constraints: Constraints = Constraints(),
                 requirements: Sequence[str] = (TABLE3_REQUIREMENT,), with_priors: bool = False) -> SolutionSpace:
    """The navigation MS's space for ``requirements`` on Table III's robot."""
    robot = load_capability_file(config.directory / TABLE3_CAPABILITIES, config.library).types[TABLE3_ROBOT_TYPE]
    task = config.task(TABLE3_TASK)
    extra = task.prior_sensors if with_priors else ()
    generator = SolutionSpaceGenerator(config.library, robot, config.costs, extra_sensors=extra,
                                       constraints=constraints)
    return generator.motor_schema_space(task.motor_schema, [config.library.parse(t) for t in requirements])


def run(request: ExperimentRequest) -> ExperimentResult:
    """Table III: table3.md, notes.md and solution_space.png in the run directory."""
    log = request.log
    run_dir = Path(request.run_dir)
    config = CoalitionConfig.load(Path(request.config_dir) / COALITIONS)
    space = table3_space(config)
    solutions = space.potential_solutions(remove_dominated=False)
    kept_ranks = {s.rank for s in space.potential_solutions()}
    first_with: dict[tuple, int] = {}
    rows = []
    for index, solution in enumerate(solutions):
        key = solution.information
        first_with.setdefault(key, solution.rank)
        paper = PAPER_TABLE3[index] if index < len(PAPER_TABLE3) else None
        leaves = leaf_texts(solution)
        rows.append({
            'rank': index + 1,
            'cost': solution.cost,
            'schemas': solution.schemas(),
            'leaves': solution.summary(),
            'kept': solution.rank in kept_ranks,
            'dominated_by': None if solution.rank in kept_ranks else first_with[key] + 1,
            'paper_row': None if paper is None else paper.row,
            'paper_cost': None if paper is None else paper.cost,
            'paper_printed': None if paper is None else paper.printed,
            'paper_reading': None if paper is None else paper.reading,
            'cost_matches_paper': paper is not None and paper.cost == solution.cost,
            'leaves_match_paper': paper is not None and paper_leaf_texts(paper.reading) == leaves,
        })
        log(f'[coalition-table3] {index + 1:2d}. cost {solution.cost:5.1f} (paper '
            f'{"-" if paper is None else f"{paper.cost:.1f}"})  {solution.summary()}'
            f'{"" if solution.rank in kept_ranks else f"  [dominated by {first_with[key] + 1}]"}')

    outputs_space = table3_space(config, Constraints(generality_reading='outputs'))
    outputs_solutions = outputs_space.potential_solutions(remove_dominated=False)
    ours = {tuple(s.schemas()) for s in solutions}
    extra = [{'cost': s.cost, 'schemas': s.schemas(), 'leaves': s.summary()}
             for s in outputs_solutions if tuple(s.schemas()) not in ours]
    full = table3_space(config, requirements=[str(i) for i in config.task(TABLE3_TASK).requires], with_priors=True)
    full_costs = [s.cost for s in full.potential_solutions(remove_dominated=False)]

    acceptance = {'eleven_solutions': len(rows) == len(PAPER_TABLE3),
                  'costs_match_paper': all(r['cost_matches_paper'] for r in rows),
                  'leaves_match_paper': all(r['leaves_match_paper'] for r in rows)}
    matches_paper = all(acceptance.values())
    results = {
        'mode': 'core',
        'robot': {'type': TABLE3_ROBOT_TYPE, 'sensors': [s.describe() for s in space.generator.sensors]},
        'motor_schema': config.task(TABLE3_TASK).motor_schema,
        'requirement': TABLE3_REQUIREMENT,
        'schema_costs': {kind.value: config.costs.of(kind) for kind in SchemaKind if kind is not SchemaKind.MS}
        | {'ms': config.costs.motor_schema(config.task(TABLE3_TASK).motor_schema)},
        'solutions': rows,
        'costs': [row['cost'] for row in rows],
        'paper_costs': [row.cost for row in PAPER_TABLE3],
        'matches_paper': matches_paper,
        'kept_costs': [row['cost'] for row in rows if row['kept']],
        'dominated_ranks': [row['rank'] for row in rows if not row['kept']],
        'space': {'stored_nodes': space.distinct_node_count(), 'tree_schema_nodes': space.tree_size(),
                  'potential_solutions': space.count_potential_solutions()},
        'generality_outputs_reading': {'costs': [s.cost for s in outputs_solutions], 'extra': extra},
        'full_task': {'requirements': [str(i) for i in config.task(TABLE3_TASK).requires], 'costs': full_costs},
    }
    run_dir.mkdir(parents=True, exist_ok=True)
    table = table3_markdown(results)
    (run_dir / 'notes.md').write_text(table3_notes(results))
    plot_solution_space(space, run_dir / 'solution_space.png',
                        f'Solution space of MS {results["motor_schema"]} for {TABLE3_REQUIREMENT} '
                        f'(Table III robot: fiducial, laser, GPS)')
    outcome = (f'{len(rows)} potential solutions ({len(results["kept_costs"])} kept after the dominance rule); '
               f'paper match: {matches_paper}')
    log(f'[coalition-table3] {outcome}')
    return ExperimentResult(passed=matches_paper, outcome=outcome, report=table, acceptance=acceptance,
                            data=results, report_file='table3.md')


def table3_markdown(results: dict) -> str:
    lines = [f'Potential solutions for {results["requirement"]} (MS {results["motor_schema"]}), robot with '
             'fiducial, laser and GPS; non-descending cost. "leaves" is what Table III prints; "schemas" is the '
             'whole solution in IQ notation (pre-order: a schema, then what feeds its inputs).', '',
             '| rank | cost | paper row (cost) | leaves | schemas | kept / dominated |',
             '|---|---|---|---|---|---|']
    for row in results['solutions']:
        paper = '-' if row['paper_row'] is None else f'{row["paper_row"]} ({row["paper_cost"]:g})'
        status = 'kept' if row['kept'] else f'dominated by {row["dominated_by"]}'
        schemas = '<br>'.join(s.replace('=>', '⇒') for s in row['schemas'])
        lines.append(f'| {row["rank"]} | {row["cost"]:g} | {paper} | {row["leaves"]} | {schemas} | {status} |')
    lines += ['', f'Costs: {", ".join(f"{c:g}" for c in results["costs"])} '
              f'(paper: {", ".join(f"{c:g}" for c in results["paper_costs"])}); '
              f'matches the paper: {"yes" if results["matches_paper"] else "NO"}.',
              f'Kept after removing solutions that need the same information as a cheaper one: '
              f'{", ".join(f"{c:g}" for c in results["kept_costs"])}.']
    return '\n'.join(lines) + '\n'


def table3_notes(results: dict) -> str:
    """What is ambiguous in the paper's Table III and what we chose (with this run's numbers)."""
    rows = {row['rank']: row for row in results['solutions']}

    def chain(rank: int) -> str:
        if rank not in rows:
            return '(not generated)'
        return '; '.join(s for s in rows[rank]['schemas'][1:] if s.startswith('RPS'))

    extra = results['generality_outputs_reading']['extra']
    extra_text = ('\n'.join(f'  - cost {e["cost"]:g}: {e["leaves"]} -- '
                            + '; '.join(s for s in e['schemas'] if s.startswith('RPS')) for e in extra)
                  if extra else '  - none')
    mismatches = [r for r in results['solutions'] if not (r['cost_matches_paper'] and r['leaves_match_paper'])]
    return f"""# Table III: ambiguities of the printed table and our choices

Result of this run: {len(results['solutions'])} potential solutions with costs
{', '.join(f'{c:g}' for c in results['costs'])}; the paper prints
{', '.join(f'{c:g}' for c in results['paper_costs'])}.
{'Every row matches the paper in cost and (read as below) in its leaves.' if not mismatches else
 'Rows that differ from the paper: ' + ', '.join(str(r['rank']) for r in mismatches) + '.'}
Costs are the paper's: RPS 0.5, ES-EPS 1, CS 2, MS 4; a potential solution costs the sum of its schemas
(row 1: EPS 1 + MS 4 = 5).

## 1. F_G printed where F_R is meant (rows 2-4)

Rows 2-4 print `EPS: F_G(X, local)`, `CS: F_G(local, X)` and `CS: F_G(X, local)`. F_G has one referent
(Table II, Definition 4.1), so a two-referent F_G does not exist; the fiducial's EPS retrieves the
relative position `F_R(X, local)` (Fig. 3: "Camera => F_R(X, local)"). We read the three rows with F_R:
row 2 `CS: F_G(X), EPS: F_R(X, local)`, row 3 `CS: F_G(X), CS: F_R(local, X)`, row 4
`CS: F_G(X), CS: F_R(X, local)`. The costs confirm this reading: row 3 (8.5) needs only Table I's
global + relative RPS, which takes F_R(local, X) as it is; rows 2 and 4 (8, 9) add the inversion
F_R(X, local) => F_R(local, X) (0.5).

## 2. Rows with identical printed leaves (7/8 and 10/11, and 5 vs 3)

Table III shows only the leaves ("RPSs are not shown for brevity"), so rows 7, 8, 10 and 11 print the
same three CSs, and row 5 prints row 3's leaves. They differ in their RPSs. Ours (rank: RPS chain):

- 3 ({rows.get(3, {}).get('cost', '-')}): {chain(3)}
- 5 ({rows.get(5, {}).get('cost', '-')}): {chain(5)}
- 7 ({rows.get(7, {}).get('cost', '-')}): {chain(7)}
- 8 ({rows.get(8, {}).get('cost', '-')}): {chain(8)}
- 10 ({rows.get(10, {}).get('cost', '-')}): {chain(10)}
- 11 ({rows.get(11, {}).get('cost', '-')}): {chain(11)}

Row 8 obtains F_R(X, local) by composition and inverts it; rows 10 and 11 are row 7 with one double
inversion (of F_R(local, X), or of F_R(local, Z)); row 5 is row 3 with a double inversion. The
Generality Imposition constraint allows one double inversion because F_R(local, X) and F_R(X, local)
have their instantiated referent at different positions and are therefore not comparable under
Definition 4.3; a third inversion is pruned. Row 8 prints `F_R(local, Z), F_R(X, Z)`; ours lists the
same two CSs in the order the composition takes them.

Section V-A-1 says solutions "that require the same set of information instances with higher costs can
be removed". Comparing the leaves up to renaming of the solution's own variables, this removes ranks
{', '.join(str(r) for r in results['dominated_ranks'])}; the kept solutions cost
{', '.join(f'{c:g}' for c in results['kept_costs'])}. Table III itself lists all eleven (the removal is a
post-processing step), and so do results.json and table3.md, each removed row with the row dominating it.

## 3. Which instances the Generality Imposition constraint compares

The constraint is worded on what an RPS *converts* ("prohibit the use of the same RPS to convert
information instances of the same type that have less or equal generality upstream on the same
branching path"); the proofs of Lemmas 4.2 and 4.4 compare what the nodes *produce* (F_u, F_v). The two
readings give different spaces. We use the worded reading ('inputs', the default of
`Constraints.generality_reading`): it gives exactly the paper's eleven rows (and Section V-A-4's
"P(r^(k)) is bounded by 11"). The 'outputs' reading gives {len(results['generality_outputs_reading']['costs'])}
solutions, costs {', '.join(f'{c:g}' for c in results['generality_outputs_reading']['costs'])}; the ones
Table III does not list:
{extra_text}

## 4. Other choices

- Only F_G(local) is expanded, as in the paper: F_G(goal) and F_M are a priori (zero-cost dummy sensors)
  and F_A(local) comes from the laser only. With all four inputs of Table II every cost is 1 higher
  (the laser): {', '.join(f'{c:g}' for c in results['full_task']['costs'])}.
- Fresh variables take the RPS's own names (Table I's Z), so our rows read like the paper's.
- Rows with equal cost are ordered deterministically (by the alternative's position in the and-or tree:
  sensors, then RPSs in library order, then CS). Rows 8 and 9 (both 11.5) print different leaves and ours
  come in the paper's order; rows 10 and 11 print the same leaves, so their order cannot be compared.
- The and-or tree (solution_space.png) is drawn with shared sub-trees repeated; tOR nodes appear
  where an instance has more than one alternative.
"""


__all__ = ['PAPER_TABLE3', 'PaperRow', 'leaf_texts', 'paper_leaf_texts', 'run', 'table3_markdown',
           'table3_notes', 'table3_space']
