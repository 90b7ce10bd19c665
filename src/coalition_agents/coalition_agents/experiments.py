"""The paper's coalition experiments in the core, without ROS (``scripts/experiment coalition-*``).

- ``table3`` (:func:`run_table3`): Table III -- the potential solutions for F_G(local) of the
  navigation MS on a robot with a fiducial, a laser and a GPS, in non-descending cost, next to
  the paper's printed rows; which ones the dominance rule of Section V-A-1 removes; the
  Generality Imposition reading that reproduces the table; a drawing of the and-or solution space.
- ``fig7`` (:func:`run_fig7_core`): Fig. 7 / Table V -- three robots that cannot localise and six
  that can, in three distant clusters; fiducials with a 180 deg field of view and a 4 m range.
  **Core version**: what each fiducial sees comes from a pure geometric visibility model
  (:class:`GeometricSensing`: field of view and range, no occlusion, no noise) over the poses of
  ``config/coalitions/scenarios/fig7.yaml``, and the team's request/offer exchange runs in one
  process (:class:`~coalition_agents.core.CoalitionSearch`). The simulated version, with the
  schema_agent nodes and the bridge's sensing, comes later.

Table V counts "coalitions with two robots". *Executable* ones are found with the geometric
sensing; *possible* ones are what an approach using only the robot types of Table IV considers:
the same search with every fiducial seeing every robot (the configuration ignored). Each count
is of distinct member sets, with the cheapest coalition cost of each set.

Each run writes results.json, Markdown tables, notes and PNG plots into its run directory and
reports progress through ``log``.
"""
from __future__ import annotations

import json
import math
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, Mapping, Sequence

from .core import (
    CoalitionResult, CoalitionSearch, CoalitionSolution, ConfigError, Constraints, Costs, Entity,
    InformationInstance, PotentialSolution, RobotCapabilities, SchemaKind, SchemaLibrary, SolutionSpace,
    SolutionSpaceGenerator, Task, load_capability_file, load_costs, load_library, load_tasks, to_absolute,
)
from .core.solution_space import RequirementNode, SchemaNode
from .core.validation import Section, as_list, as_number, load_config_file

Log = Callable[[str], None]

#: Table III's robot and requirement.
TABLE3_CAPABILITIES = 'capabilities/table3_robot.yaml'
TABLE3_ROBOT_TYPE = 'table3'
TABLE3_TASK = 'navigation'
TABLE3_REQUIREMENT = 'F_G(local)'
FIG7_SCENARIO = 'scenarios/fig7.yaml'


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


@dataclass(frozen=True)
class CoalitionConfig:
    """The coalition configuration directory (config/coalitions/) loaded once."""

    directory: Path
    library: SchemaLibrary
    costs: Costs
    tasks: Mapping[str, Task]

    @classmethod
    def load(cls, config_dir: str | Path) -> 'CoalitionConfig':
        directory = Path(config_dir)
        library = load_library(directory / 'schemas.yaml')
        return cls(directory, library, load_costs(directory / 'costs.yaml'),
                   load_tasks(directory / 'tasks.yaml', library))

    def task(self, name: str, path: str = 'task') -> Task:
        if name not in self.tasks:
            raise ConfigError(f"{path}: unknown task {name!r} (tasks.yaml defines {', '.join(sorted(self.tasks))})")
        return self.tasks[name]


# === Table III ====================================================================================

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


