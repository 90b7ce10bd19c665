"""Solution-space generation time and size against referents and robots (``scripts/bench coalition``).

Two axes, each point timed as the median of ``repeats`` runs on a fresh generator (no memo kept
between repeats):

* **Referents** -- Section IV-H bounds the solution space by the number of referents N_r of the
  information types involved (O(N_t 2^N_r N_c^(N_t 2^N_r))). For N_r = 1..5 we generate the
  navigation MS's space for F_G(local) on Table III's robot (GPS + fiducial) with the relative
  position type F_R given N_r referents -- "referent 1 relative to the frame of referents 2..N_r" --
  and Table I's RPSs generalised to it (:func:`referent_library`):

  - global:      F_G(X) + F_G(V3) + ... + F_G(Vn) + F_R(Y, X, V3..Vn) => F_G(Y)
  - inverse:     F_R(Y, X, V3..Vn) => F_R(X, Y, V3..Vn)              (swap the first two)
  - composition: F_R(X, Z, V3..Vn) + F_R(Y, Z, V3..Vn) => F_R(X, Y, V3..Vn)
  - rotation (N_r >= 3): F_R(Y, V3..Vn, X) => F_R(X, Y, V3..Vn)     (with the inverse, every
    permutation of the referents is reachable, so every referent can become ``local``)

  The fiducial retrieves F_R(X, local, V3..Vn). N_r = 2 is exactly the paper's Table I and Table III
  (11 potential solutions); N_r = 1 has no relative type at all (only the GPS). Sizes are the
  stored and-or DAG nodes and the exact number of potential solutions (counted on the DAG, not
  enumerated); the time to extract the first 10 non-dominated solutions is reported beside it.

* **Robots** -- one robot's space does not depend on the team (it is built with variables), but
  the number of spaces a team builds does: every request with variables is answered by every robot
  (footnote 9) and fully instantiated labels name robots. For N = 2, 5, 10, 20 robots of Table IV
  in two layouts with geometric sensing (:class:`~coalition_agents.core.geometric_sensing.GeometricSensing`):

  - ``column`` (Fig. 9): only the front robot localises; each robot sees only the one in front
    (2 m apart, fiducial 180 deg, 3 m); the last robot initiates the navigation task;
  - ``clusters`` (Fig. 7): clusters of three 12 m apart -- a robot that cannot localise between a
    localising robot it sees and one that sees it; every robot that cannot localise initiates.

  A coalition search (Algorithm 2 for the whole team, :class:`~coalition_agents.core.CoalitionSearch`,
  at most ``potential_solution_limit`` potential solutions checked per space, as the paper's search
  time bounds it) is run once to find which spaces the team generates (the task spaces of the
  initiators and, per robot, one reply space per variant of every request it receives). Those spaces
  are then generated again on a fresh cache and timed: Algorithm 1 plus extracting the solutions the
  search checks. The search's own time and message count are reported too (Fig. 9's trend), but the
  benchmark's subject is generation.
"""
from __future__ import annotations

import json
import statistics
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence

from ..core import (
    CoalitionSearch, Costs, RobotCapabilities, SchemaLibrary, SolutionSpaceCache,
    SolutionSpaceGenerator, Task, addressees, capability_file_from_dict, library_from_dict,
    load_capability_file, request_variants,
)
from ..core.errors import CoalitionError
from ..core.geometric_sensing import FieldOfView, GeometricSensing, Pose
from .configuration import CoalitionConfig

Log = Callable[[str], None]

REFERENTS = (1, 2, 3, 4, 5)
ROBOTS = (2, 5, 10, 20)
LAYOUTS = ('column', 'clusters')
#: Table IV's robot types (type1 cannot localise, type2 can).
TEAM_FILE = 'capabilities/fig7_team.yaml'
TASK = 'navigation'
FIRST_SOLUTIONS = 10


# === Referents ====================================================================================

