"""The Fig. 9 column: its configuration file, one column run read from its bag, and the demo.

Paper: Section V-A-4 and Fig. 9 (paper ``iq_asymtre_coalitions``, CITATION.cff): robots in a column,
only the front one localises, each sees only the robot ahead; the robot at the back must find a
coalition that includes every robot. The geometry is :func:`~..core.sim_scenarios.column_placements`;
this module reads ``config/coalitions/scenarios/fig9_column.yaml`` (:func:`load_column_config`),
summarises one recorded column run (:func:`column_result`) and runs ``scripts/demo``'s short column
(:func:`run_column_demo`). The figure itself is :mod:`.fig9`.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping

from collab_tools.core.fields import Fields, check_number, load_config_file, require_mapping

from ..core.errors import ConfigError
from ..core.sim_scenarios import COLUMN_TYPES, SensorSettings, column_placements, column_sees_only_the_robot_ahead
from .coalition_bag import CoalitionRun, conflicting_commitments, kind_totals, leader_timeline, message_counts
from .coalition_bag import read_coalition_bag
from .sessions import AgentSetup, run_session

Log = Callable[[str], None]

COLUMN_CONFIG = 'scenarios/fig9_column.yaml'


@dataclass(frozen=True)
class ColumnConfig:
    path: Path
    robots: tuple[int, ...]
    spacing_m: float
    sensors: SensorSettings
    link_preset: str
    loss_probability: float
    search_time_s: Mapping[str, float]
    settle_time_s: float
    timeout_s: float
    paper_time_s: Mapping[int, float]
    agent_processes: int = 1
    #: simulated s per bridge tick (None: the bridge's own, config/params/pybullet_bridge.yaml)
    bridge_control_period: float | None = None

    def search_time(self, robots: int) -> float:
        return self.search_time_s.get(str(robots), self.search_time_s['default'])


def column_config_from_dict(data: object, path: Path) -> ColumnConfig:
    section = Fields(data, '', ('robots', 'spacing_m', 'fiducial', 'link', 'search_time_s', 'settle_time_s',
                                'timeout_s', 'paper_time_s', 'agent_processes', 'bridge_control_period'),
                     error=ConfigError)
    robots = []
    for item_path, value in section.items('robots'):
        number = check_number(value, item_path, ge=2.0, error=ConfigError)
        if number != int(number):
            raise ConfigError(f'{item_path}: must be a whole number of robots >= 2 (got {value!r})')
        robots.append(int(number))
    if not robots:
        raise ConfigError('robots: list at least one column size')
    spacing = section.number('spacing_m', gt=0.0)
    fiducial = Fields(section.raw('fiducial'), 'fiducial', ('fov_deg', 'range_m'), error=ConfigError)
    sensors = SensorSettings(fiducial_fov_deg=fiducial.number('fov_deg', gt=0.0),
                             fiducial_range_m=fiducial.number('range_m', gt=0.0))
    if not column_sees_only_the_robot_ahead(spacing, sensors):
        raise ConfigError(f'fiducial: each robot must see only the robot ahead: need spacing_m ({spacing:g}) <= '
                          f'range_m ({sensors.fiducial_range_m:g}) < 2 x spacing_m and fov_deg < 360')
    link = Fields(section.raw('link', {}), 'link', ('preset', 'loss_probability'), error=ConfigError)
    preset = link.string('preset', 'paper_fig9', allow_empty=True)
    loss = link.number('loss_probability', 0.0, ge=0.0)
    if loss > 1.0:
        raise ConfigError(f'link.loss_probability: must be in [0, 1] (got {loss})')
    search = {str(k): v for k, v in _by_robots(section.raw('search_time_s'), 'search_time_s').items()}
    if 'default' not in search:
        raise ConfigError('search_time_s.default: required (the search time of column sizes not listed)')
    paper = {int(k): v for k, v in _by_robots(section.raw('paper_time_s', {}), 'paper_time_s').items()
             if k != 'default'}
    processes = section.number('agent_processes', 1, ge=1.0)
    if processes != int(processes):
        raise ConfigError(f'agent_processes: must be a whole number >= 1 (got {processes!r})')
    control = section.raw('bridge_control_period', None)
    if control is not None:
        # The sensors report at 10 Hz: a tick must not be longer than their period.
        control = check_number(control, 'bridge_control_period', gt=0.0, le=0.1, error=ConfigError)
    return ColumnConfig(path, tuple(robots), spacing, sensors, preset, loss, search,
                        section.number('settle_time_s', 1.0, gt=0.0), section.number('timeout_s', 150.0, gt=0.0),
                        paper, int(processes), control)


def _by_robots(value: object, path: str) -> dict:
    """``{default: s, <robots>: s}`` -> {'default' | robots: seconds > 0}."""
    data = require_mapping(value, path, ConfigError)
    found: dict = {}
    for key, seconds in data.items():
        if key != 'default' and (isinstance(key, bool) or not isinstance(key, int) or key < 2):
            raise ConfigError(f'{path}.{key}: keys are column sizes (integers >= 2) or default')
        found[key] = check_number(seconds, f'{path}.{key}', gt=0.0, error=ConfigError)
    return found


def load_column_config(path: Path) -> ColumnConfig:
    return load_config_file(path, lambda data: column_config_from_dict(data, Path(path)), error=ConfigError)


def column_result(run: CoalitionRun, robots: int, bin_s: float = 0.05) -> dict:
    """One column run from its bag: the back robot's timeline, commitments and message counts."""
    back = f'robot_{robots}'
    timeline = leader_timeline(run, back)
    everyone = [f'robot_{k}' for k in range(1, robots + 1)]
    result = {'robots': robots, 'leader': back, **timeline.to_dict(),
              'time_s': None if timeline.found_s is None else round(timeline.found_s, 4),
              'includes_all_robots': sorted(timeline.members) == sorted(everyone),
              'messages': len(run.messages), 'ros_messages': run.ros_messages, 'kinds': kind_totals(run),
              'conflicting_commitments': conflicting_commitments(run)}
    if timeline.search_start is not None:
        end = max([m.stamp for m in run.messages] + [timeline.search_start + bin_s])
        result['counts'] = message_counts(run, everyone, timeline.search_start, end, bin_s)
    return result


