"""Plots for run reports (matplotlib, Agg backend), with a registry.

Other subsystems add plots for their own message types without editing this
module::

    from collab_tools.core.report_plots import register_plot

    def plot_scans(bag, summary, out_dir):
        ...  # read with bag_analysis.read_messages(bag, topics)
        return [out_dir / 'scans.png']

    register_plot('scans', {'sensor_msgs/msg/LaserScan'}, plot_scans)

A plot registered with an empty ``type_names`` runs for every bag.
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use('Agg')

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402

from .bag_analysis import BagSummary, read_messages, read_timestamps  # noqa: E402
from .bag_types import normalize_type_name  # noqa: E402
from .scene_layout import Rect, SceneLayout, scene_of_bag  # noqa: E402

__all__ = [
    'PlotFn',
    'PlotError',
    'registered_plots',
    'register_plot',
    'draw_scene',
    'frame_scene',
    'robot_colours',
    'unregister_plot',
    'write_plots',
]

PlotFn = Callable[[Path, BagSummary, Path], list[Path]]

BODY_STATES_TYPE = 'bridge_interfaces/msg/BodyStates'
TWIST_TYPE = 'geometry_msgs/msg/Twist'
ROLE_ASSIGNMENT_TYPE = 'role_interfaces/msg/RoleAssignment'
MOBILE_ROBOT_KIND = 'mobile_robot'
#: Bodies robots push: their paths are drawn too (dashed), from the scene's place to where they ended.
MOVABLE_KIND = 'movable_box'


@dataclass(frozen=True)
class _Plot:
    name: str
    type_names: frozenset[str]
    fn: PlotFn


_REGISTRY: dict[str, _Plot] = {}


class PlotError(RuntimeError):
    """One or more plots failed (the others were still written)."""


def register_plot(name: str, type_names: set[str], fn: PlotFn) -> None:
    """Register (or replace) plot ``name``: ``fn(bag, summary, out_dir) -> [pngs]``.

    It is called for a bag that has a topic of one of ``type_names``
    ('pkg/msg/Name' or 'pkg/Name'); an empty set means every bag.
    """
    if not name or not isinstance(name, str):
        raise ValueError(f'register_plot: invalid plot name {name!r}')
    if not callable(fn):
        raise TypeError(f'register_plot({name!r}): fn is not callable')
    if isinstance(type_names, str):
        type_names = {type_names}
    _REGISTRY[name] = _Plot(name, frozenset(normalize_type_name(t) for t in type_names), fn)


def unregister_plot(name: str) -> None:
    _REGISTRY.pop(name, None)


def registered_plots() -> dict[str, set[str]]:
    """Registered plot names -> the type names that trigger them (empty: every bag)."""
    return {p.name: set(p.type_names) for p in _REGISTRY.values()}


def write_plots(bag: Path, summary: BagSummary, out_dir: Path, *, strict: bool = False) -> list[Path]:
    """Run every applicable registered plot; return the PNGs written.

    A failing plot is reported on stderr and skipped (``strict=True`` raises
    :class:`PlotError` after running the others).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    present = summary.type_names
    written: list[Path] = []
    failures: list[str] = []
    for plot in list(_REGISTRY.values()):
        if plot.type_names and not (plot.type_names & present):
            continue
        try:
            paths = plot.fn(Path(bag), summary, out_dir) or []
        except Exception as exc:  # noqa: BLE001 - one broken plot must not sink the report
            failures.append(f'{plot.name}: {type(exc).__name__}: {exc}')
            print(f'report_plots: plot {plot.name!r} failed: {type(exc).__name__}: {exc}', file=sys.stderr)
            continue
        finally:
            plt.close('all')
        written.extend(Path(p) for p in paths)
    if strict and failures:
        raise PlotError('; '.join(failures))
    return written


# ---------------------------------------------------------------- helpers
def _slug(text: str) -> str:
    return re.sub(r'[^A-Za-z0-9]+', '_', text).strip('_') or 'root'