def run_table3(config_dir: str | Path, run_dir: str | Path, log: Log = print) -> dict:
    """Table III: results.json, table3.md, notes.md and solution_space.png in ``run_dir``."""
    started = time.perf_counter()
    run_dir = Path(run_dir)
    config = CoalitionConfig.load(config_dir)
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

    results = {
        'experiment': 'coalition-table3',
        'mode': 'core',
        'robot': {'type': TABLE3_ROBOT_TYPE, 'sensors': [s.describe() for s in space.generator.sensors]},
        'motor_schema': config.task(TABLE3_TASK).motor_schema,
        'requirement': TABLE3_REQUIREMENT,
        'schema_costs': {kind.value: config.costs.of(kind) for kind in SchemaKind if kind is not SchemaKind.MS}
        | {'ms': config.costs.motor_schema(config.task(TABLE3_TASK).motor_schema)},
        'solutions': rows,
        'costs': [row['cost'] for row in rows],
        'paper_costs': [row.cost for row in PAPER_TABLE3],
        'matches_paper': (len(rows) == len(PAPER_TABLE3)
                          and all(r['cost_matches_paper'] and r['leaves_match_paper'] for r in rows)),
        'kept_costs': [row['cost'] for row in rows if row['kept']],
        'dominated_ranks': [row['rank'] for row in rows if not row['kept']],
        'space': {'stored_nodes': space.distinct_node_count(), 'tree_schema_nodes': space.tree_size(),
                  'potential_solutions': space.count_potential_solutions()},
        'generality_outputs_reading': {'costs': [s.cost for s in outputs_solutions], 'extra': extra},
        'full_task': {'requirements': [str(i) for i in config.task(TABLE3_TASK).requires], 'costs': full_costs},
    }
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / 'table3.md').write_text(table3_markdown(results))
    (run_dir / 'notes.md').write_text(table3_notes(results))
    plot_solution_space(space, run_dir / 'solution_space.png',
                        f'Solution space of MS {results["motor_schema"]} for {TABLE3_REQUIREMENT} '
                        f'(Table III robot: fiducial, laser, GPS)')
    results['wall_s'] = round(time.perf_counter() - started, 3)
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2))
    log(f'[coalition-table3] {len(rows)} potential solutions ({len(results["kept_costs"])} kept after the '
        f'dominance rule); paper match: {results["matches_paper"]}; {results["wall_s"]:.2f} s')
    return results


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


# --- The and-or tree drawing ------------------------------------------------------------------------

@dataclass
class _DrawNode:
    text: str
    kind: str            # 'schema' | 'tor'
    schema_kind: SchemaKind | None
    children: list['_DrawNode']
    x: float = 0.0
    y: float = 0.0


def _draw_tree(space: SolutionSpace) -> _DrawNode:
    def schema(node: SchemaNode) -> _DrawNode:
        head = f'{node.kind.short} {node.schema}' if node.kind is not SchemaKind.CS else 'CS'
        text = head if node.output is None else f'{head}\n→ {node.output}'
        return _DrawNode(f'{text}   [{node.cost:g}]', 'schema', node.kind, [requirement(r) for r in node.inputs])

    def requirement(node: RequirementNode) -> _DrawNode:
        if len(node.options) == 1:
            return schema(node.options[0])
        return _DrawNode(f'tOR {node.instance}', 'tor', None, [schema(o) for o in node.options])

    assert space.root is not None
    return schema(space.root)


def _layout(root: _DrawNode) -> tuple[int, int]:
    """Leaves on consecutive rows, parents centred on their children; x = depth."""
    next_row = [0]
    depth_max = [0]

    def place(node: _DrawNode, depth: int) -> None:
        node.x = depth
        depth_max[0] = max(depth_max[0], depth)
        if not node.children:
            node.y = next_row[0]
            next_row[0] += 1
            return
        for child in node.children:
            place(child, depth + 1)
        node.y = (node.children[0].y + node.children[-1].y) / 2

    place(root, 0)
    return next_row[0], depth_max[0]


def _walk(node: _DrawNode) -> Iterator[_DrawNode]:
    yield node
    for child in node.children:
        yield from _walk(child)


_KIND_COLOURS = {SchemaKind.MS: '#f4cccc', SchemaKind.RPS: '#cfe2f3', SchemaKind.PS: '#cfe2f3',
                 SchemaKind.ES_EPS: '#d9ead3', SchemaKind.CS: '#fff2cc', SchemaKind.PRIOR: '#eeeeee'}


