"""The simulated world of a recording as a report draws it: walls, obstacles, tables, targets, robots' looks.

A bag holds the bodies' poses (``/ground_truth/bodies``) but not their shapes or colours; those are
in the scenario the bridge ran. A :class:`SceneLayout` is that part of a scenario, in plain data,
so report plots and videos draw walls, obstacles and targets under the trajectories and give each
robot its simulation colour, without this package knowing the scenario format: the bridge
registers a reader (``register_scene_reader``, loaded as a report plug-in) that finds a bag's
scenario and converts it. Without a reader, or for a bag with no scenario, there is no layout and
plots fall back to a plain palette.
"""
from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ['Disc', 'GridTable', 'Rect', 'SceneLayout', 'register_scene_reader', 'scene_of_bag',
           'unregister_scene_reader']

Colour = tuple[float, float, float]


@dataclass(frozen=True)
class Rect:
    """A box's footprint: centre, size (x, y before the yaw), yaw (rad) and colour (r, g, b in [0, 1])."""
    name: str
    center: tuple[float, float]
    size: tuple[float, float]
    yaw: float = 0.0
    color: Colour = (0.5, 0.5, 0.5)


@dataclass(frozen=True)
class Disc:
    """A round footprint (a robot's or a target's)."""
    name: str
    center: tuple[float, float]
    radius: float
    color: Colour = (0.1, 0.1, 0.1)


@dataclass(frozen=True)
class GridTable:
    """A table top with its grid (rows x cols cells; row 0 has the largest y, col 0 the smallest x)."""
    name: str
    center: tuple[float, float]
    size: tuple[float, float]
    rows: int = 1
    cols: int = 1
    color: Colour = (0.78, 0.66, 0.5)

    def cell_center(self, cell: int) -> tuple[float, float]:
        """World x, y of cell ``row * cols + col``."""
        row, col = divmod(int(cell), self.cols)
        width, depth = self.size[0] / self.cols, self.size[1] / self.rows
        return (self.center[0] - self.size[0] / 2 + (col + 0.5) * width,
                self.center[1] + self.size[1] / 2 - (row + 0.5) * depth)


@dataclass(frozen=True)
class SceneLayout:
    """What a plot draws of the world; ``robots``: each mobile robot's start footprint and colour."""
    source: str = ''
    bounds: tuple[float, float, float, float] | None = None
    walls: tuple[Rect, ...] = ()
    obstacles: tuple[Rect, ...] = ()
    movable_boxes: tuple[Rect, ...] = ()
    tables: tuple[GridTable, ...] = ()
    targets: tuple[Disc, ...] = ()
    robots: dict[str, Disc] = field(default_factory=dict)

    def robot_color(self, name: str) -> Colour | None:
        robot = self.robots.get(name)
        return None if robot is None else robot.color

    @property
    def empty(self) -> bool:
        return not (self.walls or self.obstacles or self.movable_boxes or self.tables or self.targets or self.robots)


SceneReader = Callable[[Path], 'SceneLayout | None']
_READERS: dict[str, SceneReader] = {}


def register_scene_reader(name: str, reader: SceneReader) -> None:
    """``reader(bag_dir) -> SceneLayout | None`` (None: not a bag it knows the scene of)."""
    _READERS[name] = reader


def unregister_scene_reader(name: str) -> None:
    _READERS.pop(name, None)


def scene_of_bag(bag: Path) -> SceneLayout | None:
    """The first registered reader's layout of ``bag``; None when no reader knows it.

    A reader that fails is reported on stderr and skipped: plots are drawn without the scene.
    """
    for name, reader in list(_READERS.items()):
        try:
            layout = reader(Path(bag))
        except Exception as error:  # noqa: BLE001 - a broken scenario must not sink the report
            print(f'report: scene reader {name!r} failed for {bag}: {type(error).__name__}: {error}',
                  file=sys.stderr)
            continue
        if layout is not None:
            return layout
    return None
