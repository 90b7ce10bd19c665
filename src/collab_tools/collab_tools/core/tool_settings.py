"""Settings of the workspace's tool nodes (bag_recorder, scripted_driver), checked without ROS."""
from __future__ import annotations

import re

from .bag_storage import STORAGE_PRESETS
from .settings import Setting, SettingsSchema

#: Topics the recorder leaves out when it records everything (as `ros2 bag record -a` does).
DEFAULT_EXCLUDE = ['/rosout', '/parameter_events']


def regex_problem(patterns: list[str]) -> str | None:
    """Why one of ``patterns`` is no regular expression (None when all are)."""
    for pattern in patterns:
        try:
            re.compile(pattern)
        except re.error as error:
            return f'invalid regular expression {pattern!r} ({error})'
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
)

DRIVER_SETTINGS = SettingsSchema(
    Setting('plan_file', '', 'drive plan YAML (config/plans/*.yaml)', required=True),
    Setting('command_rate', 20.0, 'Hz at which commands are published (of the node clock)',
            low=0.0, high=1000.0, low_open=True, dynamic=True),
)