def referent_library(referents: int) -> tuple[SchemaLibrary, RobotCapabilities]:
    """Table I and Table III's robot with F_R given ``referents`` referents (see the module doc)."""
    if not 1 <= referents <= 9:
        raise CoalitionError(f'referents: must be in 1..9 (got {referents})')
    types = {'F_G': {'referents': 1, 'description': 'global position'}}
    sensors = [{'name': 'gps', 'provides': ['F_G(local)']}]
    reductions = []
    if referents >= 2:
        rest = [f'V{i}' for i in range(3, referents + 1)]

        def relative(*first: str) -> str:
            return f'F_R({", ".join([*first, *rest])})'

        types['F_R'] = {'referents': referents, 'description': 'referent 1 relative to the frame of the others'}
        globals_needed = ' + '.join(f'F_G({v})' for v in ['X', *rest])
        reductions = [
            {'name': 'global_from_relative', 'conversion': f'{globals_needed} + {relative("Y", "X")} => F_G(Y)'},
            {'name': 'relative_inverse', 'conversion': f'{relative("Y", "X")} => {relative("X", "Y")}'},
            {'name': 'relative_composition',
             'conversion': f'{relative("X", "Z")} + {relative("Y", "Z")} => {relative("X", "Y")}'},
        ]
        if referents >= 3:
            rotated = f'F_R({", ".join(["Y", *rest, "X"])})'
            reductions.append({'name': 'referent_rotation', 'conversion': f'{rotated} => {relative("X", "Y")}'})
        sensors.append({'name': 'fiducial', 'provides': [relative('X', 'local')]})
    library = library_from_dict({'information_types': types, 'reduction_schemas': reductions}, 'library')
    capabilities = capability_file_from_dict(
        {'robot_types': {'table3': {'sensors': sensors, 'motor_schemas': ['navigate']}}}, library, 'team')
    return library, capabilities.types['table3']


def _median_ms(samples: Sequence[float]) -> float:
    return round(statistics.median(samples) * 1e3, 3)


def bench_referents(costs: Costs, counts: Sequence[int], repeats: int, log: Log, progress) -> list[dict]:
    rows = []
    for referents in counts:
        library, robot = referent_library(referents)
        requirement = [library.parse('F_G(local)')]
        times, first_times = [], []
        space = generator = None
        for _ in range(repeats):
            begin = time.perf_counter()
            generator = SolutionSpaceGenerator(library, robot, costs)
            space = generator.motor_schema_space('navigate', requirement)
            middle = time.perf_counter()
            first = space.potential_solutions(FIRST_SOLUTIONS)
            end = time.perf_counter()
            times.append(middle - begin)
            first_times.append(end - middle)
        assert space is not None and generator is not None
        row = {
            'referents': referents,
            'rps': [conversion.text() for conversion in library.reductions],
            'generation_ms': _median_ms(times),
            'generation_ms_samples': [round(t * 1e3, 3) for t in times],
            'first_solutions_ms': _median_ms(first_times),
            'stored_nodes': space.distinct_node_count(),
            'schema_nodes': generator.stats.schema_nodes,
            'requirement_expansions': generator.stats.expansions,
            'potential_solutions': space.count_potential_solutions(),
            'first_costs': [s.cost for s in first],
        }
        rows.append(row)
        log(f'[bench coalition {progress()}] referents {referents}: generation {row["generation_ms"]:.2f} ms '
            f'(median of {repeats}), {row["stored_nodes"]} stored nodes, {row["potential_solutions"]:.4g} '
            f'potential solutions, first {len(first)} in {row["first_solutions_ms"]:.2f} ms')
    return rows


# === Robots =======================================================================================

@dataclass(frozen=True)
class Layout:
    team: dict[str, RobotCapabilities]
    poses: dict[str, Pose]
    fields_of_view: dict[str, FieldOfView]
    initiators: tuple[str, ...]


def column_layout(types: Mapping[str, RobotCapabilities], robots: int) -> Layout:
    """Fig. 9: a column facing +y, 2 m apart; only the front robot (robot_1) localises."""
    names = [f'robot_{i}' for i in range(1, robots + 1)]
    team = {name: types['type2' if i == 0 else 'type1'] for i, name in enumerate(names)}
    poses = {name: Pose(0.0, -2.0 * i, 90.0, str(i + 1)) for i, name in enumerate(names)}
    return Layout(team, poses, {'fiducial': FieldOfView(180.0, 3.0)}, (names[-1],))


def cluster_layout(types: Mapping[str, RobotCapabilities], robots: int) -> Layout:
    """Fig. 7-like clusters of three, 12 m apart: a type1 robot, a type2 it sees, a type2 that sees it."""
    roles = (('type1', 0.0, 0.0), ('type2', 2.5, 0.5), ('type2', -2.0, -0.5))
    team, poses, initiators = {}, {}, []
    for index in range(robots):
        cluster, role = divmod(index, len(roles))
        kind, dx, dy = roles[role]
        name = f'robot_{index + 1}'
        team[name] = types[kind]
        poses[name] = Pose(12.0 * cluster + dx, dy, 0.0, str(index + 1))
        if kind == 'type1':
            initiators.append(name)
    return Layout(team, poses, {'fiducial': FieldOfView(180.0, 4.0)}, tuple(initiators))


