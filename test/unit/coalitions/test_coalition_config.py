"""Schemas, costs, the RPS library, capability files and tasks: loading and clear errors."""
from pathlib import Path

import pytest

from coalition_agents.core import (
    ConfigError, Costs, SchemaKind, capability_file_from_dict, capability_file_from_text, costs_from_dict,
    library_from_dict,
    load_capability_file, tasks_from_dict,
)
from coalition_agents.core.schemas import parse_conversion


def test_paper_costs(costs):
    # Section V-A-1: cost(RPS) = 0.5, cost(ES-EPS) = 1.0, cost(CS) = 2.0, cost(MS) = 4.0.
    assert (costs.rps, costs.es_eps, costs.cs, costs.ms, costs.prior) == (0.5, 1.0, 2.0, 4.0, 0.0)
    assert costs.of(SchemaKind.RPS) == 0.5 and costs.of(SchemaKind.CS) == 2.0
    assert costs.motor_schema('navigate') == 4.0
    assert costs.motor_schema('maintain_relative_position') == 6.0  # footnote 14


def test_costs_defaults_and_errors():
    assert costs_from_dict({}) == Costs()
    with pytest.raises(ConfigError, match=r'^cs: must be > 0.0 \(got 0.0\)'):
        costs_from_dict({'cs': 0})
    with pytest.raises(ConfigError, match=r"^rsp: unknown field \(allowed: rps, ps, es_eps"):
        costs_from_dict({'rsp': 0.5})
    with pytest.raises(ConfigError, match=r"^motor_schemas.navigate: must be a number"):
        costs_from_dict({'motor_schemas': {'navigate': 'cheap'}})
    with pytest.raises(ConfigError, match=r'^ms: must be a number \(got bool True\)'):
        costs_from_dict({'ms': True})


def test_library_has_table_one(library):
    texts = {c.name: c.text() for c in library.reductions}
    assert texts['global_from_relative'] == 'F_G(X) + F_R(Y, X) => F_G(Y)'
    assert texts['relative_inverse'] == 'F_R(Y, X) => F_R(X, Y)'
    assert texts['relative_composition'] == 'F_R(X, Z) + F_R(Y, Z) => F_R(X, Y)'
    assert library.types.get('F_R').referents == 2 and library.types.get('F_M').referents == 0
    assert library.catalog.objects >= {'goal', 'box', 'target'}


@pytest.mark.parametrize('data, message', [
    ({'information_types': {'F_G': {'referents': 1.5}}}, 'information_types.F_G.referents: must be a whole number'),
    ({'information_types': {'F_G': {'referents': 1}}, 'objects': ['X1']},
     "objects[0]: entity name 'X1' looks like a variable"),
    ({'information_types': {'F_G': {'referents': 1}},
      'reduction_schemas': [{'name': 'bad', 'conversion': 'F_G(X) => F_Q(X)'}]},
     "reduction_schemas[0].conversion: unknown information type 'F_Q' (known: F_G)"),
    ({'information_types': {'F_G': {'referents': 1}},
      'reduction_schemas': [{'name': 'invent', 'conversion': 'F_G(X) => F_G(Y)'}]},
     'output variable(s) Y appear in no input'),
    ({'information_types': {'F_G': {'referents': 1}},
      'reduction_schemas': [{'name': 'a', 'conversion': 'F_G(X) => F_G(X)'},
                            {'name': 'a', 'conversion': 'F_G(X) => F_G(X)'}]},
     "reduction_schemas[1].name: schema name 'a' is used twice"),
    ({'information_types': {'F_G': {'referents': 1}}, 'rpss': []}, 'rpss: unknown field'),
])
def test_library_errors(data, message):
    with pytest.raises(ConfigError) as caught:
        library_from_dict(data)
    assert message in str(caught.value)


def test_conversion_inputs_for_populates_and_names_fresh_variables(library):
    composition = library.reduction('relative_composition')
    inputs, fresh = composition.inputs_for(library.parse('F_R(local, X)'))
    # X is taken by the requirement, the RPS's Y binds to it; its Z is fresh.
    assert [str(i) for i in inputs] == ['F_R(local, Z)', 'F_R(X, Z)']
    assert [v.name for v in fresh] == ['Z']
    inputs, fresh = composition.inputs_for(library.parse('F_R(Z, local)'))
    assert [str(i) for i in inputs] == ['F_R(Z, Z1)', 'F_R(local, Z1)']
    # The referent instantiation constraint: no conversion whose output does not match.
    assert composition.inputs_for(library.parse('F_G(local)')) is None