def plot_solution_space(space: SolutionSpace, path: Path, title: str) -> None:
    """The and-or tree, root at the left, information flowing right to left (leaves at the right)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    root = _draw_tree(space)
    leaves, depth = _layout(root)
    fig, ax = plt.subplots(figsize=(1.75 * (depth + 1) + 0.5, 0.5 * leaves + 1.6))
    artists = {}
    for node in _walk(root):
        if node.kind == 'tor':
            box = {'boxstyle': 'round4,pad=0.3', 'fc': 'white', 'ec': '#aa0000', 'ls': '--'}
            artists[id(node)] = ax.text(node.x, -node.y, node.text, ha='center', va='center', fontsize=8,
                                        color='#aa0000', bbox=box)
        else:
            box = {'boxstyle': 'round,pad=0.3', 'fc': _KIND_COLOURS.get(node.schema_kind, 'white'), 'ec': '#333333'}
            artists[id(node)] = ax.text(node.x, -node.y, node.text, ha='center', va='center', fontsize=8, bbox=box)
    for node in _walk(root):
        for child in node.children:
            # From the child's left edge to the parent's right edge: information flows to the root.
            ax.annotate('', xy=(1.0, 0.5), xycoords=artists[id(node)], xytext=(0.0, 0.5),
                        textcoords=artists[id(child)],
                        arrowprops={'arrowstyle': '->', 'color': '#666666', 'lw': 0.8, 'shrinkA': 2, 'shrinkB': 2})
    ax.set_xlim(-0.6, depth + 0.6)
    ax.set_ylim(-leaves + 0.3, 0.7)
    ax.axis('off')
    kinds = [kind for kind in _KIND_COLOURS if any(n.schema_kind is kind for n in _walk(root))]
    handles = [plt.Rectangle((0, 0), 1, 1, fc=_KIND_COLOURS[k], ec='#333333') for k in kinds]
    ax.legend(handles, [k.short for k in kinds], loc='lower left', fontsize=8, ncol=len(kinds), frameon=False)
    ax.set_title(f'{title}\nboxes: schemas with [cost]; dashed: tOR choice; arrows: information flow '
                 f'({space.count_potential_solutions()} potential solutions)', fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# === Fig. 7 / Table V: the geometric scenario ======================================================

@dataclass(frozen=True)
class Pose:
    x: float
    y: float
    heading_deg: float
    label: str


@dataclass(frozen=True)
class FieldOfView:
    """A geometric sensor's field of view (centred on the heading) and range."""

    fov_deg: float
    range_m: float

    def contains(self, pose: Pose, x: float, y: float) -> bool:
        dx, dy = x - pose.x, y - pose.y
        if math.hypot(dx, dy) > self.range_m:
            return False
        bearing = math.degrees(math.atan2(dy, dx)) - pose.heading_deg
        bearing = (bearing + 180.0) % 360.0 - 180.0
        return abs(bearing) <= self.fov_deg / 2.0 + 1e-9


@dataclass(frozen=True)
class Scenario:
    """Robots with poses for the geometric sensing model (config/coalitions/scenarios/*.yaml)."""

    path: Path
    team: Mapping[str, RobotCapabilities]
    task: Task
    initiators: tuple[str, ...]
    sensors: Mapping[str, FieldOfView]
    poses: Mapping[str, Pose]
    goals: Mapping[str, tuple[float, float]]
    paper_table5: Mapping[str, dict]


def _point(value: object, path: str) -> tuple[float, float]:
    items = as_list(value, path)
    if len(items) != 2:
        raise ConfigError(f'{path}: must be [x, y] (got {len(items)} numbers)')
    return as_number(items[0], f'{path}[0]'), as_number(items[1], f'{path}[1]')


def _robot_name(value: object, path: str, team: Mapping[str, RobotCapabilities]) -> str:
    if value not in team:
        raise ConfigError(f'{path}: unknown robot {value!r} (team: {", ".join(team)})')
    return str(value)


