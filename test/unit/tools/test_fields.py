"""The shared field readers: messages start with the dotted path, the caller's error class is raised."""
import pytest

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.fields import (Fields, check_int, check_name, check_number, check_vector, join_path,
                                      load_config_file, parse_yaml_text, read_yaml_file, require_list)


class PackageError(ConfigurationError):
    """Stands for a package's own error type (ScenarioError, ConfigError, ...)."""


def test_paths_join_keys_and_indices():
    assert join_path('', 'robots') == 'robots'
    assert join_path('robots', 2) == 'robots[2]'
    assert join_path('robots[2]', 'name') == 'robots[2].name'


@pytest.mark.parametrize('value, bounds, message', [
    ('1', {}, "speed: must be a number (got str '1')"),
    (True, {}, 'speed: must be a number (got bool True)'),
    (float('nan'), {}, 'speed: must be finite (got nan)'),
    (0.0, {'gt': 0.0}, 'speed: must be > 0.0 (got 0.0)'),
    (-1, {'ge': 0.0}, 'speed: must be >= 0.0 (got -1.0)'),
    (2.0, {'lt': 2.0}, 'speed: must be < 2.0 (got 2.0)'),
    (3, {'le': 2.0}, 'speed: must be <= 2.0 (got 3.0)'),
])
def test_numbers_name_the_bound_they_break(value, bounds, message):
    with pytest.raises(PackageError) as error:
        check_number(value, 'speed', error=PackageError, **bounds)
    assert str(error.value) == message


def test_good_values_come_back_typed():
    assert check_number(2, 'x', ge=0) == 2.0 and isinstance(check_number(2, 'x'), float)
    assert check_int(3, 'n', ge=1, le=3) == 3
    assert check_vector([1, 2], 'p', 2) == (1.0, 2.0)
    assert check_name('burger_1', 'robot') == 'burger_1'
    assert require_list((1, 2), 'l') == [1, 2]


def test_default_error_is_the_shared_configuration_error():
    with pytest.raises(ConfigurationError, match=r'^n: must be an integer'):
        check_int(1.5, 'n')
    with pytest.raises(ConfigurationError, match=r"invalid name '1robot'"):
        check_name('1robot', 'robot')


def test_fields_reject_unknown_keys_and_read_each_kind():
    data = {'name': 'arm', 'reach': 0.8, 'joints': 6, 'color': [1, 0, 0], 'enabled': True,
            'mode': 'fast', 'links': [{'a': 1}], 'tools': {'gripper': 1}, 'note': ''}
    fields = Fields(data, 'arms[0]', allowed=list(data) + ['missing'], error=PackageError)
    assert fields.name() == 'arm'
    assert fields.number('reach', gt=0) == 0.8
    assert fields.integer('joints', ge=1) == 6
    assert fields.color() == (1.0, 0.0, 0.0)
    assert fields.boolean('enabled') is True
    assert fields.choice('mode', ('fast', 'slow')) == 'fast'
    assert fields.items('links') == [('arms[0].links[0]', {'a': 1})]
    assert fields.entries('tools') == [('arms[0].tools.gripper', 'gripper', 1)]
    assert fields.string('note', allow_empty=True) == ''
    assert fields.number('missing', 2.5) == 2.5
    with pytest.raises(PackageError, match=r'^arms\[0\]\.missing: missing required field$'):
        fields.raw('missing')
    with pytest.raises(PackageError, match=r"^arms\[0\]\.note: must be a non-empty string"):
        fields.string('note')
    with pytest.raises(PackageError, match=r"^arms\[0\]\.mode: must be one of slow \(got 'fast'\)"):
        fields.choice('mode', ('slow',))
    with pytest.raises(PackageError, match=r'^arms\[0\]\.speed: unknown field \(allowed: name'):
        Fields({'speed': 1}, 'arms[0]', allowed=('name',), error=PackageError)
    with pytest.raises(PackageError, match=r'^arms: must be a mapping \(got list\)'):
        Fields([], 'arms', allowed=(), error=PackageError)


def test_nested_sections_keep_the_path():
    fields = Fields({'camera': {'width': 0}}, 'scene', allowed=('camera', 'light'))
    with pytest.raises(ConfigurationError, match=r'^scene\.camera\.width: must be >= 16'):
        fields.sub('camera', ('width',)).integer('width', ge=16)
    assert fields.sub('light', ('power',), default=None).number('power', 1.0) == 1.0


def test_files_and_text_name_where_they_came_from(tmp_path):
    missing = tmp_path / 'nope.yaml'
    with pytest.raises(PackageError, match=r"^team file '.*nope.yaml': does not exist$"):
        read_yaml_file(missing, 'team file', PackageError)
    empty = tmp_path / 'empty.yaml'
    empty.write_text('')
    with pytest.raises(ConfigurationError, match='file is empty'):
        read_yaml_file(empty)
    broken = tmp_path / 'broken.yaml'
    broken.write_text('a: [1, 2\n')
    with pytest.raises(ConfigurationError, match='invalid YAML'):
        read_yaml_file(broken)
    with pytest.raises(PackageError, match=r'^invalid YAML'):
        parse_yaml_text('a: [', PackageError)
    good = tmp_path / 'team.yaml'
    good.write_text('robots: 3\n')

    def read(data):
        return Fields(data, '', allowed=('robots',), error=PackageError).integer('robots', le=2)

    with pytest.raises(PackageError, match=rf'^{good}: robots: must be <= 2 \(got 3\)$'):
        load_config_file(good, read, PackageError)
