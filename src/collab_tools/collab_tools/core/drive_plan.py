"""Scripted velocity plans for robots: timed segments of (linear, angular) velocity.

Plan file (YAML):

    robots:
      robot_1:
        - {linear: 0.4, angular: 0.0, duration: 3.0}   # m/s, rad/s, s of simulated time
        - {linear: 0.0, angular: 0.8, duration: 2.0}
      robot_2:
        - {linear: 0.2, angular: 0.3, duration: 4.0}

Each robot's plan starts at the same instant and ends with a zero command.
"""

import math
import re
from dataclasses import dataclass
from pathlib import Path

import yaml

ROBOT_NAME = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')
SEGMENT_FIELDS = ('linear', 'angular', 'duration')


class PlanError(ValueError):
    pass


@dataclass(frozen=True)
class Segment:
    linear: float
    angular: float
    duration: float


@dataclass(frozen=True)
class DrivePlan:
    segments: dict[str, tuple[Segment, ...]]

    @property
    def robots(self) -> list[str]:
        return list(self.segments)

    @property
    def duration(self) -> float:
        return max((sum(s.duration for s in segs) for segs in self.segments.values()), default=0.0)

    def command_at(self, robot: str, elapsed: float) -> tuple[float, float]:
        """Velocity command for `robot` at `elapsed` s into the plan; zero after its end."""
        start = 0.0
        for segment in self.segments[robot]:
            if start <= elapsed < start + segment.duration:
                return segment.linear, segment.angular
            start += segment.duration
        return 0.0, 0.0


def _number(value, path: str, low: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise PlanError(f'{path}: must be a finite number (got {value!r})')
    if low is not None and value <= low:
        raise PlanError(f'{path}: must be > {low} (got {value!r})')
    return float(value)


def parse_plan(data) -> DrivePlan:
    if not isinstance(data, dict) or set(data) != {'robots'}:
        raise PlanError("plan: must be a mapping with exactly one key 'robots'")
    robots = data['robots']
    if not isinstance(robots, dict) or not robots:
        raise PlanError('robots: must map at least one robot name to a list of segments')
    segments = {}
    for name, items in robots.items():
        if not isinstance(name, str) or not ROBOT_NAME.match(name):
            raise PlanError(f'robots.{name}: robot names are [A-Za-z][A-Za-z0-9_]*')
        if not isinstance(items, list) or not items:
            raise PlanError(f'robots.{name}: must be a non-empty list of segments')
        parsed = []
        for index, item in enumerate(items):
            path = f'robots.{name}[{index}]'
            if not isinstance(item, dict):
                raise PlanError(f'{path}: must be a mapping with {", ".join(SEGMENT_FIELDS)}')
            unknown = set(item) - set(SEGMENT_FIELDS)
            if unknown:
                raise PlanError(f'{path}.{sorted(unknown)[0]}: unknown field '
                                f'(allowed: {", ".join(SEGMENT_FIELDS)})')
            for field in SEGMENT_FIELDS:
                if field not in item:
                    raise PlanError(f'{path}.{field}: missing required field')
            parsed.append(Segment(_number(item['linear'], f'{path}.linear'),
                                  _number(item['angular'], f'{path}.angular'),
                                  _number(item['duration'], f'{path}.duration', low=0.0)))
        segments[name] = tuple(parsed)
    return DrivePlan(segments)


def load_plan(path: str | Path) -> DrivePlan:
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as error:
        raise PlanError(f'plan file {path}: cannot read ({error.strerror})') from None
    except yaml.YAMLError as error:
        raise PlanError(f'plan file {path}: invalid YAML ({error})') from None
    try:
        return parse_plan(data)
    except PlanError as error:
        raise PlanError(f'plan file {path}: {error}') from None