def scenario_from_dict(data: object, config: CoalitionConfig, path: Path) -> Scenario:
    section = Section(data, '', ('team', 'task', 'initiators', 'sensors', 'robots', 'goals', 'paper_table5'))
    team_file = section.text('team')
    team = load_capability_file(config.directory / team_file, config.library).robots
    if not team:
        raise ConfigError(f'team: {team_file} names no robots (its robots: mapping is empty)')
    task = config.task(section.name('task'))
    initiators = tuple(_robot_name(v, p, team) for p, v in section.items('initiators'))
    if not initiators:
        raise ConfigError('initiators: name at least one robot of the team')
    sensors = {}
    known_sensors = {s.sensor for capabilities in team.values() for s in capabilities.sensors}
    for entry_path, sensor, value in section.entries('sensors', []):
        if sensor not in known_sensors:
            raise ConfigError(f'{entry_path}: no robot of the team has a sensor {sensor!r} '
                              f'(sensors: {", ".join(sorted(known_sensors))})')
        entry = Section(value, entry_path, ('fov_deg', 'range_m'))
        fov = entry.number('fov_deg', gt=0.0)
        if fov > 360.0:
            raise ConfigError(f"{entry.at('fov_deg')}: must be in (0, 360] (got {fov})")
        sensors[sensor] = FieldOfView(fov, entry.number('range_m', gt=0.0))
    poses = {}
    for entry_path, robot, value in section.entries('robots'):
        _robot_name(robot, entry_path, team)
        entry = Section(value, entry_path, ('position', 'heading_deg', 'label'))
        x, y = _point(entry.get('position'), entry.at('position'))
        poses[robot] = Pose(x, y, entry.number('heading_deg'), entry.text('label', robot))
    missing = [robot for robot in team if robot not in poses]
    if missing:
        raise ConfigError(f'robots: no pose for {", ".join(missing)} (every robot of {team_file} needs one)')
    goals = {_robot_name(robot, p, team): _point(v, p) for p, robot, v in section.entries('goals', [])}
    paper = {}
    for entry_path, robot, value in section.entries('paper_table5', []):
        _robot_name(robot, entry_path, team)
        entry = Section(value, entry_path, ('possible', 'executable_costs'))
        possible = entry.number('possible', ge=0.0)
        if possible != int(possible):
            raise ConfigError(f"{entry.at('possible')}: must be a whole number (got {possible})")
        paper[robot] = {'possible': int(possible),
                        'executable_costs': [as_number(v, p) for p, v in entry.items('executable_costs')]}
    return Scenario(path, team, task, initiators, sensors, poses, goals, paper)


def load_scenario(path: str | Path, config: CoalitionConfig) -> Scenario:
    """Read and validate a scenario; errors name the file and the field."""
    path = Path(path)
    scenario = load_config_file(path, lambda data: scenario_from_dict(data, config, path))
    GeometricSensing(scenario.team, scenario.poses, scenario.sensors)  # every geometric sensor has a FOV
    return scenario


