"""Settings of the workspace's tool nodes (bag_recorder, scripted_driver), checked without ROS."""
from __future__ import annotations

import re

from .bag_storage import STORAGE_PRESETS
from .drive_plan import DrivePlan, PlanError, load_plan
from .errors import ConfigurationError
from .settings import Setting, SettingsSchema, echo

#: Topics the recorder leaves out when it records everything (as `ros2 bag record -a` does).
DEFAULT_EXCLUDE = ['/rosout', '/parameter_events']


def regex_problem(patterns: list[str]) -> str | None:
    """Why one of ``patterns`` is no regular expression (None when all are)."""
    for pattern in patterns:
        try:
            re.compile(pattern)
        except re.error as error:
            return f'invalid regular expression {echo(pattern)} ({error})'
    return None


def parse_topic_rates(entries: list[str]) -> dict[str, float]:
    """``['/clock=500', 'cmd_vel=20']`` -> {topic: Hz}; '' entries are skipped; ValueError naming the entry."""
    rates = {}
    for entry in entries:
        if not entry:
            continue
        topic, sep, rate = entry.rpartition('=')
        try:
            value = float(rate)
        except ValueError:
            value = float('nan')
        if not sep or not topic or not 0.0 < value <= 1e6:
            raise ValueError(f"{echo(entry)} is not 'TOPIC=HZ' with 0 < HZ <= 1e6")
        rates[topic] = value
    return rates


def rates_problem(entries: list[str]) -> str | None:
    try:
        parse_topic_rates(entries)
    except ValueError as error:
        return str(error)
    return None


RECORDER_SETTINGS = SettingsSchema(
    Setting('output', '', 'directory of the new bag (must not exist yet)', required=True),
    Setting('topics', [''], "topics to record; a relative name is resolved in this node's namespace; "
            "[''] = every topic that exclude does not match"),
    Setting('exclude', DEFAULT_EXCLUDE, 'regular expressions (full match on absolute names) of the topics '
            'not recorded when topics is empty', check=regex_problem),
    Setting('discovery_period', 0.5, 'seconds between looks for new topics', low=0.01, high=60.0, dynamic=True),
    Setting('storage_preset', 'none', "MCAP chunk compression, as rosbag2's storage_preset_profile: none and "
            'fastwrite = uncompressed 768 KiB chunks, zstd_fast = zstd level -5, zstd_small = zstd level 19 '
            'in 4 MiB chunks', choices=tuple(STORAGE_PRESETS)),
    Setting('topic_rates', [''], "expected rates of the fast topics, 'TOPIC=HZ' (wall clock; a relative "
            'TOPIC is resolved like topics): the subscription queue holds queue_seconds of them',
            check=rates_problem),
    Setting('queue_seconds', 2.0, "seconds of a topic's expected rate its subscription queue holds",
            low=0.1, high=60.0),
    Setting('queue_depth', 100, 'subscription queue depth of a topic with no expected rate (and the least '
            'any topic gets)', low=1, high=100000),
    Setting('chunk_flush_period', 1.0, 'seconds (wall clock) after which the chunk being filled is written '
            'even if not full: a killed recorder loses at most that much (bag_reindex repairs the rest)',
            low=0.05, high=600.0),
    Setting('drain_quiet_period', 0.3, 'seconds (wall clock): on SIGINT/SIGTERM the recorder keeps taking what '
            'its queues hold until no message published before the stop came for this long, then closes the bag',
            low=0.01, high=10.0),
    Setting('drain_timeout', 3.0, 'seconds (wall clock) the drain after SIGINT/SIGTERM may last at most; '
            'messages still queued then are counted lost (drain_left). Keep it below the orchestration\'s '
            'stop timeout (10 s) minus the close', low=0.0, high=6.0),
)

DRIVER_SETTINGS = SettingsSchema(
    Setting('plan_file', '', 'drive plan YAML (config/plans/*.yaml)', required=True),
    Setting('command_rate', 20.0, 'Hz at which commands are published (of the node clock)',
            low=0.0, high=1000.0, low_open=True, dynamic=True),
)


def read_plan_parameter(path: str) -> DrivePlan:
    """The drive plan of the scripted driver's ``plan_file`` parameter; errors name the parameter."""
    try:
        return load_plan(path)
    except PlanError as error:
        raise ConfigurationError(f'parameter plan_file: {error}') from None
