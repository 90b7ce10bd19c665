"""``coalition-fig9``: a column of robots -- time to find the coalition, messages over time (IQ-ASyMTRe, Fig. 9).

Paper: Section V-A-4 and Fig. 9 (paper ``iq_asymtre_coalitions``, CITATION.cff): the time the robot
at the back of a column takes to find the coalition solution (which must include every robot) as
the column grows, with the paper's link delay N(3.85 ms, 5.05 ms); and the messages four robots
of the ten-robot column send and receive over time. The paper's text gives "about 30 s" for ten
robots (mean of five runs) and "the 28th second" in the run it plots, with fixed 0.2 s gaps (T_G,
T_C) between steps; ours is event-driven. fig9.md puts the paper's values beside ours and
``paper_notes.md`` explains the differences (:data:`PAPER_FIG9`, the paper's Eq. (1)).

One recorded run per column size (``--robots``, default: the column file ``--column``, itself by
default ``config/coalitions/scenarios/fig9_column.yaml``)
with schema_agent nodes on the bridge (:mod:`.sessions`), read back from its bag (:mod:`.column`,
:mod:`.coalition_bag`). The agents run on the wall clock (``use_sim_time`` false): the paper
reports wall-clock times and the bridge may fall behind real time with 20 robots, which would make
simulated stamps understate the wall time.

Acceptance: every column formed a coalition of all its robots, none committed to two coalitions
at once, and (when ten robots ran) the ten-robot column found and formed it within 3 s.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from collab_tools.experiments import plots
from collab_tools.experiments.api import ExperimentRequest, ExperimentResult
from collab_tools.experiments.checkpoint import fresh_step_dir
from collab_tools.experiments.sweep import sweep

from ..core.errors import ConfigError
from ..core.sim_scenarios import COLUMN_TYPES, column_placements
from .coalition_bag import read_coalition_bag
from .column import COLUMN_CONFIG, column_result, load_column_config
from .sessions import AgentSetup, run_session

#: What the paper's text (Section V-A-4) says about Fig. 9; its other points are only in the plot.
#: Reference data for the side-by-side columns and the notes only.
PAPER_FIG9 = {
    'mean_of_runs_s': {10: 30.0},      # "find the coalition involving ten robots (N = 9) in about 30 s"
    'runs_averaged': 5,                # "averaged over five runs"
    'plotted_run_s': {10: 28.0},       # "finds the coalition solution at the 28th second"
    't_g_s': 0.2, 't_c_s': 0.2,        # "when T_G and T_C are set to be 0.2 s"
    'link_delay_ms': (3.85, 5.05),     # T_D ~ N(mu, sigma)
    'p_bound': 11, 's_bound': 10,      # P(r) bounded by 11 (Table III), S(r) by 10
    'maintain_gap_s': 60.0,            # "A 60-s gap is manually inserted" before maintaining
    'stable_after_s': 90.0,            # messages "become stable ... (after the 90th second)"
}


def eq1_gap_terms(robots: int, t_g: float, t_c: float, p: int = 1, s: int = 1) -> float:
    """The fixed gaps of the paper's Eq. (1) for a column of ``robots`` (N = robots - 1 hops): every robot
    of the path checks ``p`` potential solutions in ``s`` spaces, T_G apart, and every hop waits T_C
    both ways: (N + 1) p s T_G + 2 N T_C."""
    hops = robots - 1
    return (hops + 1) * p * s * t_g + 2 * hops * t_c


def eq1_delays(robots: int, mean_delay_s: float) -> float:
    """The link delays of Eq. (1) for the column: a request and an answer on each of the N hops."""
    return 2 * (robots - 1) * mean_delay_s


def run(request: ExperimentRequest) -> ExperimentResult:
    """Fig. 9: one recorded run per column size (``robots`` option, else the config's); fig9.md and
    plots in the run directory, each run in ``n<robots>/``."""
    config_dir, run_dir, log = Path(request.config_dir), Path(request.run_dir), request.log
    column_file = request.option('column')
    if column_file is not None and not Path(column_file).is_file():
        raise ConfigError(f'--column: no file {column_file!r}')
    config = load_column_config(Path(column_file) if column_file else config_dir / 'coalitions' / COLUMN_CONFIG)
    bad = [n for n in request.option('robots') or () if isinstance(n, bool) or not isinstance(n, int) or n < 2]
    if bad:
        raise ConfigError(f'--robots: column sizes must be integers >= 2 (got {bad[0]!r})')
    wanted = tuple(request.option('robots') or config.robots)

    def run_column(case: tuple[int, int]) -> dict:
        index, robots = case
        placements = column_placements(robots, config.spacing_m)
        setup = AgentSetup(leaders=(placements[-1].robot,), search_time_s=config.search_time(robots),
                           settle_time_s=config.settle_time_s, loss_probability=config.loss_probability,
                           link_preset=config.link_preset, use_sim_time=False, seed=index, timeout_s=config.timeout_s,
                           host_processes=config.agent_processes,
                           bridge_control_period=config.bridge_control_period)
        case_dir = fresh_step_dir(run_dir, run_dir / f'n{robots:02d}')   # an interrupted try set aside
        log(f'[coalition-fig9 {index}/{len(wanted)}] column of {robots} robots (search_time '
            f'{setup.search_time_s:g} s) -> {case_dir}')
        began = time.monotonic()
        result = run_session(case_dir, config_dir, f'fig9_column_{robots}', placements, COLUMN_TYPES,
                             config.sensors, setup, log=None)
        row = {'robots': robots, 'run_dir': str(case_dir), 'exit_code': result.exit_code,
               'session_wall_s': round(time.monotonic() - began, 1), 'search_time_s': setup.search_time_s,
               'paper_time_s': config.paper_time_s.get(robots)}
        if result.bag is not None and result.bag.exists():
            row.update(column_result(read_coalition_bag(result.bag), robots))
        else:
            row.update({'state': 'no bag', 'time_s': None, 'formed_s': None})
        return row

    def describe(row: dict) -> str:
        return (f'{row.get("state")}; found after {row.get("time_s")} s, formed after {row.get("formed_s")} s '
                f'(wall, agents\' clocks); {row.get("messages", 0)} logical channel messages in '
                f'{row.get("ros_messages", 0)} ROS messages')

    rows = sweep('coalition-fig9', list(enumerate(wanted, start=1)), run_column, log, name=lambda c: f'{c[1]} robots',
                 describe=describe, request=request)   # each column checkpointed, restored by --resume
    ten = next((r for r in rows if r['robots'] == 10), None)
    acceptance = {'every_column_formed': all(r.get('state') == 'committed' and r.get('includes_all_robots')
                                             for r in rows),
                  'ten_robots_formed_within_3_s': None if ten is None else
                  (ten.get('formed_s') is not None and ten['formed_s'] <= 3.0),
                  'ten_robots_found_within_3_s': None if ten is None else
                  (ten.get('time_s') is not None and ten['time_s'] <= 3.0),
                  'no_conflicting_commitments': all(not r.get('conflicting_commitments') for r in rows)}
    passed = all(v is not False for v in acceptance.values())
    results = {'mode': 'sim', 'config': str(config.path),
               'spacing_m': config.spacing_m,
               'fiducial': {'fov_deg': config.sensors.fiducial_fov_deg, 'range_m': config.sensors.fiducial_range_m},
               'link': {'preset': config.link_preset, 'loss_probability': config.loss_probability},
               'clock': 'wall (agents with use_sim_time false; stamps are the agents\' own)',
               'time_s': {str(r['robots']): r.get('time_s') for r in rows},
               'formed_s': {str(r['robots']): r.get('formed_s') for r in rows},
               'paper_time_s': {str(k): v for k, v in config.paper_time_s.items()},
               'runs': rows}
    run_dir.mkdir(parents=True, exist_ok=True)
    table = fig9_markdown(results, {'passed': passed, **acceptance})
    (run_dir / 'paper_notes.md').write_text(fig9_notes(results))
    plot_fig9(results, run_dir)
    outcome = '; '.join(f'{r["robots"]} robots: {r.get("state")}, found {r.get("time_s")} s, formed '
                        f'{r.get("formed_s")} s' for r in rows)
    return ExperimentResult(passed=passed, outcome=outcome, report=table, acceptance=acceptance, data=results,
                            report_file='fig9.md')


def fig9_markdown(results: dict, acceptance: dict) -> str:
    lines = ['Time for the robot at the back of the column to find / set up its coalition (Fig. 9), wall-clock '
             's from its search start, schema_agent nodes on the bridge, link delay '
             f'{results["link"]["preset"]} (loss {results["link"]["loss_probability"]:g}).', '',
             'The paper\'s values (its text; its other points are only in the plot) are in their own columns; '
             'why ours are far shorter is explained in **paper_notes.md** (same run directory).', '',
             '| robots | found (s) | paper: mean of 5 runs (s) | paper: plotted run (s) | paper\'s Eq. (1) gaps alone, '
             'T_G = T_C = 0.2 s (s) | formed (s) | search_time (s) | state | members | cost | messages '
             '(logical / ROS) |',
             '|---|---|---|---|---|---|---|---|---|---|---|']
    fmt = lambda v: '-' if v is None else f'{v:.3f}'  # noqa: E731
    for r in results['runs']:
        mean = PAPER_FIG9['mean_of_runs_s'].get(r['robots'])
        plotted = PAPER_FIG9['plotted_run_s'].get(r['robots'])
        gaps = eq1_gap_terms(r['robots'], PAPER_FIG9['t_g_s'], PAPER_FIG9['t_c_s'])
        cost = '-' if r.get('cost') is None else f'{r["cost"]:g}'
        lines.append(f'| {r["robots"]} | {fmt(r.get("time_s"))} | {"-" if mean is None else f"~{mean:g}"} | '
                     f'{"-" if plotted is None else f"{plotted:g}"} | >= {gaps:.1f} | {fmt(r.get("formed_s"))} | '
                     f'{r["search_time_s"]:g} | {r.get("state")} | {len(r.get("members", []))} | {cost} | '
                     f'{r.get("messages", 0)} / {r.get("ros_messages", 0)} |')
    lines += ['', '- found: when the back robot first had an executable coalition (its AgentStatus coalition_found '
              'stamp, from the bag); the paper\'s Fig. 9 measures this ("time to find the coalition solution").',
              '- formed: its committed AgentStatus. The node negotiates once its cheapest coalition has not '
              'improved for settle_time, or at search_time at the latest.',
              '- The paper: about 30 s for ten robots (mean of five runs; 28 s in the run it plots) with fixed '
              '0.2 s gaps (T_G, T_C) between steps; ours is event-driven (agents evaluate when channel messages '
              'arrive). "Eq. (1) gaps alone": the least those gaps add for the column by the paper\'s Eq. (1) '
              '(every robot takes its first potential solution in one space); see paper_notes.md.',
              '- messages: logical channel messages (each piggybacked ACK counted as one, retries included) / '
              'ROS messages (AgentMessageBundle: one per agent process and processing step, holding one '
              'AgentMessageBatch per sender and recipient). The link model applies per batch: one delay and one '
              'loss draw per batch, so a loss probability is per batch.',
              f'- Acceptance: {json.dumps(acceptance)}']
    return '\n'.join(lines) + '\n'


def fig9_notes(results: dict) -> str:
    """paper_notes.md: every difference from the paper's Fig. 9 that is not a reproduction failure."""
    p = PAPER_FIG9
    mean_delay = p['link_delay_ms'][0] / 1000.0
    rows = []
    for r in results['runs']:
        n = r['robots']
        rows.append(f"| {n} | {'-' if r.get('time_s') is None else format(r['time_s'], '.3f')} | "
                    f"{'-' if p['mean_of_runs_s'].get(n) is None else '~' + format(p['mean_of_runs_s'][n], 'g')} | "
                    f"{'-' if p['plotted_run_s'].get(n) is None else format(p['plotted_run_s'][n], 'g')} | "
                    f"{eq1_gap_terms(n, p['t_g_s'], p['t_c_s']):.1f} | "
                    f"{eq1_gap_terms(n, p['t_g_s'], p['t_c_s'], p['p_bound'], p['s_bound']):.0f} | "
                    f"{eq1_delays(n, mean_delay) * 1000:.0f} |")
    ten = next((r for r in results['runs'] if r['robots'] == 10), None)
    ours_ten = '-' if ten is None or ten.get('time_s') is None else f"{ten['time_s']:.3f} s"
    return f"""# Fig. 9 beside the paper: what differs and why

Paper: iq_asymtre_coalitions, Section V-A-4 and Fig. 9: a column of robots, only the front one localises, the
back one needs a coalition of all of them. Its text gives one number for the top plot: ten robots (N = 9)
find the coalition "in about 30 s" (the mean of {p['runs_averaged']} runs), and in the run whose messages it
plots, "at the 28th second". Its other points are only in the plot, not in the text, so they are not
compared. Ours, ten robots: {ours_ten} (one run per column size, wall clock).

## 1. The paper's time is mostly its fixed gaps, which we do not have

The paper bounds the search time by its Eq. (1): the link delays T_D along the recursive path, plus
P(r) S(r) T_G for every robot of the path (T_G: "a constant time gap inserted between checking two consecutive
potential solutions"), plus 2 N T_C (T_C: received messages are processed "every T_C seconds"). It sets
T_G = T_C = {p['t_g_s']:g} s, "introduced due to a thread implementation". Ours has no such gaps: an agent
reasons as soon as a channel message arrives (event-driven), so T_G = T_C = 0 and Eq. (1) leaves the delays
and the reasoning time. By the paper's own formula and parameters (N = robots - 1; P = S = 1 is the least,
P <= {p['p_bound']} and S <= {p['s_bound']} the paper's bounds; delays at the mean mu = {p['link_delay_ms'][0]:g} ms):

| robots | ours, found (s) | paper, mean of 5 runs (s) | paper, plotted run (s) | Eq. (1) gaps, P = S = 1 (s) | Eq. (1) gaps, P = 11, S = 10 (s) | Eq. (1) delays (ms) |
|---|---|---|---|---|---|---|
{chr(10).join(rows)}

The paper's 28-30 s for ten robots lies between the least its gaps add and their bound; the delays are tens of
milliseconds. Our times are the delays plus reasoning and the ROS transport, so they are shorter mainly by the
gaps: a difference of implementation that the paper itself attributes to its threads, not a different search.
What can be compared is the shape: {_shape_text(results)}

## 2. Runs and clocks

The paper averages five runs per size; we run each size once (config/coalitions/scenarios/fig9_column.yaml)
with the paper's link delay N({p['link_delay_ms'][0]:g} ms, {p['link_delay_ms'][1]:g} ms) (truncated at 0). Our
times are wall-clock seconds on a 2-core machine shared with other work, from the back robot's search start
to its coalition_found status ("found"); "formed" (committed, after settle_time or search_time) is ours, the
paper reports only finding.

## 3. The message plots

The paper inserts "a 60-s gap" between searching and maintaining and its message counts "become stable ...
after the 90th second". We insert no gap: the coalition is negotiated once its cheapest solution has not
improved for settle_time, and the plot (fig9_messages.png) covers that run's time. Our counts are logical
channel messages (each ACK counted) and the ROS messages that carry them in batches; the paper counts the
messages "addressed to individual robots". The phase delay of the peaks from the front robot backwards, which
the paper describes, is what to look for; absolute counts depend on the transport.
"""


def _shape_text(results: dict) -> str:
    """Whether the time grows with the column, and whether every column formed a coalition of all its robots."""
    timed = sorted((r['robots'], r['time_s']) for r in results['runs'] if r.get('time_s') is not None)
    formed = [r for r in results['runs'] if r.get('state') == 'committed' and r.get('includes_all_robots')]
    parts = []
    if len(timed) >= 2:
        span = f'({timed[0][1]:.3f} s for {timed[0][0]} robots, {timed[-1][1]:.3f} s for {timed[-1][0]})'
        if all(b[1] >= a[1] for a, b in zip(timed, timed[1:])):
            trend = f'the time grows with the column here {span}'
        elif timed[-1][1] > timed[0][1]:
            trend = (f'the time grows with the column overall {span}, though not at every size (one run per '
                     'size on a shared machine)')
        else:
            trend = f'the time does NOT grow with the column here {span}'
        parts.append(trend + ', as the paper expects from the hops the information must travel')
    parts.append(f"{len(formed)} of {len(results['runs'])} columns formed a coalition of all their robots")
    return '; '.join(parts) + '.'


def plot_fig9(results: dict, run_dir: Path) -> None:
    runs = [r for r in results['runs'] if r.get('time_s') is not None]
    fig, ax = plots.figure(9.5, 4.5)
    ax.plot([r['robots'] for r in runs], [r['time_s'] for r in runs], 'o-', label='found (ours)')
    ax.plot([r['robots'] for r in runs if r.get('formed_s') is not None],
            [r['formed_s'] for r in runs if r.get('formed_s') is not None], 's--', label='formed (settle_time / search_time)')
    sizes = sorted({r['robots'] for r in runs})
    if sizes:
        ax.plot(sizes, [eq1_gap_terms(n, PAPER_FIG9['t_g_s'], PAPER_FIG9['t_c_s']) for n in sizes], 'k:',
                label="paper's Eq. (1): its 0.2 s gaps alone (lower bound)")
    for key, marker, label in (('mean_of_runs_s', 'k*', 'paper, mean of 5 runs (text)'),
                               ('plotted_run_s', 'kx', 'paper, the plotted run (text)')):
        points = PAPER_FIG9[key]
        ax.plot(list(points), list(points.values()), marker, ms=11, label=label)
    ax.set_xlabel('robots in the column')
    ax.set_ylabel('wall-clock s from search start')
    ax.set_yscale('log')
    ax.grid(alpha=0.3, which='both')
    plots.legend_outside(ax, fontsize=8)
    ax.set_title('Fig. 9 (top): time for the back robot to find its coalition')
    plots.save(fig, run_dir / 'fig9_time.png', dpi=100)
    largest = max((r for r in runs if 'counts' in r and r['robots'] <= 10), key=lambda r: r['robots'], default=None)
    if largest is None:
        return
    counts = largest['counts']
    robots = list(counts['sent'])
    shown = sorted({robots[0], robots[len(robots) // 3], robots[2 * len(robots) // 3], robots[-1]},
                   key=robots.index)
    fig, axes = plots.figure(10.5, 6.5, rows=2, sharex=True)
    for ax, which in zip(axes, ('sent', 'received')):
        for robot in shown:
            ax.plot(counts['times_s'], counts[which][robot], drawstyle='steps-post', label=robot)
        if largest.get('time_s') is not None:
            ax.axvline(largest['time_s'], color='k', ls=':', label='back robot found its coalition')
        if largest.get('formed_s') is not None:
            ax.axvline(largest['formed_s'], color='k', ls='--', label='coalition set up')
        ax.set_ylabel(f'messages {which} / {counts["bin_s"] * 1000:g} ms')
        ax.grid(alpha=0.3)
    plots.legend_outside(axes[0], fontsize=8)
    axes[1].set_xlabel('wall s from the back robot\'s search start')
    fig.suptitle(f'Fig. 9 (bottom): messages sent and received (addressed to the robot), {largest["robots"]} robots')
    plots.save(fig, run_dir / 'fig9_messages.png', dpi=100)



__all__ = ['PAPER_FIG9', 'eq1_delays', 'eq1_gap_terms', 'fig9_markdown', 'fig9_notes', 'plot_fig9', 'run']
