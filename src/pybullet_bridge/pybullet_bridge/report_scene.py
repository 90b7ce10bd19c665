"""scripts/report plug-in: the scene a recorded run simulated, for plots and videos.

A bag of an orchestrated run lies in ``<run_dir>/bags/<bag>``; the run's ``session.json`` names
the bridge's parameter files, whose ``scenario`` is the scenario file the bridge loaded. That file
is read with the bridge's own parser (:func:`.core.scenario.load_scenario`) and handed to the report
as a :class:`collab_tools.core.scene_layout.SceneLayout`: walls, obstacle boxes (an occupancy map's
boxes included), movable boxes, tables with their grids, targets and each robot's footprint and
colour, exactly as the simulation drew them. Registered through the ament index resource
``collab_report_plots`` (see collab_tools.report_cli).
"""
from __future__ import annotations

import json
from pathlib import Path

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.fields import read_yaml_file
from collab_tools.core.scene_layout import Disc, GridTable, Rect, SceneLayout, register_scene_reader

from .core.obstacles import WALL_COLOR, WallSet
from .core.scenario import Scenario, load_scenario

#: How far above a bag directory its run directory (with session.json) may lie.
SEARCH_DEPTH = 3


def scenario_file_of(bag: Path) -> Path | None:
    """The scenario the bridge of ``bag``'s run loaded (from the run's session.json), None if unknown."""
    for run_dir in list(Path(bag).resolve().parents)[:SEARCH_DEPTH]:
        session = run_dir / 'session.json'
        if not session.is_file():
            continue
        nodes = json.loads(session.read_text(encoding='utf-8')).get('nodes', {})
        for label, node in nodes.items():
            command = node.get('command') or []
            if not any(str(part).endswith('/pybullet_bridge') for part in command[:1]):
                continue
            scenario = None
            for index, part in enumerate(command[:-1]):
                if part == '--params-file':
                    scenario = _scenario_parameter(Path(command[index + 1])) or scenario
                elif part == '-p' and str(command[index + 1]).startswith('scenario:='):
                    scenario = command[index + 1].split(':=', 1)[1]
            if scenario:
                return Path(scenario)
        return None
    return None


def _scenario_parameter(path: Path) -> str | None:
    """The ``scenario`` of a ROS parameter file (any node entry), None if it sets none."""
    try:
        data = read_yaml_file(path, 'parameter file')
    except ConfigurationError:
        return None
    for entry in data.values() if isinstance(data, dict) else ():
        value = (entry or {}).get('ros__parameters', {}).get('scenario') if isinstance(entry, dict) else None
        if value:
            return str(value)
    return None


def layout_of(scenario: Scenario) -> SceneLayout:
    world = scenario.world
    walls = ()
    if world.walls is not None:
        walls = tuple(Rect('walls', center, size, 0.0, WALL_COLOR)
                      for center, size in WallSet.around(world).wall_boxes())
    sections = scenario.sections
    return SceneLayout(
        source=str(scenario.source or ''), bounds=tuple(world.bounds), walls=walls,
        obstacles=tuple(Rect(b.name, b.center, b.size, b.yaw, b.color) for b in sections.get('obstacles', [])),
        movable_boxes=tuple(Rect(b.name, b.center, b.size, b.yaw, b.color)
                            for b in sections.get('movable_boxes', [])),
        tables=tuple(GridTable(t.name, t.center, t.size, *t.shape, t.color) for t in sections.get('tables', [])),
        targets=tuple(Disc(t.name, t.position, t.radius, t.color) for t in sections.get('targets', [])),
        robots={r.name: Disc(r.name, r.initial_pose[:2], r.params.radius, r.params.color)
                for r in sections.get('mobile_robots', [])})


def read_scene(bag: Path) -> SceneLayout | None:
    path = scenario_file_of(bag)
    if path is None or not path.is_file():
        return None
    return layout_of(load_scenario(path))


register_scene_reader('pybullet_bridge', read_scene)
