"""Figures for experiment reports: headless, one style, saved so titles and legends are never clipped.

An experiment that ran in simulation draws its trajectories like ``scripts/report`` does: the scene
of its bag (:func:`bag_scene`: walls, obstacles, targets, each robot's colour) drawn with
:func:`collab_tools.core.report_plots.draw_scene`, robots in
:func:`~collab_tools.core.report_plots.robot_colours`, framed by
:func:`~collab_tools.core.report_plots.frame_scene`.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use('Agg')  # experiments run headless (CI, ssh); must precede pyplot's import
import matplotlib.pyplot as plt  # noqa: E402

DPI = 110


def figure(width: float = 6.4, height: float = 4.0, rows: int = 1, columns: int = 1, **keywords):
    """(fig, axes) with a constrained layout, so long titles and outside legends fit."""
    return plt.subplots(rows, columns, figsize=(width, height), layout='constrained', **keywords)


def legend_outside(ax, **keywords) -> None:
    """A legend right of the axes, where it cannot cover bars or lines."""
    ax.legend(loc='upper left', bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, **keywords)


def save(fig, path: str | Path, dpi: int = DPI) -> Path:
    """Save and close ``fig``; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches='tight')
    plt.close(fig)
    return path


def bag_scene(bag: str | Path | None):
    """The simulated scene of a recorded run (a :class:`~collab_tools.core.scene_layout.SceneLayout`),
    from the scene readers the subsystems register for ``scripts/report``; None when none knows the bag."""
    if bag is None:
        return None
    from ..core.scene_layout import scene_of_bag
    from ..report_cli import load_plot_plugins   # the bridge's scene reader is one of the plug-ins
    load_plot_plugins()
    return scene_of_bag(Path(bag))