class GeometricSensing:
    """What each robot's sensors retrieve from the robots' poses (a ``SensingModel``).

    A sensor whose label has one variable (fiducial: ``F_R(X, local)``) retrieves it for every
    other robot inside its field of view and range (no occlusion, no noise; the bridge replaces
    this model in simulation). A sensor whose label has no variable (laser ``F_A(local)``,
    localization ``F_G(local)``) always retrieves it.
    """

    def __init__(self, team: Mapping[str, RobotCapabilities], poses: Mapping[str, Pose],
                 fields_of_view: Mapping[str, FieldOfView]):
        self.team = team
        self.poses = poses
        self.fields_of_view = fields_of_view
        self._table: dict[str, dict[str, tuple[InformationInstance, ...]]] = {}
        for robot, capabilities in team.items():
            if robot not in poses:
                raise ConfigError(f'robots.{robot}: no pose for this robot')
            per_sensor: dict[str, list[InformationInstance]] = {}
            for sensor in capabilities.sensors:
                per_sensor.setdefault(sensor.sensor, []).extend(self._retrieve(robot, sensor.sensor, sensor.output))
            self._table[robot] = {name: tuple(found) for name, found in per_sensor.items()}

    def _retrieve(self, robot: str, sensor: str, label: InformationInstance) -> list[InformationInstance]:
        variables = label.variables
        if not variables:
            return [to_absolute(label, robot)]
        if len(variables) > 1:
            raise ConfigError(f'sensors.{sensor}: the geometric model senses one entity at a time; '
                              f'{label} has {len(variables)} variables')
        if sensor not in self.fields_of_view:
            raise ConfigError(f'sensors.{sensor}: missing field of view (robot {robot}\'s {sensor} retrieves '
                              f'{label}, which depends on what it sees: give fov_deg and range_m)')
        view = self.fields_of_view[sensor]
        pose = self.poses[robot]
        return [to_absolute(label.substitute({variables[0]: Entity(other, robot=True)}), robot)
                for other in self.team if other != robot
                and view.contains(pose, self.poses[other].x, self.poses[other].y)]

    def readings(self, robot: str, sensor: str) -> tuple[InformationInstance, ...]:
        return self._table.get(robot, {}).get(sensor, ())

    def sightings(self) -> list[tuple[str, str, str]]:
        """(observer, seen robot, sensor) for every geometric reading."""
        found = []
        for robot, per_sensor in self._table.items():
            for sensor, instances in per_sensor.items():
                if sensor not in self.fields_of_view:
                    continue
                for instance in instances:
                    seen = [r.name for r in instance.referents if isinstance(r, Entity) and r.name != robot]
                    found.extend((robot, other, sensor) for other in seen)
        return found


def configuration_blind(fields_of_view: Mapping[str, FieldOfView]) -> dict[str, FieldOfView]:
    """Every geometric sensor sees every robot: what approaches using only Table IV assume."""
    return {sensor: FieldOfView(360.0, math.inf) for sensor in fields_of_view}


# === Fig. 7 / Table V: the experiment ===============================================================

def _two_robot(result: CoalitionResult) -> list[CoalitionSolution]:
    return [c for c in result.per_members() if len(c.members) == 2]


def _coalition_entry(coalition: CoalitionSolution) -> dict:
    return {**coalition.to_dict(), 'local_coalition': list(coalition.local_coalition),
            'description': coalition.describe()}


