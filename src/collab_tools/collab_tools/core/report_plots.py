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

from .bag_analysis import BagSummary, read_messages, read_timestamps  # noqa: E402
from .bag_types import normalize_type_name  # noqa: E402

__all__ = [
    'PlotFn',
    'PlotError',
    'registered_plots',
    'register_plot',
    'unregister_plot',
    'write_plots',
]

PlotFn = Callable[[Path, BagSummary, Path], list[Path]]

BODY_STATES_TYPE = 'bridge_interfaces/msg/BodyStates'
TWIST_TYPE = 'geometry_msgs/msg/Twist'
MOBILE_ROBOT_KIND = 'mobile_robot'


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


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _stamp_s(summary: BagSummary, ns: int) -> float:
    return (ns - summary.start_ns) / 1e9


# ---------------------------------------------------------------- built-ins
def plot_message_rates(bag: Path, summary: BagSummary, out_dir: Path) -> list[Path]:
    """Messages per second over time, one line per topic, binned."""
    topics = [t.topic for t in summary.topics if t.count]
    fig, ax = plt.subplots(figsize=(10, 5))
    duration = max(summary.duration_s, 0.0)
    if duration <= 0:
        bin_s, nbins = 1.0, 1
    else:
        # ~1 s bins; finer for short bags (>= ~10 bins), coarser for long ones (<= 200 bins).
        bin_s = 1.0 if duration >= 10 else duration / 10
        if duration / bin_s > 200:
            bin_s = duration / 200
        nbins = max(1, math.ceil(duration / bin_s - 1e-9))
    edges = np.arange(nbins + 1) * bin_s
    edges[-1] = max(edges[-1], duration)  # the last message belongs in the last bin
    times: dict[str, list[float]] = {t: [] for t in topics}
    for topic, ns in read_timestamps(bag, topics):
        times[topic].append(_stamp_s(summary, ns))
    centers = (edges[:-1] + edges[1:]) / 2
    for topic in topics:
        counts, _ = np.histogram(np.asarray(times[topic]), bins=edges)
        ax.step(centers, counts / bin_s, where='mid', label=f'{topic} ({len(times[topic])})')
    ax.set_title(f'Message rates — {summary.path.name} (bins of {bin_s:.3g} s)')
    ax.set_xlabel('time since bag start [s]')
    ax.set_ylabel('rate [messages/s]')
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    if topics:
        ax.legend(fontsize='small', loc='best')
    else:
        ax.text(0.5, 0.5, 'no messages', ha='center', va='center', transform=ax.transAxes)
    return [_save(fig, out_dir / 'message_rates.png')]


def plot_trajectories(bag: Path, summary: BagSummary, out_dir: Path) -> list[Path]:
    """x-y path of every mobile_robot body in BodyStates, start/end markers, equal aspect."""
    written: list[Path] = []
    topics = summary.topics_of_type(BODY_STATES_TYPE)
    for topic in topics:
        paths: dict[str, list[tuple[float, float]]] = {}
        for _topic, _ns, msg in read_messages(bag, [topic]):
            for body in msg.bodies:
                if body.kind != MOBILE_ROBOT_KIND:
                    continue
                paths.setdefault(body.name, []).append((body.pose.position.x, body.pose.position.y))
        fig, ax = plt.subplots(figsize=(7, 7))
        for name in sorted(paths):
            xy = np.asarray(paths[name])
            (line,) = ax.plot(xy[:, 0], xy[:, 1], '-', label=name)
            ax.plot(xy[0, 0], xy[0, 1], 'o', color=line.get_color(), markersize=8)
            ax.plot(xy[-1, 0], xy[-1, 1], 's', color=line.get_color(), markersize=8)
        if paths:
            # Marker legend entries without colour meaning.
            ax.plot([], [], 'o', color='gray', label='start')
            ax.plot([], [], 's', color='gray', label='end')
            ax.legend(fontsize='small', loc='best')
        else:
            ax.text(0.5, 0.5, f'no {MOBILE_ROBOT_KIND} bodies', ha='center', va='center', transform=ax.transAxes)
        ax.set_aspect('equal', adjustable='datalim')
        ax.set_title(f'Robot trajectories ({topic})')
        ax.set_xlabel('x [m]')
        ax.set_ylabel('y [m]')
        ax.grid(True, alpha=0.3)
        suffix = '' if len(topics) == 1 else f'_{_slug(topic)}'
        written.append(_save(fig, out_dir / f'trajectories{suffix}.png'))
    return written


def plot_velocities(bag: Path, summary: BagSummary, out_dir: Path) -> list[Path]:
    """Commanded linear.x and angular.z per Twist (cmd_vel) topic over time."""
    topics = summary.topics_of_type(TWIST_TYPE)
    if not topics:
        return []
    data: dict[str, tuple[list[float], list[float], list[float]]] = {t: ([], [], []) for t in topics}
    for topic, ns, msg in read_messages(bag, topics):
        t, vx, wz = data[topic]
        t.append(_stamp_s(summary, ns))
        vx.append(msg.linear.x)
        wz.append(msg.angular.z)
    fig, (ax_v, ax_w) = plt.subplots(2, 1, sharex=True, figsize=(10, 6))
    for topic in topics:
        t, vx, wz = data[topic]
        ax_v.step(t, vx, where='post', label=topic)
        ax_w.step(t, wz, where='post', label=topic)
    ax_v.set_title(f'Commanded velocities — {summary.path.name}')
    ax_v.set_ylabel('linear.x [m/s]')
    ax_w.set_ylabel('angular.z [rad/s]')
    ax_w.set_xlabel('time since bag start [s]')
    for ax in (ax_v, ax_w):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize='small', loc='best')
    return [_save(fig, out_dir / 'velocities.png')]


register_plot('message_rates', set(), plot_message_rates)
register_plot('trajectories', {BODY_STATES_TYPE}, plot_trajectories)
register_plot('velocities', {TWIST_TYPE}, plot_velocities)