def _figure(width: float, height: float, **keywords):
    """(fig, ax) with a constrained layout: long titles and outside legends fit."""
    return plt.subplots(figsize=(width, height), layout='constrained', **keywords)


def _save(fig, path: Path) -> Path:
    fig.savefig(path, dpi=100, bbox_inches='tight')   # nothing clipped, whatever the legend's size
    plt.close(fig)
    return path


def _legend_outside(ax, **keywords) -> None:
    """A legend right of the axes, where it covers no data."""
    ax.legend(loc='upper left', bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize='small', **keywords)


def _stamp_s(summary: BagSummary, ns: int) -> float:
    return (ns - summary.start_ns) / 1e9


def _rect_patch(rect: Rect, **keywords) -> Rectangle:
    (cx, cy), (sx, sy) = rect.center, rect.size
    return Rectangle((cx - sx / 2, cy - sy / 2), sx, sy, angle=math.degrees(rect.yaw), rotation_point='center',
                     **keywords)


def draw_scene(ax, layout: SceneLayout | None) -> None:
    """Walls, obstacles (a map's boxes too), tables with their grids, movable boxes and targets, in the
    simulation's colours, under whatever is drawn next (zorder 1)."""
    if layout is None:
        return
    for rect in layout.walls:
        ax.add_patch(_rect_patch(rect, facecolor=rect.color, edgecolor='none', zorder=1))
    for rect in layout.obstacles:
        ax.add_patch(_rect_patch(rect, facecolor=rect.color, edgecolor='black', linewidth=0.3, zorder=1))
    for rect in layout.movable_boxes:
        ax.add_patch(_rect_patch(rect, facecolor=rect.color, edgecolor='black', hatch='//', alpha=0.6, zorder=1))
    for table in layout.tables:
        (cx, cy), (sx, sy) = table.center, table.size
        ax.add_patch(Rectangle((cx - sx / 2, cy - sy / 2), sx, sy, facecolor=table.color, edgecolor='black',
                               alpha=0.5, zorder=1))
        for col in range(1, table.cols):
            x = cx - sx / 2 + col * sx / table.cols
            ax.plot([x, x], [cy - sy / 2, cy + sy / 2], color='black', linewidth=0.5, zorder=1)
        for row in range(1, table.rows):
            y = cy + sy / 2 - row * sy / table.rows
            ax.plot([cx - sx / 2, cx + sx / 2], [y, y], color='black', linewidth=0.5, zorder=1)
    for target in layout.targets:
        ax.add_patch(Circle(target.center, target.radius, facecolor=target.color, edgecolor='black', zorder=1))
        ax.annotate(target.name, target.center, xytext=(4, 4), textcoords='offset points', fontsize=7, zorder=1)


def frame_scene(ax, layout: SceneLayout | None) -> None:
    """Equal aspect; the whole arena (walls included) in view when the scene gives its bounds."""
    if layout is not None and layout.bounds is not None:
        xmin, ymin, xmax, ymax = layout.bounds
        margin = 0.1 + (layout.walls[0].size[1] if layout.walls else 0.0)
        ax.set_xlim(xmin - margin, xmax + margin)
        ax.set_ylim(ymin - margin, ymax + margin)
    ax.set_aspect('equal', adjustable='box')


def robot_colours(names, layout: SceneLayout | None) -> dict[str, tuple]:
    """Each robot's colour in the simulation (from the scenario), else one of matplotlib's cycle."""
    cycle = plt.rcParams['axes.prop_cycle'].by_key().get('color', ['C0'])
    colours = {}
    for index, name in enumerate(sorted(names)):
        colour = layout.robot_color(name) if layout is not None else None
        colours[name] = tuple(colour) if colour is not None else cycle[index % len(cycle)]
    return colours