def run_fig7_core(config_dir: str | Path, run_dir: str | Path, log: Log = print,
                  scenario_path: str | Path | None = None) -> dict:
    """Fig. 7 / Table V in the core: results.json, table5.md and fig7.png in ``run_dir``."""
    started = time.perf_counter()
    run_dir = Path(run_dir)
    config = CoalitionConfig.load(config_dir)
    scenario = load_scenario(Path(scenario_path) if scenario_path else config.directory / FIG7_SCENARIO, config)
    sensing = GeometricSensing(scenario.team, scenario.poses, scenario.sensors)
    sightings = sensing.sightings()
    log(f'[coalition-fig7] {len(scenario.team)} robots, {len(sightings)} sightings with '
        + ', '.join(f'{s} (FOV {v.fov_deg:g} deg, {v.range_m:g} m)' for s, v in scenario.sensors.items()))

    def search(model: GeometricSensing, what: str) -> tuple[dict[str, CoalitionResult], dict]:
        begin = time.perf_counter()
        engine = CoalitionSearch(config.library, config.costs, scenario.task, scenario.team, model)
        results = engine.run(scenario.initiators)
        info = {'seconds': round(time.perf_counter() - begin, 3), 'messages': engine.stats.messages,
                'request_deliveries': engine.stats.request_deliveries,
                'offers': sum(engine.stats.offers_sent.values()),
                'solution_spaces': sum(engine.stats.solution_spaces.values())}
        log(f'[coalition-fig7] {what} search: {info["messages"]} messages, {info["solution_spaces"]} solution '
            f'spaces, {info["seconds"]:.2f} s')
        return results, info

    executable, executable_info = search(sensing, 'geometric (executable)')
    blind_model = GeometricSensing(scenario.team, scenario.poses, configuration_blind(scenario.sensors))
    possible, possible_info = search(blind_model, 'configuration-blind (possible)')

    table5 = []
    chosen = {}
    for robot in scenario.initiators:
        found, blind = executable[robot], possible[robot]
        pairs, possible_pairs = _two_robot(found), _two_robot(blind)
        paper = scenario.paper_table5.get(robot)
        entry = {
            'robot': robot, 'label': scenario.poses[robot].label,
            'possible': len(possible_pairs),
            'possible_partners': [c.members[1] for c in possible_pairs],
            'possible_costs': [c.cost for c in possible_pairs],
            'executable': len(pairs),
            'executable_costs': [c.cost for c in pairs],
            'executable_partners': [c.members[1] for c in pairs],
            'executable_any_size': [{'members': list(c.members), 'cost': c.cost} for c in found.per_members()],
            'instantiations': len(found.coalitions),
            'paper': paper,
        }
        if paper is not None:
            entry['matches_paper'] = (paper['possible'] == entry['possible']
                                      and sorted(paper['executable_costs']) == sorted(entry['executable_costs']))
        table5.append(entry)
        best = found.best
        chosen[robot] = None if best is None else _coalition_entry(best)
        log(f'[coalition-fig7] {robot}: possible {entry["possible"]}, executable {entry["executable"]} '
            f'(costs {", ".join(f"{c:g}" for c in entry["executable_costs"]) or "-"}); chosen: '
            + ('none' if best is None else f'{", ".join(best.members)} at {best.cost:g}'))
    helpers: dict[str, list[str]] = {}
    for robot, coalition in chosen.items():
        for member in (coalition or {}).get('members', [])[1:]:
            helpers.setdefault(member, []).append(robot)
    results = {
        'experiment': 'coalition-fig7',
        'mode': 'core',
        'note': ('core version (no ROS): fiducial readings from a geometric field-of-view/range model over '
                 'the scenario poses, the team search run in one process; the simulated version comes with '
                 'the schema_agent nodes'),
        'scenario': str(scenario.path),
        'task': scenario.task.name,
        'sensors': {s: {'fov_deg': v.fov_deg, 'range_m': v.range_m} for s, v in scenario.sensors.items()},
        'robots': {robot: {'type': scenario.team[robot].name, 'label': pose.label, 'x': pose.x, 'y': pose.y,
                           'heading_deg': pose.heading_deg} for robot, pose in scenario.poses.items()},
        'sightings': [[a, b] for a, b, _ in sightings],
        'table5': table5,
        'matches_paper': all(e.get('matches_paper', True) for e in table5),
        'chosen': chosen,
        'helpers_shared_by_initiators': {h: r for h, r in helpers.items() if len(r) > 1},
        'search': {'executable': executable_info, 'possible': possible_info},
    }
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / 'table5.md').write_text(table5_markdown(results))
    plot_fig7(scenario, sensing, results, run_dir / 'fig7.png')
    results['wall_s'] = round(time.perf_counter() - started, 3)
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2))
    log(f'[coalition-fig7] paper match: {results["matches_paper"]}; {results["wall_s"]:.2f} s')
    return results


