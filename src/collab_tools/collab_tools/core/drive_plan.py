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

from dataclasses import dataclass
from pathlib import Path

from .errors import ConfigurationError
from .fields import Fields, join_path, load_config_file

SEGMENT_FIELDS = ('linear', 'angular', 'duration')


class PlanError(ConfigurationError):
    """A drive plan field is invalid; the message starts with its dotted path."""


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


def parse_plan(data) -> DrivePlan:
    plan = Fields(data, 'plan', allowed=('robots',), error=PlanError)
    robots = plan.entries('robots')
    if not robots:
        raise PlanError('robots: must map at least one robot name to a list of segments')
    segments = {}
    for path, name, items in robots:
        if not isinstance(items, list) or not items:
            raise PlanError(f'{path}: must be a non-empty list of segments')
        parsed = []
        for index, item in enumerate(items):
            segment = Fields(item, join_path(path, index), SEGMENT_FIELDS, PlanError)
            parsed.append(Segment(segment.number('linear'), segment.number('angular'),
                                  segment.number('duration', gt=0.0)))
        segments[name] = tuple(parsed)
    return DrivePlan(segments)


def load_plan(path: str | Path) -> DrivePlan:
    return load_config_file(path, parse_plan, PlanError, what='plan file')
