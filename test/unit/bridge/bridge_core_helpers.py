"""Small scenario dicts shared by the bridge unit tests."""
from __future__ import annotations

import copy
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[3]
SCENARIO_DIR = REPO_ROOT / 'config' / 'scenarios'

MINIMAL = {
    'name': 'unit',
    'world': {'bounds': [-2.0, -2.0, 2.0, 2.0], 'walls': {'height': 0.3, 'thickness': 0.05}},
    'camera': {'width': 64, 'height': 64, 'altitude': 5.0},
    'mobile_robots': [
        {'name': 'robot_1', 'type': 'pioneer_3dx', 'pose': [0.0, 0.0, 0.0], 'color': [0.9, 0.1, 0.1]},
    ],
}


def scenario_dict(**overrides) -> dict:
    """A fresh copy of MINIMAL with top-level keys replaced (None deletes a key)."""
    return with_overrides(MINIMAL, **overrides)


def with_overrides(base: dict, **overrides) -> dict:
    """A fresh copy of a scenario dict with top-level keys replaced (None deletes a key)."""
    data = copy.deepcopy(base)
    for key, value in overrides.items():
        if value is None:
            data.pop(key, None)
        else:
            data[key] = value
    return data


def robot(**fields) -> dict:
    """A robot entry for 'mobile_robots' with fields replaced."""
    entry = copy.deepcopy(MINIMAL['mobile_robots'][0])
    entry.update(fields)
    return entry
