"""The recorder's and the scripted driver's start values, checked as the nodes check them."""
import pytest

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.tool_settings import DRIVER_SETTINGS, RECORDER_SETTINGS


@pytest.mark.parametrize('values, message', [
    ({}, 'parameter output: required'),
    ({'output': 'bag', 'exclude': ['(']}, "parameter exclude: invalid regular expression '('"),
    ({'output': 'bag', 'discovery_period': 0.0}, 'parameter discovery_period: must be in [0.01, 60]'),
    ({'output': 'bag', 'storage_preset': 'lz4'}, 'parameter storage_preset: must be one of none, '),
])
def test_recorder_refuses_bad_start_values(values, message):
    with pytest.raises(ConfigurationError) as error:
        RECORDER_SETTINGS.validate(values)
    assert str(error.value).startswith(message)


def test_recorder_defaults_record_everything_but_the_log_topics():
    values = RECORDER_SETTINGS.validate({'output': 'bag'})
    assert values['topics'] == [''] and values['exclude'] == ['/rosout', '/parameter_events']
    assert RECORDER_SETTINGS['discovery_period'].dynamic and not RECORDER_SETTINGS['output'].dynamic


@pytest.mark.parametrize('values, message', [
    ({}, 'parameter plan_file: required'),
    ({'plan_file': 'p.yaml', 'command_rate': -1.0}, 'parameter command_rate: must be in (0, 1000] (got -1.0)'),
    ({'plan_file': 'p.yaml', 'command_rate': 'fast'}, "parameter command_rate: must be a number (got 'fast')"),
])
def test_driver_refuses_bad_start_values(values, message):
    with pytest.raises(ConfigurationError) as error:
        DRIVER_SETTINGS.validate(values)
    assert str(error.value) == message