LAYOUT_BUILDERS = {'column': column_layout, 'clusters': cluster_layout}


def spaces_generated(search: CoalitionSearch, task: Task, initiators: Sequence[str]) -> dict[str, list]:
    """Per robot, what it built a space for in ``search``: None for its task, else the request variants."""
    sent = [label for agent in search.agents.values() for label in agent.reasoner.ledger.sent]
    spaces: dict[str, list] = {robot: ([None] if robot in initiators else []) for robot in search.team}
    for robot in search.team:
        variants: dict = {}
        for label in sent:
            if robot in addressees(label, search.team):
                variants.update(dict.fromkeys(request_variants(label, robot)))
        spaces[robot].extend(variants)
    return spaces


def generate_team_spaces(config: CoalitionConfig, team: Mapping[str, RobotCapabilities], task: Task,
                         spaces: Mapping[str, list], limit: int | None) -> dict:
    """Build every space of ``spaces`` on a fresh cache and extract the solutions a search checks."""
    cache = SolutionSpaceCache(config.library, config.costs)
    generators = {}
    stored = potential = checked = 0
    for robot, wanted in spaces.items():
        generator = cache.generator(team[robot], task.prior_sensors)
        generators[id(generator)] = generator
        for variant in wanted:
            space = (generator.motor_schema_space(task.motor_schema, task.requirements()) if variant is None
                     else generator.request_space(variant))
            checked += len(space.potential_solutions(limit))
            stored += space.distinct_node_count()
            potential += space.count_potential_solutions()
    return {'generators': len(generators),
            'stored_nodes': sum(g.stats.schema_nodes + g.stats.expansions for g in generators.values()),
            'nodes_per_space_sum': stored, 'potential_solutions': potential, 'checked_solutions': checked}


def bench_robots(config: CoalitionConfig, layouts: Sequence[str], counts: Sequence[int], repeats: int,
                 limit: int | None, log: Log, progress) -> list[dict]:
    types = load_capability_file(config.directory / TEAM_FILE, config.library).types
    task = config.task(TASK)
    rows = []
    for layout_name in layouts:
        if layout_name not in LAYOUT_BUILDERS:
            raise CoalitionError(f'layouts: unknown layout {layout_name!r} (known: {", ".join(LAYOUT_BUILDERS)})')
        for robots in counts:
            layout = LAYOUT_BUILDERS[layout_name](types, robots)
            sensing = GeometricSensing(layout.team, layout.poses, layout.fields_of_view)
            begin = time.perf_counter()
            search = CoalitionSearch(config.library, config.costs, task, layout.team, sensing,
                                     potential_solution_limit=limit)
            results = search.run(layout.initiators)
            search_s = time.perf_counter() - begin
            spaces = spaces_generated(search, task, layout.initiators)
            counted = sum(len(v) for v in spaces.values())
            if counted != sum(search.stats.solution_spaces.values()):
                raise CoalitionError(f'{layout_name} {robots}: reconstructed {counted} spaces, the search built '
                                     f'{sum(search.stats.solution_spaces.values())}')
            times, sizes = [], {}
            for _ in range(repeats):
                start = time.perf_counter()
                sizes = generate_team_spaces(config, layout.team, task, spaces, limit)
                times.append(time.perf_counter() - start)
            found = [r.best for r in results.values() if r.best is not None]
            row = {
                'layout': layout_name, 'robots': robots, 'initiators': len(layout.initiators),
                'solution_spaces': counted,
                'generation_ms': _median_ms(times),
                'generation_ms_samples': [round(t * 1e3, 3) for t in times],
                **sizes,
                'search_s': round(search_s, 3), 'messages': search.stats.messages,
                'coalitions_found': len(found),
                'largest_coalition': max((len(c.members) for c in found), default=0),
                'best_costs': [c.cost for c in found],
            }
            rows.append(row)
            log(f'[bench coalition {progress()}] {layout_name} {robots} robots: {counted} spaces generated in '
                f'{row["generation_ms"]:.1f} ms (median of {repeats}), {row["stored_nodes"]} stored nodes, '
                f'{row["potential_solutions"]} potential solutions; search {search_s:.2f} s, '
                f'{row["messages"]} messages, {row["coalitions_found"]}/{len(layout.initiators)} initiators with a '
                f'coalition (largest {row["largest_coalition"]} robots)')
    return rows


# === Entry point ==================================================================================