def formation_targets(bag: Path, summary: BagSummary) -> dict[str, tuple[float, float]]:
    """robot -> goal of the last assigned round of any RoleAssignment topic ({} without one); of the last
    engine session recorded (bag order)."""
    goals: dict[str, tuple[float, float]] = {}
    topics = summary.topics_of_type(ROLE_ASSIGNMENT_TYPE)
    if not topics:
        return goals
    best, session = -1, None
    for _topic, _ns, msg in read_messages(bag, topics):
        if getattr(msg, 'session', 0) != session:      # a restarted role engine counts its rounds anew
            best, session = -1, getattr(msg, 'session', 0)
        if msg.status == 'assigned' and msg.round >= best:
            best = msg.round
            goals = {r: (float(x), float(y)) for r, x, y in zip(msg.robots, msg.goal_x, msg.goal_y)}
    return goals


# ---------------------------------------------------------------- built-ins
def _rate_bins(duration: float) -> tuple[float, int]:
    if duration <= 0:
        return 1.0, 1
    # ~1 s bins; finer for short bags (>= ~10 bins), coarser for long ones (<= 200 bins).
    bin_s = 1.0 if duration >= 10 else duration / 10
    if duration / bin_s > 200:
        bin_s = duration / 200
    return bin_s, max(1, math.ceil(duration / bin_s - 1e-9))