def test_conversion_rejects_inputs_naming_one_entity_twice(library):
    # "F_R(X, goal) => F_G(X)" asked for F_G(goal) would need F_R(goal, goal): a conflict.
    conversion = parse_conversion('from_goal', 'F_R(X, goal) => F_G(X)', library.types, library.catalog)
    assert conversion.inputs_for(library.parse('F_G(local)'))[0] == (library.parse('F_R(local, goal)'),)
    assert conversion.inputs_for(library.parse('F_G(goal)')) is None


def test_table3_capability_file(table3_robot):
    assert [(s.sensor, str(s.output)) for s in table3_robot.sensors] == [
        ('fiducial', 'F_R(X, local)'), ('laser', 'F_A(local)'), ('gps', 'F_G(local)')]
    assert 'navigate' in table3_robot.motor_schemas


CAPABILITY_ERRORS = [
    ({}, 'robot_types: missing required field'),
    ({'robot_types': {'scout': {'sensors': [{'name': 'cam', 'provides': ['F_Q(X)']}]}}},
     "robot_types.scout.sensors[0].provides[0]: unknown information type 'F_Q'"),
    ({'robot_types': {'scout': {'sensors': [{'name': 'cam', 'provides': ['F_R(X']}]}}},
     "robot_types.scout.sensors[0].provides[0]: malformed information instance 'F_R(X'"),
    ({'robot_types': {'scout': {'sensors': [{'name': 'cam', 'provides': []}]}}},
     'robot_types.scout.sensors[0].provides: a sensor must provide at least one label'),
    ({'robot_types': {'scout': {'sensors': [{'name': 'prior', 'provides': ['F_M']}]}}},
     "robot_types.scout.sensors[0].name: 'prior' is reserved"),
    ({'robot_types': {'scout': {'sensors': [{'name': 'cam', 'provides': ['F_M']},
                                            {'name': 'cam', 'provides': ['F_M']}]}}},
     "robot_types.scout.sensors[1].name: sensor 'cam' is listed twice"),
    ({'robot_types': {'scout': {'sensor': []}}}, 'robot_types.scout.sensor: unknown field'),
    ({'robot_types': {'scout': {'perceptual_schemas': [
        {'name': 'relative_inverse', 'conversion': 'F_R(X, local) => F_R(local, X)'}]}}},
     "robot_types.scout.perceptual_schemas[0].name: 'relative_inverse' shadows a library RPS"),
    ({'robot_types': {'scout': {}}, 'robots': {'R1': 'scout'}}, "robots.R1: entity name 'R1' looks like a variable"),
    ({'robot_types': {'scout': {}}, 'robots': {'robot_1': 'sout'}}, "robots.robot_1: unknown robot type 'sout'"),
    ({'robot_types': {'scout': {'motor_schemas': 'navigate'}}},
     'robot_types.scout.motor_schemas: must be a list (got str)'),
    ([1, 2], '<file>: must be a mapping (got list)'),
]


@pytest.mark.parametrize('data, message', CAPABILITY_ERRORS)
def test_capability_file_errors(library, data, message):
    with pytest.raises(ConfigError) as caught:
        capability_file_from_dict(data, library)
    assert message in str(caught.value)


def test_capability_file_errors_name_the_file(library, tmp_path: Path):
    path = tmp_path / 'caps.yaml'
    path.write_text("robot_types:\n  scout:\n    sensors:\n      - name: cam\n        provides: [F_R(X, local)]\n")
    with pytest.raises(ConfigError) as caught:
        load_capability_file(path, library)
    assert str(caught.value).startswith(f'{path}: robot_types.scout.sensors[0].provides[0]: malformed')
    path.write_text('robot_types: [unclosed\n')
    with pytest.raises(ConfigError, match='invalid YAML'):
        load_capability_file(path, library)
    with pytest.raises(ConfigError, match='missing.yaml.*does not exist'):
        load_capability_file(tmp_path / 'missing.yaml', library)