def run_column_demo(config_dir: str | Path, run_dir: str | Path, robots: int = 3, search_time_s: float = 3.0,
                    log: Log = print):
    """scripts/demo's coalition scenario: a short column (Fig. 9 geometry, paper link model); the
    robot at the back forms its coalition through the robots ahead. Returns the SessionRunResult;
    coalition.json in ``run_dir`` summarises the bag."""
    config_dir, run_dir = Path(config_dir), Path(run_dir)
    config = load_column_config(config_dir / 'coalitions' / COLUMN_CONFIG)
    placements = column_placements(robots, config.spacing_m)
    setup = AgentSetup(leaders=(placements[-1].robot,), search_time_s=search_time_s, use_sim_time=True,
                       link_preset=config.link_preset, timeout_s=90.0)
    result = run_session(run_dir, config_dir, f'demo_column_{robots}', placements, COLUMN_TYPES, config.sensors,
                         setup, log=None)
    if result.bag is not None and result.bag.exists():
        summary = column_result(read_coalition_bag(result.bag), robots)
        summary.pop('counts', None)
        (Path(run_dir) / 'coalition.json').write_text(json.dumps(summary, indent=2))
        log(f'[demo coalitions] {summary["leader"]}: {summary["state"]} with {", ".join(summary["members"]) or "-"} '
            f'(cost {summary["cost"]}), formed {summary["formed_s"]} s after its search started')
    return result


__all__ = ['COLUMN_CONFIG', 'ColumnConfig', 'column_config_from_dict', 'column_result', 'load_column_config',
           'run_column_demo']
