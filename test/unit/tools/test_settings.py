"""Node settings as plain data: the checks a node applies at start, without starting one."""
import math

import pytest

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.settings import Setting, SettingsSchema, kind_of

SCHEMA = SettingsSchema(
    Setting('horizon', 3, 'rolling horizon T', low=0, high=6),
    Setting('rate', 10.0, 'Hz', low=0.0, low_open=True, dynamic=True),
    Setting('mode', 'core', 'how to run', choices=('core', 'sim')),
    Setting('scenario', '', 'scenario file', required=True),
    Setting('origin', [0.0, 0.0], 'x, y', length=2),
    Setting('robots', [''], 'robot names', check=lambda v: None if len(set(v)) == len(v) else 'names repeat'),
    Setting('verbose', False, 'log every message'),
)


def test_kinds_follow_the_defaults():
    assert [kind_of(v) for v in (True, 1, 1.0, 's', [1.0], [''], [1], [False])] == [
        'bool', 'integer', 'double', 'string', 'double_array', 'string_array', 'integer_array', 'bool_array']
    with pytest.raises(TypeError):
        kind_of([])


def test_valid_values_with_defaults_filled_in():
    values = SCHEMA.validate({'scenario': 's.yaml', 'rate': 5, 'use_sim_time': True})
    assert values['horizon'] == 3 and values['rate'] == 5.0 and isinstance(values['rate'], float)
    assert values['scenario'] == 's.yaml' and values['origin'] == [0.0, 0.0]


@pytest.mark.parametrize('values, message', [
    ({'horizon': 7}, 'parameter horizon: must be in [0, 6] (got 7)'),
    ({'horizon': 2.0}, 'parameter horizon: must be an integer (got 2.0)'),
    ({'rate': 0.0}, 'parameter rate: must be in (0, inf] (got 0.0)'),
    ({'rate': math.inf}, 'parameter rate: must be finite (got inf)'),
    ({'rate': 'fast'}, "parameter rate: must be a number (got 'fast')"),
    ({'mode': 'real'}, "parameter mode: must be one of core, sim (got 'real')"),
    ({'origin': [1.0]}, 'parameter origin: must have exactly 2 elements (got 1)'),
    ({'robots': ['a', 'a']}, 'parameter robots: names repeat'),
    ({'verbose': 1}, 'parameter verbose: must be true or false (got 1)'),
    ({'horizn': 2}, 'parameter horizn: unknown (known: horizon, rate, mode, scenario, origin, robots, verbose)'),
])
def test_bad_values_are_named_with_what_is_allowed(values, message):
    with pytest.raises(ConfigurationError) as error:
        SCHEMA.validate({'scenario': 's.yaml', **values})
    assert str(error.value) == message


def test_a_required_setting_without_a_value_is_refused():
    with pytest.raises(ConfigurationError, match='^parameter scenario: required$'):
        SCHEMA.validate({})


def test_constraints_read_as_the_descriptor_shows_them():
    assert SCHEMA['horizon'].constraints_text() == 'in [0, 6]'
    assert SCHEMA['rate'].constraints_text() == 'in (0, inf]'
    assert SCHEMA['scenario'].constraints_text() == 'required (no default)'
    assert SCHEMA['rate'].dynamic and not SCHEMA['horizon'].dynamic


def test_schemas_refuse_a_setting_declared_twice_and_extend():
    with pytest.raises(ValueError, match='declared twice: rate'):
        SettingsSchema(Setting('rate', 1.0, 'a'), Setting('rate', 2.0, 'b'))
    extended = SCHEMA.extended(Setting('seed', 0, 'random seed', low=0))
    assert extended.names[-1] == 'seed' and 'seed' not in SCHEMA