def run_benchmark(config_dir: str | Path, out_dir: str | Path, log: Log = print, *,
                  referents: Sequence[int] = REFERENTS, robots: Sequence[int] = ROBOTS,
                  layouts: Sequence[str] = LAYOUTS, repeats: int = 3,
                  potential_solution_limit: int | None = 4) -> dict:
    """Both axes; results.json and coalition_bench.png in ``out_dir``."""
    if repeats < 1:
        raise CoalitionError(f'repeats: must be >= 1 (got {repeats})')
    if potential_solution_limit is not None and potential_solution_limit < 1:
        raise CoalitionError(f'potential_solution_limit: must be >= 1 or None (got {potential_solution_limit})')
    started = time.perf_counter()
    config = CoalitionConfig.load(config_dir)
    total = len(referents) + len(layouts) * len(robots)
    step = [0]

    def progress() -> str:
        step[0] += 1
        return f'{step[0]}/{total}'

    referent_rows = bench_referents(config.costs, referents, repeats, log, progress)
    robot_rows = bench_robots(config, layouts, robots, repeats, potential_solution_limit, log, progress)
    results = {
        'benchmark': 'coalition',
        'settings': {'repeats': repeats, 'potential_solution_limit': potential_solution_limit,
                     'referents': list(referents), 'robots': list(robots), 'layouts': list(layouts),
                     'first_solutions': FIRST_SOLUTIONS},
        'referents': referent_rows,
        'robots': robot_rows,
    }
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    plot_benchmark(results, out_dir / 'coalition_bench.png')
    results['wall_s'] = round(time.perf_counter() - started, 3)
    (out_dir / 'results.json').write_text(json.dumps(results, indent=2))
    return results


def plot_benchmark(results: dict, path: Path) -> None:
    from matplotlib.ticker import NullFormatter

    from collab_tools.experiments import plots

    fig, axes = plots.figure(12, 8.5, rows=2, columns=2)
    by_referents = results['referents']
    if by_referents:
        n = [r['referents'] for r in by_referents]
        ax = axes[0][0]
        ax.plot(n, [r['generation_ms'] for r in by_referents], 'o-', label='Algorithm 1 (space)')
        ax.plot(n, [r['first_solutions_ms'] for r in by_referents], 's--',
                label=f'first {results["settings"]["first_solutions"]} potential solutions')
        ax.set_ylabel('time (ms, median)')
        ax.set_title('F_G(local) on Table III\'s robot vs referents of F_R')
        ax = axes[1][0]
        ax.plot(n, [r['stored_nodes'] for r in by_referents], 'o-', label='stored and-or nodes')
        ax.plot(n, [r['potential_solutions'] for r in by_referents], 's--', label='potential solutions')
        ax.set_ylabel('size')
        for ax in (axes[0][0], axes[1][0]):
            ax.set_xlabel('referents of the relative type (N_r)')
            ax.set_xticks(n)
    by_robots = results['robots']
    limit = results['settings']['potential_solution_limit']
    for layout, marker in zip(results['settings']['layouts'], ('o-', 's--', '^-.')):
        rows = [r for r in by_robots if r['layout'] == layout]
        if not rows:
            continue
        n = [r['robots'] for r in rows]
        axes[0][1].plot(n, [r['generation_ms'] for r in rows], marker, label=f'{layout}: generation')
        axes[0][1].plot(n, [r['search_s'] * 1e3 for r in rows], marker, alpha=0.4, label=f'{layout}: whole search')
        axes[1][1].plot(n, [r['solution_spaces'] for r in rows], marker, label=f'{layout}: spaces')
        axes[1][1].plot(n, [r['stored_nodes'] for r in rows], marker, alpha=0.4, label=f'{layout}: stored nodes')
    axes[0][1].set_ylabel('time (ms)')
    axes[0][1].set_title(f'A team\'s solution spaces vs robots (limit {limit} per space)')
    axes[1][1].set_ylabel('size')
    for ax in (axes[0][1], axes[1][1]):
        ax.set_xlabel('robots')
        ax.set_xscale('log')
        ax.set_xticks(results['settings']['robots'])
        ax.set_xticklabels([str(n) for n in results['settings']['robots']])
        ax.xaxis.set_minor_formatter(NullFormatter())
    for ax in axes.flat:
        ax.set_yscale('log')
        ax.grid(alpha=0.3, which='both')
        if ax.lines:
            ax.legend(fontsize=8)
    fig.suptitle('IQ-ASyMTRe solution-space generation (core, one process)')
    plots.save(fig, path)


__all__ = ['LAYOUTS', 'REFERENTS', 'ROBOTS', 'bench_referents', 'bench_robots', 'cluster_layout', 'column_layout',
           'generate_team_spaces', 'referent_library', 'run_benchmark', 'spaces_generated']
