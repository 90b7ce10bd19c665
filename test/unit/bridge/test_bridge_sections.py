"""New entity kinds plug in through register_section, without touching scene.py."""
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from bridge_core_helpers import scenario_dict
from collab_tools.core.fields import Fields, join_path, require_list
from pybullet_bridge.core.errors import ScenarioError
from pybullet_bridge.core.scenario import (
    parse_scenario, register_section, registered_sections, unregister_section,
)
from pybullet_bridge.core.scene import Scene, SceneEntity


class Marker(SceneEntity):
    """A small static sphere; counts its hook calls to prove the scene drives it."""

    kind = 'test_marker'

    def __init__(self, name, position, seed):
        self.name = name
        self.position = position
        self.seed = seed
        self.before_calls = self.after_calls = 0

    def spawn(self, client):
        self.before_calls = self.after_calls = 0
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=0.1, physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_SPHERE, radius=0.1, rgbaColor=[1, 1, 0, 1], physicsClientId=client)
        return [p.createMultiBody(0, shape, visual, basePosition=[*self.position, 0.1], physicsClientId=client)]

    def before_step(self, client, dt, sim_time):
        self.before_calls += 1

    def after_step(self, client, dt, sim_time):
        self.after_calls += 1


def parse_markers(value, context):
    markers = []
    for index, item in enumerate(require_list(value, context.path, ScenarioError)):
        fields = Fields(item, join_path(context.path, index), allowed=('name', 'position'), error=ScenarioError)
        markers.append(Marker(fields.name(), fields.vector('position', 2), context.seed))
    return markers


@pytest.fixture
def markers_section():
    register_section('test_markers', parse_markers)
    yield
    unregister_section('test_markers')


def test_registered_section_is_parsed_and_spawned(markers_section):
    assert registered_sections()[:2] == ['mobile_robots', 'obstacles']
    assert registered_sections()[-1] == 'test_markers'
    data = scenario_dict(seed=42, test_markers=[{'name': 'm1', 'position': [1.0, -1.0]}])
    scenario = parse_scenario(data, Path('.'))
    assert scenario.seed == 42
    [spec] = scenario.sections['test_markers']
    assert spec.seed == 42 and spec.config_path == 'test_markers[0]'
    with Scene(scenario) as scene:
        marker = scene.entity('m1')
        assert isinstance(marker, Marker) and marker is not spec  # the scene works on its own copy
        assert scene.label_legend()[-1] == (3, 'm1', 'test_marker')
        scene.step(5)
        assert (marker.before_calls, marker.after_calls) == (5, 5)
        position, _ = p.getBasePositionAndOrientation(marker.body_ids[0], physicsClientId=scene.client)
        assert position[:2] == pytest.approx((1.0, -1.0))
        labels = scene.render().labels
        assert np.any(labels == 3)


def test_registered_section_errors_and_name_clashes(markers_section):
    with pytest.raises(ScenarioError, match=r'^test_markers\[0\]\.colour: unknown field'):
        parse_scenario(scenario_dict(test_markers=[{'name': 'm', 'position': [0, 0], 'colour': 1}]), Path('.'))
    with pytest.raises(ScenarioError, match=r"^test_markers\[0\]\.name: duplicate name 'robot_1' "
                                            r'\(also used by mobile_robots\[0\]\)'):
        parse_scenario(scenario_dict(test_markers=[{'name': 'robot_1', 'position': [0, 0]}]), Path('.'))


def test_unregistered_section_is_an_unknown_key():
    with pytest.raises(ScenarioError, match='^test_markers: unknown top-level field'):
        parse_scenario(scenario_dict(test_markers=[]), Path('.'))


@pytest.mark.parametrize('key', ['name', 'camera', 'not-an-identifier', ''])
def test_reserved_or_invalid_section_keys_are_refused(key):
    with pytest.raises(ValueError):
        register_section(key, parse_markers)