def table5_markdown(results: dict) -> str:
    lines = ['Coalitions with two robots (Table V), core version: geometric visibility, no ROS.', '',
             '| robot | possible coalitions | executable coalitions | paper (possible; executable) | chosen |',
             '|---|---|---|---|---|']
    for entry in results['table5']:
        costs = ', '.join(f'{c:g}' for c in entry['executable_costs'])
        partners = ', '.join(entry['executable_partners'])
        paper = entry['paper']
        paper_text = '-' if paper is None else (f'{paper["possible"]}; {len(paper["executable_costs"])} (cost '
                                                f'{", ".join(f"{c:g}" for c in paper["executable_costs"])})')
        chosen = results['chosen'][entry['robot']]
        chosen_text = 'none' if chosen is None else f'{", ".join(chosen["members"])} ({chosen["cost"]:g})'
        lines.append(f'| {entry["robot"]} ({entry["label"]}) | {entry["possible"]} | {entry["executable"]} '
                     f'(cost {costs or "-"}; with {partners or "-"}) | {paper_text} | {chosen_text} |')
    lines += ['', '## How this is computed', '',
              '- Possible: two-robot coalitions found when every fiducial sees every robot (the configuration '
              'ignored, as approaches that know only the robot types of Table IV do). Executable: found with '
              'the scenario\'s poses, field of view and range. Each is counted once per set of members, with '
              'its cheapest cost.',
              '- Coalition cost (footnote 14): the schemas of every robot in the coalition, a CS pair counted '
              'once, plus the MS each helper runs to keep the relative position (6). With the paper\'s costs '
              'a helper the robot sees gives 16 = Table III row 2 (8) + laser (1) + the helper\'s '
              'localisation (1) + its MS (6); a helper that sees the robot gives 17.5 = row 3 (8.5) + laser (1) '
              '+ localisation (1) + the helper\'s fiducial (1) + its MS (6).',
              '- The paper gives no coordinates: the poses in the scenario file are ours, chosen to have the '
              'properties the text states (distant clusters, R behind one helper and seen by another, G seeing '
              'one helper with helper 5 close but out of range, Y seeing two helpers).',
              '- Visibility is purely geometric (field of view and range, no occlusion, no noise) and the '
              'team\'s request/offer exchange runs in one process; the chosen coalition is each robot\'s '
              'cheapest executable one (the negotiation that sets it up belongs to the nodes).',
              '', '## Chosen coalitions', '']
    for robot, chosen in results['chosen'].items():
        lines += ['```', chosen['description'] if chosen else f'{robot}: no executable coalition', '```']
    return '\n'.join(lines) + '\n'


_INITIATOR_COLOURS = ('#d62728', '#2ca02c', '#e6b800', '#1f77b4', '#9467bd', '#8c564b')