def test_capability_document_as_text_is_the_file(library, config_dir):
    """A capability document given as text (the agents' capabilities parameter) parses as the file does."""
    path = config_dir / 'capabilities' / 'box_pushing_team.yaml'
    from_text = capability_file_from_text(path.read_text(), library)
    assert from_text == load_capability_file(path, library)
    assert from_text.robots['pusher_g1'].sensor_names  # not vacuous: a real team
    # Flow style on one line (what the experiments generate) too.
    assert capability_file_from_text("{robot_types: {scout: {sensors: [{name: gps, provides: ['F_G(local)']}]}}, "
                                     "robots: {robot_1: scout}}", library).robots['robot_1'].sensor_names == ('gps',)


@pytest.mark.parametrize('text, message', [
    ('robot_types: [unclosed', 'invalid YAML'),
    ('', 'must be a mapping (got null)'),
    ('robot_types: {scout: {sensors: [{name: cam, provides: [F_Q(local)]}]}}', 'robot_types.scout.sensors[0].provides[0]'),
    ('robot_types: {scout: {}}\nrobots: {robot_1: sout}', "robots.robot_1: unknown robot type 'sout'"),
])
def test_capability_text_errors_name_the_field(library, text, message):
    with pytest.raises(ConfigError) as caught:
        capability_file_from_text(text, library)
    assert message in str(caught.value)


def test_robot_specific_perceptual_schema(library):
    caps = capability_file_from_dict({'robot_types': {'lidar_bot': {
        'sensors': [{'name': 'laser', 'provides': ['F_A(local)']}],
        'perceptual_schemas': [{'name': 'laser_localization', 'conversion': 'F_A(local) + F_M => F_G(local)'}],
    }}}, library).types['lidar_bot']
    (ps,) = caps.perceptual_schemas
    assert ps.kind is SchemaKind.PS and ps.text() == 'F_A(local) + F_M => F_G(local)'


def test_tasks(tasks, library):
    navigation = tasks['navigation']
    assert [str(i) for i in navigation.requires] == ['F_G(local)', 'F_G(goal)', 'F_A(local)', 'F_M']
    assert [str(i) for i in navigation.prior] == ['F_G(goal)', 'F_M']
    assert navigation.helper_motor_schema == 'maintain_relative_position'
    assert [str(i) for i in tasks['box_pushing_torque'].requires] == [
        'F_B(local)', 'F_B(Y)', 'F_T(local, box)', 'F_T(Y, box)']
    second = tasks['monitoring'].with_objects({'target': 'target_2'})
    assert [str(i) for i in second.requires] == ['F_G(target_2)']
    assert navigation.requirements([library.parse('F_G(local)')]) == (library.parse('F_G(local)'),)
    with pytest.raises(ConfigError, match='F_B.local. is not an input of its motor schema'):
        navigation.requirements([library.parse('F_B(local)')])


@pytest.mark.parametrize('data, message', [
    ({'tasks': {'go': {'motor_schema': 'navigate', 'requires': []}}},
     'tasks.go.requires: a task must require at least one information instance'),
    ({'tasks': {'go': {'motor_schema': 'navigate', 'requires': ['F_G(local)', 'F_G(local)']}}},
     'tasks.go.requires: an instance is listed twice'),
    ({'tasks': {'go': {'motor_schema': 'navigate', 'requires': ['F_G(local)'], 'prior': ['F_G(X)']}}},
     'tasks.go.prior[0]: a priori information must name objects only'),
    ({'tasks': {'go': {'motor_schema': 'navigate', 'requires': ['F_Z(local)']}}},
     "tasks.go.requires[0]: unknown information type 'F_Z'"),
    ({'tasks': {'go': {'requires': ['F_G(local)']}}}, 'tasks.go.motor_schema: missing required field'),
    ({'tasks': {}}, 'tasks: define at least one task'),
])
def test_task_errors(library, data, message):
    with pytest.raises(ConfigError) as caught:
        tasks_from_dict(data, library)
    assert message in str(caught.value)
