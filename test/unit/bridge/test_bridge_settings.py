"""The bridge node's parameters as a schema: bad start values name the parameter and what is allowed.

These are the checks the node applies when it declares the schema (a bad value exits 2 with the
same message; test/integration/test_bridge_startup_errors.py proves that once for a real node).
"""
import pytest

from collab_tools.core.errors import ConfigurationError
from pybullet_bridge.core.settings import BRIDGE_SETTINGS, CAMERA_SETTINGS, NODE_SETTINGS

GOOD = {'scenario': '/tmp/scenario.yaml'}


def test_defaults_with_a_scenario_are_the_documented_start_values():
    values = NODE_SETTINGS.validate(GOOD)
    assert values == {'scenario': '/tmp/scenario.yaml', 'scenario_directories': [''], 'real_time_factor': 1.0, 'control_period': 0.01,
                      'fast_batch_period': 0.0, 'clock_rate': 0.0, 'ground_truth_rate': 20.0, 'status_rate': 1.0, 'start_paused': False,
                      'camera_renderer': 'tiny', 'publish_camera': True, 'compressed_rate': 0.0, 'jpeg_quality': 95}


def test_which_parameters_change_at_run_time():
    assert [s.name for s in NODE_SETTINGS if s.dynamic] == [
        'real_time_factor', 'ground_truth_rate', 'status_rate', 'publish_camera', 'compressed_rate', 'jpeg_quality']


@pytest.mark.parametrize('values, expected', [
    ({'real_time_factor': -1.0}, ['parameter real_time_factor', '[0, 1000]']),
    ({'real_time_factor': 'fast'}, ['parameter real_time_factor', 'must be a number']),   # a string for a double
    ({'control_period': 0.0}, ['parameter control_period', '(0, 1]']),                    # an open bound
    ({'control_period': 1.5}, ['parameter control_period', '(0, 1]']),
    ({'ground_truth_rate': 0.0}, ['parameter ground_truth_rate', '(0, 1000]']),
    ({'status_rate': 5000.0}, ['parameter status_rate', '(0, 1000]']),
    ({'status_rate': float('nan')}, ['parameter status_rate', 'must be finite']),
    ({'start_paused': 'yes'}, ['parameter start_paused', 'true or false']),
    ({'scenario': ''}, ['parameter scenario: required']),
    ({'clock_rate': -1.0}, ['parameter clock_rate', '[0, 1000]']),
    ({'camera_renderer': 'opengl'}, ['parameter camera_renderer', 'auto, egl, tiny']),
])
def test_bad_bridge_parameter_names_the_parameter(values, expected):
    with pytest.raises(ConfigurationError) as error:
        BRIDGE_SETTINGS.validate({**GOOD, **values})
    for text in expected:
        assert text in str(error.value)


def test_scenario_is_required_without_a_value():
    with pytest.raises(ConfigurationError, match='^parameter scenario: required$'):
        BRIDGE_SETTINGS.validate({})


@pytest.mark.parametrize('values, expected', [
    ({'jpeg_quality': 0}, ['parameter jpeg_quality', '[1, 100]']),
    ({'jpeg_quality': 101}, ['parameter jpeg_quality', '[1, 100]']),
    ({'jpeg_quality': 90.5}, ['parameter jpeg_quality', 'must be an integer']),
    ({'compressed_rate': -2.0}, ['parameter compressed_rate', '[0, 1000]']),
    ({'publish_camera': 1}, ['parameter publish_camera', 'true or false']),
])
def test_bad_camera_parameter_names_the_parameter(values, expected):
    with pytest.raises(ConfigurationError) as error:
        CAMERA_SETTINGS.validate(values)
    for text in expected:
        assert text in str(error.value)


def test_an_integer_for_a_double_is_taken_as_that_double():
    values = BRIDGE_SETTINGS.validate({**GOOD, 'real_time_factor': 0, 'status_rate': 2})
    assert values['real_time_factor'] == 0.0 and isinstance(values['real_time_factor'], float)
    assert values['status_rate'] == 2.0


def test_unknown_parameter_is_refused():
    with pytest.raises(ConfigurationError, match='parameter real_time_facter: unknown'):
        NODE_SETTINGS.validate({**GOOD, 'real_time_facter': 2.0})
