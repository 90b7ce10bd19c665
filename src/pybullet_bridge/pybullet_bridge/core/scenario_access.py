"""Which scenario files the bridge's ``~/reset`` service may load: only those in configured directories.

Anyone on the ROS domain can call ``~/reset`` with a path, so a request could otherwise make the
bridge open any readable file (``../../etc/passwd``, ``/dev/zero``) and send parts of it back in
the response. The ``scenario_directories`` parameter lists the directories a requested scenario
must lie in (default: the workspace's ``config/scenarios``); a relative request is taken relative to
the first of them. Symbolic links and ``..`` are resolved before the check, so neither leads out.
A refused request says only that the path is outside those directories: not whether the file
exists, nothing of its content. The file is then read like any input file
(collab_tools.core.input_files: regular file, size, UTF-8 and YAML bounds).

The scenario the bridge starts with (its ``scenario`` parameter, set by whoever starts it) is not
restricted; ``~/reset`` with an empty path reloads it. Map images and Nav2 map files named by an
allowed scenario are read from where the scenario says (its author chose them).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

from collab_tools.core.input_files import check_path, shown_path

from .errors import ScenarioError
from .scenario import Scenario, load_scenario

__all__ = ['DEFAULT_SCENARIO_DIRECTORY', 'ScenarioDirectories', 'load_scenario']

#: The workspace's scenario directory (src/pybullet_bridge/pybullet_bridge/core/ -> config/scenarios;
#: the workspace is built with --symlink-install, so this file resolves into src/).
DEFAULT_SCENARIO_DIRECTORY = Path(os.environ.get('COLLAB_WS_ENV') or Path(__file__).resolve().parents[4]) \
    / 'config' / 'scenarios'


class ScenarioDirectories:
    """The directories ``~/reset`` may load scenarios from (resolved once, at start)."""

    def __init__(self, directories: Sequence[str]):
        given = [d for d in directories if d] or [str(DEFAULT_SCENARIO_DIRECTORY)]
        self.directories = []
        for index, directory in enumerate(given):
            path = check_path(directory, f'parameter scenario_directories[{index}]', ScenarioError).resolve()
            if not path.is_dir():
                raise ScenarioError(f"parameter scenario_directories[{index}]: '{shown_path(path)}' is not a directory")
            self.directories.append(path)

    def resolve(self, requested: str) -> Path:
        """The real path of the scenario ``requested`` names, or ScenarioError when it lies outside."""
        path = check_path(requested, 'scenario_path', ScenarioError)
        if not path.is_absolute():
            path = self.directories[0] / path
        try:
            real = path.resolve()      # symlinks and .. resolved: the file that would be opened
        except (OSError, RuntimeError):    # a symlink loop
            real = None
        if real is None or not any(real.is_relative_to(directory) for directory in self.directories):
            raise ScenarioError(f"scenario_path: '{shown_path(requested)}' is outside the directories scenarios "
                                'are loaded from (parameter scenario_directories)')
        return real

    def load(self, requested: str, current: str) -> tuple[Scenario, str]:
        """(scenario, its path) a reset request asks for: ``requested`` from the allowed directories, or
        the ``current`` scenario again when ``requested`` is empty; ScenarioError says why not."""
        path = str(self.resolve(requested)) if requested else current
        return load_scenario(path), path

    def __str__(self) -> str:
        return ', '.join(str(d) for d in self.directories)
