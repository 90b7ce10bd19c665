"""What Tables III and IV write besides results.json: the breakdown tables (Markdown) and the figures
(example problems on their maps, one measure per environment)."""
from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from collab_tools.experiments import plots

from ..core.assignment import AssignmentResult
from ..core.environment import Environment, RobotEnvironment
from .gp_sweep import Evaluated, number_text, percent
from .problems import Problem


def breakdown_markdown(results: dict, methods: tuple[str, ...], short: dict[str, str],
                        second: str) -> list[str]:
    """Per-environment and per-sigma_obs tables: feasibility, ``second`` and iterations per method."""
    columns = [f'{short[m]} {name}' for m in methods for name in ('feasibility', second, 'iterations')]
    lines = []
    for heading, first, breakdown in (('Per environment', 'environment', results['per_environment']),
                                      ('Per sigma_obs', 'sigma_obs', results['per_sigma'])):
        lines += ['', f'## {heading}', '', f"| {first} | {' | '.join(columns)} |",
                  '|' + '---|' * (len(columns) + 1)]
        for key, row in breakdown.items():
            lines.append(f'| {key} | ' + ' | '.join(
                f"{percent(row[m]['feasibility'])} | {number_text(row[m][second])} | {number_text(row[m]['iterations'], 3)}"
                for m in methods) + ' |')
    return lines


def closing_markdown(results: dict, acceptance: str) -> list[str]:
    return (['', '## Definitions', ''] + [f'- **{k}**: {v}.' for k, v in results['definitions'].items()]
            + ['', f"Acceptance: {acceptance}.", ''])



def _suptitle(fig, text: str, columns: int) -> None:
    fig.suptitle(textwrap.fill(text, max(60, 45 * columns)), fontsize=9)



def _draw_map(ax, environment: Environment, views: list[RobotEnvironment]) -> None:
    """Obstacles black, the largest robot's inflation margin grey, free space white (y up)."""
    shade = np.ones(environment.shape)
    for view in views:
        shade = np.where(view.inflated, 0.75, shade)
    shade = np.where(environment.occupied, 0.0, shade)
    x0, y0, x1, y1 = environment.frame.bounds
    ax.imshow(shade, origin='lower', extent=(x0, x1, y0, y1), cmap='gray', vmin=0.0, vmax=1.0,
              interpolation='nearest')
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect('equal')
    ax.set_xticks([])
    ax.set_yticks([])


def _draw_team(ax, problem: Problem, evaluated: Evaluated, assignment: AssignmentResult | None) -> None:
    from matplotlib.patches import Circle
    colours = ['tab:red', 'tab:blue', 'tab:orange', 'tab:purple', 'tab:brown', 'tab:cyan', 'tab:pink', 'tab:olive']
    for agent in problem.agents:
        ax.add_patch(Circle(agent.position, max(agent.robot_type.radius, 0.03), facecolor='limegreen',
                            edgecolor='darkgreen', zorder=3))
    largest = max(a.robot_type.radius for a in problem.agents)
    for role in problem.roles:
        ax.add_patch(Circle(role.destination, max(largest, 0.03), facecolor='none', edgecolor='blue', lw=1.2, zorder=3))
    if assignment is None or not assignment.feasible:
        return
    for k, (a, r) in enumerate(assignment.pairs):
        plan = evaluated.plan(a, r)
        colour = colours[k % len(colours)]
        ax.plot(plan.trajectory[:, 0], plan.trajectory[:, 1], '-', color=colour, lw=1.2, zorder=4)
        if not plan.collision_free:
            view = evaluated.negotiation.robot_envs[problem.agents[a].robot_type.name]
            inside = view.sdf.distance(plan.trajectory[:, :2]) < 0.0
            ax.plot(plan.trajectory[inside, 0], plan.trajectory[inside, 1], 'x', color='red', ms=5, zorder=5)




def plot_examples(panels: list[list[tuple]], row_labels: list[str], title: str, path: Path) -> None:
    """Rows of example problems (one column per environment): each panel is (environment, problem,
    evaluated, assignment, panel title)."""
    columns = len(panels[0])
    fig, axes = plots.figure(max(3.0 * columns, 4.0), 7.0, rows=len(panels), columns=columns, squeeze=False)
    for row, panel_row in enumerate(panels):
        for column, (environment, problem, evaluated, assignment, panel_title) in enumerate(panel_row):
            ax = axes[row][column]
            _draw_map(ax, environment, list(evaluated.negotiation.robot_envs.values()))
            _draw_team(ax, problem, evaluated, assignment)
            ax.set_title(panel_title, fontsize=8)
            if column == 0:
                ax.set_ylabel(row_labels[row], fontsize=9)
    _suptitle(fig, title, columns)
    plots.save(fig, path)


def plot_per_environment(results: dict, methods, labels, measure: str, ylabel: str, title: str, path: Path,
                          as_percent: bool = False, log_scale: bool = False,
                          paper: dict[str, float] | None = None) -> None:
    """One bar per environment and method: ``measure`` of the per-environment breakdown, with the
    paper's overall value of each method as a dashed line (``paper``; the paper gives no per-environment
    values). The legend sits right of the axes, never over the bars; the title wraps."""
    envs = list(results['per_environment'])
    fig, ax = plots.figure(1.3 * len(envs) + 4.5, 3.8)
    width = 0.8 / len(methods)
    colours = {}
    for k, method in enumerate(methods):
        values = [results['per_environment'][e][method][measure] for e in envs]
        values = [(100.0 * v if as_percent else v) if v is not None else np.nan for v in values]
        bars = ax.bar(np.arange(len(envs)) + (k - (len(methods) - 1) / 2) * width, values, width,
                      label=f'{labels[method]} (ours)')
        colours[method] = bars.patches[0].get_facecolor() if bars.patches else None
    for method, value in (paper or {}).items():
        ax.axhline(100.0 * value if as_percent else value, color=colours.get(method), ls='--', lw=1.2,
                   label=f"{labels[method]}: paper, overall ({f'{100.0 * value:.2f} %' if as_percent else f'{value:g}'})")
    ax.set_xticks(np.arange(len(envs)), envs)
    ax.set_ylabel(ylabel)
    if log_scale:
        ax.set_yscale('log')
    ax.set_title(textwrap.fill(title, 70), fontsize=10)
    ax.grid(axis='y', alpha=0.3, which='both' if log_scale else 'major')
    plots.legend_outside(ax, fontsize=8)
    plots.save(fig, path)
