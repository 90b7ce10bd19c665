"""The Fig. 7 drawings: the clusters with their fields of view and sightings, and the coalitions set up.

Paper: Fig. 7 (paper ``iq_asymtre_coalitions``, CITATION.cff): (a) the robots, the fiducials'
semicircular fields of view and an arrow where one robot sees another; (b) the coalitions set up,
as ellipses. :func:`plot_fig7` draws both from the core run, :func:`plot_fig7_sim` draws (b) from
the coalitions the schema_agent nodes set up in simulation.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Iterator, Sequence

from collab_tools.experiments import plots
from collab_tools.experiments.plots import plt
from matplotlib.patches import Ellipse, Polygon, Wedge

from ..core.geometric_sensing import GeometricSensing, Pose
from .configuration import Scenario

_INITIATOR_COLOURS = ('#d62728', '#2ca02c', '#e6b800', '#1f77b4', '#9467bd', '#8c564b')


def plot_fig7(scenario: Scenario, sensing: GeometricSensing, results: dict, path: Path) -> None:
    """(a) poses, fiducial FOVs and who sees whom; (b) the chosen coalitions and their information flow."""
    colours = {robot: _INITIATOR_COLOURS[i % len(_INITIATOR_COLOURS)] for i, robot in enumerate(scenario.initiators)}
    xs = [p.x for p in scenario.poses.values()] + [g[0] for g in scenario.goals.values()]
    ys = [p.y for p in scenario.poses.values()] + [g[1] for g in scenario.goals.values()]
    views = scenario.views()
    reach = max((v.range_m for per_robot in views.values() for v in per_robot.values()), default=1.0)
    fig, axes = plt.subplots(1, 2, figsize=(17, 8))

    def base(ax, fov: bool) -> None:
        draw_obstacles(ax, scenario)
        for robot, pose in scenario.poses.items():
            colour = colours.get(robot, '#555555')
            if fov:
                for view in views[robot].values():
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
    shown = ', '.join(sorted({f'{s}: FOV {v.fov_deg:g}°, {v.range_m:g} m'
                              for per_robot in views.values() for s, v in per_robot.items()}))
    ax.set_title(f'(a) poses and headings, {shown} (wedges);\ndashed arrow: observer → robot it sees; '
                 f'squares: goals', fontsize=10)

    ax = axes[1]
    base(ax, fov=False)
    for robot, chosen in results['chosen'].items():
        if chosen is None:
            continue
        colour = colours[robot]
        members = [scenario.poses[m] for m in chosen['members']]
        _enclose(ax, members, colour)
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
    plots.save(fig, path, dpi=100)


def _flows(solution: dict) -> Iterator[tuple[str, str, str]]:
    """(provider, receiver, instance) of every offer in a coalition solution dict."""
    for helper in solution['helpers']:
        if helper['robot'] != solution['robot']:  # a self-request (footnote 10) is no link
            yield helper['robot'], solution['robot'], helper['provides'] or ''
        yield from _flows(helper)


def _enclose(ax, poses: Sequence[Pose], colour: str) -> None:
    """An ellipse around ``poses`` (one coalition)."""
    cx = sum(p.x for p in poses) / len(poses)
    cy = sum(p.y for p in poses) / len(poses)
    far = max(poses, key=lambda p: math.hypot(p.x - cx, p.y - cy))
    angle = math.degrees(math.atan2(far.y - cy, far.x - cx))
    half = max(math.hypot(p.x - cx, p.y - cy) for p in poses)
    ax.add_patch(Ellipse((cx, cy), 2 * half + 1.8, 2.2, angle=angle, fc='none', ec=colour, lw=2.0))




def draw_obstacles(ax, scenario: Scenario) -> None:
    """The scenario's obstacles: dark if they block lines of sight, light if lower than the sensor."""
    for box in scenario.obstacles.boxes:
        occludes = box in scenario.obstacles.occluding
        ax.add_patch(Polygon(box.corners(), closed=True, fc='#333333' if occludes else '#bbbbbb', ec='black',
                             lw=0.5, alpha=0.8))


def plot_fig7_sim(scenario: Scenario, results: dict, path: Path) -> None:
    """The poses and the coalitions the nodes set up (ellipse per coalition), with their costs."""
    colours = ('#d62728', '#2ca02c', '#e6b800', '#1f77b4', '#9467bd')
    fig, ax = plt.subplots(figsize=(9, 8))
    views = scenario.views()
    draw_obstacles(ax, scenario)
    for robot, pose in scenario.poses.items():
        for view in views[robot].values():
            ax.add_patch(Wedge((pose.x, pose.y), view.range_m, pose.heading_deg - view.fov_deg / 2,
                               pose.heading_deg + view.fov_deg / 2, fc='grey', alpha=0.06, ec='grey', lw=0.5))
        ax.plot(pose.x, pose.y, 'o', ms=15, mfc='white', mec='black')
        ax.text(pose.x, pose.y, pose.label, ha='center', va='center', fontsize=9, fontweight='bold')
    for index, row in enumerate(results['leaders']):
        if row['state'] != 'committed':
            continue
        colour = colours[index % len(colours)]
        _enclose(ax, [scenario.poses[m] for m in row['members']], colour)
        pose = scenario.poses[row['robot']]
        ax.text(pose.x, pose.y - 1.6, f'cost {row["cost"]:g}', ha='center', color=colour, fontweight='bold')
    ax.set_aspect('equal')
    ax.autoscale()
    ax.margins(0.15)
    ax.grid(alpha=0.25)
    ax.set_title(f'Fig. 7(b) in simulation: coalitions set up by the schema_agent nodes '
                 f'(loss {results["loss_probability"]:g})', fontsize=10)
    fig.tight_layout()
    plots.save(fig, path, dpi=100)


__all__ = ['plot_fig7', 'plot_fig7_sim']