def plot_fig7(scenario: Scenario, sensing: GeometricSensing, results: dict, path: Path) -> None:
    """(a) poses, fiducial FOVs and who sees whom; (b) the chosen coalitions and their information flow."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.patches import Ellipse, Wedge

    colours = {robot: _INITIATOR_COLOURS[i % len(_INITIATOR_COLOURS)] for i, robot in enumerate(scenario.initiators)}
    xs = [p.x for p in scenario.poses.values()] + [g[0] for g in scenario.goals.values()]
    ys = [p.y for p in scenario.poses.values()] + [g[1] for g in scenario.goals.values()]
    reach = max((v.range_m for v in scenario.sensors.values()), default=1.0)
    fig, axes = plt.subplots(1, 2, figsize=(17, 8))

    def base(ax, fov: bool) -> None:
        for robot, pose in scenario.poses.items():
            colour = colours.get(robot, '#555555')
            if fov:
                for sensor, view in scenario.sensors.items():
                    if any(s.sensor == sensor for s in scenario.team[robot].sensors):
                        ax.add_patch(Wedge((pose.x, pose.y), view.range_m, pose.heading_deg - view.fov_deg / 2,
                                           pose.heading_deg + view.fov_deg / 2, fc=colour, alpha=0.07, ec=colour,
                                           lw=0.6))
            heading = math.radians(pose.heading_deg)
            ax.annotate('', xy=(pose.x + 1.2 * math.cos(heading), pose.y + 1.2 * math.sin(heading)),
                        xytext=(pose.x, pose.y), arrowprops={'arrowstyle': '->', 'color': 'black', 'lw': 1.2})
            ax.plot(pose.x, pose.y, 'o', ms=15, mfc=colour if robot in colours else 'white', mec='black')
            ax.text(pose.x, pose.y, pose.label, ha='center', va='center', fontsize=9, fontweight='bold')
        for robot, (gx, gy) in scenario.goals.items():
            ax.plot(gx, gy, 's', ms=8, mfc=colours.get(robot, 'grey'), mec='black')
            ax.text(gx + 0.35, gy + 0.35, scenario.poses[robot].label.lower(), fontsize=9)
        ax.set_aspect('equal')
        ax.set_xlim(min(xs) - reach - 0.5, max(xs) + reach + 0.5)
        ax.set_ylim(min(ys) - reach - 0.5, max(ys) + reach + 0.5)
        ax.grid(alpha=0.25)
        ax.set_xlabel('x (m)')
        ax.set_ylabel('y (m)')

    ax = axes[0]
    base(ax, fov=True)
    for observer, seen, _ in sensing.sightings():
        a, b = scenario.poses[observer], scenario.poses[seen]
        ax.annotate('', xy=(b.x, b.y), xytext=(a.x, a.y),
                    arrowprops={'arrowstyle': '->', 'color': '#444444', 'lw': 1.0, 'shrinkA': 9, 'shrinkB': 9,
                                'ls': '--'})
    views = ', '.join(f'{s}: FOV {v.fov_deg:g}°, {v.range_m:g} m' for s, v in scenario.sensors.items())
    ax.set_title(f'(a) poses and headings, {views} (wedges);\ndashed arrow: observer → robot it sees; '
                 f'squares: goals', fontsize=10)

    ax = axes[1]
    base(ax, fov=False)
    for robot, chosen in results['chosen'].items():
        if chosen is None:
            continue
        colour = colours[robot]
        members = [scenario.poses[m] for m in chosen['members']]
        _enclose(ax, members, colour, Ellipse)
        for provider, receiver, instance in _flows(chosen['solution']):
            a, b = scenario.poses[provider], scenario.poses[receiver]
            ax.annotate('', xy=(b.x, b.y), xytext=(a.x, a.y),
                        arrowprops={'arrowstyle': '-|>', 'color': colour, 'lw': 1.8, 'shrinkA': 10, 'shrinkB': 10})
            length = math.hypot(b.x - a.x, b.y - a.y) or 1.0
            normal = (-(b.y - a.y) / length, (b.x - a.x) / length)
            ax.text((a.x + b.x) / 2 + 1.1 * normal[0], (a.y + b.y) / 2 + 1.1 * normal[1], instance, fontsize=8,
                    color=colour, ha='center', va='center',
                    bbox={'boxstyle': 'round,pad=0.15', 'fc': 'white', 'ec': 'none', 'alpha': 0.8})
        pose = scenario.poses[robot]
        ax.text(pose.x, pose.y - 1.6, f'cost {chosen["cost"]:g}', ha='center', fontsize=9, color=colour,
                fontweight='bold')
    ax.set_title('(b) coalitions set up (cheapest executable, ellipses);\narrows: information sent to the '
                 'robot that runs the task', fontsize=10)
    fig.suptitle('Forming executable coalitions (Fig. 7 / Table V) -- core version: geometric visibility, '
                 'no ROS', fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _flows(solution: dict) -> Iterator[tuple[str, str, str]]:
    """(provider, receiver, instance) of every offer in a coalition solution dict."""
    for helper in solution['helpers']:
        if helper['robot'] != solution['robot']:  # a self-request (footnote 10) is no link
            yield helper['robot'], solution['robot'], helper['provides'] or ''
        yield from _flows(helper)


def _enclose(ax, poses: Sequence[Pose], colour: str, ellipse_type) -> None:
    cx = sum(p.x for p in poses) / len(poses)
    cy = sum(p.y for p in poses) / len(poses)
    far = max(poses, key=lambda p: math.hypot(p.x - cx, p.y - cy))
    angle = math.degrees(math.atan2(far.y - cy, far.x - cx))
    half = max(math.hypot(p.x - cx, p.y - cy) for p in poses)
    ax.add_patch(ellipse_type((cx, cy), 2 * half + 1.8, 2.2, angle=angle, fc='none', ec=colour, lw=2.0))


__all__ = [
    'CoalitionConfig', 'FieldOfView', 'GeometricSensing', 'PAPER_TABLE3', 'PaperRow', 'Pose', 'Scenario',
    'configuration_blind', 'load_scenario', 'plot_fig7', 'plot_solution_space', 'run_fig7_core', 'run_table3',
    'scenario_from_dict', 'table3_space',
]