def plot_message_rates(bag: Path, summary: BagSummary, out_dir: Path) -> list[Path]:
    """Messages per second over time, one line per topic, binned, on a log scale (so /clock's
    hundreds per second do not flatten a 1 Hz status); no plot for a bag without messages."""
    topics = [t.topic for t in summary.topics if t.count]
    if not topics:
        return []
    bin_s, nbins = _rate_bins(max(summary.duration_s, 0.0))
    edges = np.arange(nbins + 1) * bin_s
    edges[-1] = max(edges[-1], summary.duration_s)  # the last message belongs in the last bin
    times: dict[str, list[float]] = {t: [] for t in topics}
    for topic, ns in read_timestamps(bag, topics):
        times[topic].append(_stamp_s(summary, ns))
    centers = (edges[:-1] + edges[1:]) / 2
    fig, ax = _figure(11, 5 + 0.12 * max(0, len(topics) - 25))
    cycle = plt.rcParams['axes.prop_cycle'].by_key().get('color', ['C0'])
    for index, topic in enumerate(topics):
        counts, _ = np.histogram(np.asarray(times[topic]), bins=edges)
        rates = np.where(counts > 0, counts / bin_s, np.nan)   # log scale: an empty bin is a gap
        style = ('-', '--', ':', '-.')[(index // len(cycle)) % 4]
        ax.step(centers, rates, where='mid', linestyle=style, label=f'{topic} ({len(times[topic])})')
    ax.set_yscale('log')
    ax.set_title(f'Message rates — {summary.path.name} (bins of {bin_s:.3g} s, log scale)')
    ax.set_xlabel('time since bag start [s]')
    ax.set_ylabel('rate [messages/s]')
    ax.grid(True, which='both', alpha=0.3)
    _legend_outside(ax, ncols=1 if len(topics) <= 30 else 2)
    return [_save(fig, out_dir / 'message_rates.png')]


def plot_trajectories(bag: Path, summary: BagSummary, out_dir: Path) -> list[Path]:
    """x-y path of every mobile_robot body in BodyStates, in its simulation colour, over the scene's
    walls, obstacles and targets, with start/end markers and formation targets; equal aspect.
    A topic without mobile robots gets no plot."""
    written: list[Path] = []
    topics = summary.topics_of_type(BODY_STATES_TYPE)
    layout = scene_of_bag(bag) if topics else None
    goals = formation_targets(bag, summary) if topics else {}
    for topic in topics:
        paths: dict[str, list[tuple[float, float]]] = {}
        pushed: dict[str, list[tuple[float, float, float]]] = {}      # x, y, yaw
        for _topic, _ns, msg in read_messages(bag, [topic]):
            for body in msg.bodies:
                position, q = body.pose.position, body.pose.orientation
                if body.kind == MOBILE_ROBOT_KIND:
                    paths.setdefault(body.name, []).append((position.x, position.y))
                elif body.kind == MOVABLE_KIND:
                    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
                    pushed.setdefault(body.name, []).append((position.x, position.y, yaw))
        if not paths:
            continue
        colours = robot_colours(paths, layout)
        fig, ax = _figure(8.5, 7)
        draw_scene(ax, layout)
        boxes = {b.name: b for b in (layout.movable_boxes if layout is not None else ())}
        for name, path in sorted(pushed.items()):
            xy = np.asarray(path)
            colour = boxes[name].color if name in boxes else 'gray'
            ax.plot(xy[:, 0], xy[:, 1], '--', color=colour, linewidth=2, label=f'{name} (pushed)', zorder=3)
            if name in boxes:   # where it ended (the scene's hatched footprint is where it started)
                end = Rect(name, tuple(xy[-1, :2]), boxes[name].size, float(xy[-1, 2]), boxes[name].color)
                ax.add_patch(_rect_patch(end, facecolor=end.color, edgecolor='black', alpha=0.5, zorder=2))
        for name in sorted(paths):
            xy = np.asarray(paths[name])
            colour = colours[name]
            ax.plot(xy[:, 0], xy[:, 1], '-', color=colour, label=name, zorder=3)
            ax.plot(xy[0, 0], xy[0, 1], 'o', color=colour, markersize=8, zorder=4)
            ax.plot(xy[-1, 0], xy[-1, 1], 's', color=colour, markersize=8, markeredgecolor='black', zorder=4)
            if name in goals:
                ax.plot(*goals[name], marker='*', color=colour, markersize=15, markeredgecolor='black', zorder=5)
        # Marker legend entries without colour meaning.
        ax.plot([], [], 'o', color='gray', label='start')
        ax.plot([], [], 's', color='gray', markeredgecolor='black', label='end')
        if goals:
            ax.plot([], [], '*', color='gray', markersize=12, markeredgecolor='black', label='formation target')
        frame_scene(ax, layout)
        ax.set_title(f'Robot trajectories ({topic})' + ('' if layout else ' — scene unknown'))
        ax.set_xlabel('x [m]')
        ax.set_ylabel('y [m]')
        ax.grid(True, alpha=0.3)
        _legend_outside(ax)
        suffix = '' if len(topics) == 1 else f'_{_slug(topic)}'
        written.append(_save(fig, out_dir / f'trajectories{suffix}.png'))
    return written


def plot_velocities(bag: Path, summary: BagSummary, out_dir: Path) -> list[Path]:
    """Commanded linear.x and angular.z per Twist (cmd_vel) topic over time, each robot in its
    simulation colour; no plot when no command was recorded."""
    topics = [t.topic for t in summary.topics if t.type_name == TWIST_TYPE and t.count]
    if not topics:
        return []
    data: dict[str, tuple[list[float], list[float], list[float]]] = {t: ([], [], []) for t in topics}
    for topic, ns, msg in read_messages(bag, topics):
        t, vx, wz = data[topic]
        t.append(_stamp_s(summary, ns))
        vx.append(msg.linear.x)
        wz.append(msg.angular.z)
    robot_of = {topic: topic.strip('/').split('/')[0] for topic in topics}
    colours = robot_colours(set(robot_of.values()), scene_of_bag(bag))
    fig, (ax_v, ax_w) = plt.subplots(2, 1, sharex=True, figsize=(11, 6), layout='constrained')
    for topic in topics:
        t, vx, wz = data[topic]
        ax_v.step(t, vx, where='post', label=topic, color=colours[robot_of[topic]])
        ax_w.step(t, wz, where='post', label=topic, color=colours[robot_of[topic]])
    ax_v.set_title(f'Commanded velocities — {summary.path.name}')
    ax_v.set_ylabel('linear.x [m/s]')
    ax_w.set_ylabel('angular.z [rad/s]')
    ax_w.set_xlabel('time since bag start [s]')
    for ax in (ax_v, ax_w):
        ax.grid(True, alpha=0.3)
    _legend_outside(ax_v)
    return [_save(fig, out_dir / 'velocities.png')]


register_plot('message_rates', set(), plot_message_rates)
register_plot('trajectories', {BODY_STATES_TYPE}, plot_trajectories)
register_plot('velocities', {TWIST_TYPE}, plot_velocities)
