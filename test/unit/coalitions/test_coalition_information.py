"""Information types, instances, referents and the generality order (Definitions 4.1-4.3)."""
import pytest

from coalition_agents.core import (
    LOCAL, Entity, EntityCatalog, InformationError, InformationInstance, InformationType, InformationTypes,
    Variable, canonical_instance, compare_generality, has_same_generality, is_more_general, parse_instance,
)
from coalition_agents.core.information import bind_to_ground, fresh_variable, match_template, split_conversion

TYPES = InformationTypes([InformationType('F_G', 1), InformationType('F_R', 2), InformationType('F_M', 0),
                          InformationType('F_X', 3)])
CATALOG = EntityCatalog(objects=frozenset({'goal', 'box'}), robots=frozenset({'robot_1', 'robot_2'}))


def inst(text):
    return parse_instance(text, TYPES, CATALOG)


def test_parse_distinguishes_variables_local_objects_and_robots():
    instance = inst('F_R(X, local)')
    assert instance.referents == (Variable('X'), LOCAL)
    assert inst('F_G(goal)').referents == (Entity('goal', robot=False),)
    assert inst('F_R(robot_1, Z2)').referents == (Entity('robot_1', robot=True), Variable('Z2'))
    assert inst('F_M').referents == () and inst('F_M()') == inst('F_M')
    assert str(inst('F_R( X ,local )')) == 'F_R(X, local)'


@pytest.mark.parametrize('text, message', [
    ('F_Q(X)', "unknown information type 'F_Q' (known: F_G, F_M, F_R, F_X)"),
    ('F_G(X, local)', 'information type F_G has 1 referent (got 2)'),
    ('F_R(X)', 'information type F_R has 2 referents (got 1)'),
    ('F_G(gaol)', "unknown entity 'gaol'"),
    ('F_R(X, X)', 'a referent appears twice'),
    ('F_R(X', 'malformed information instance'),
    ('F_R(X, 3a)', "malformed referent '3a'"),
    (42, 'must be a string'),
])
def test_parse_errors_are_clear(text, message):
    with pytest.raises(InformationError) as caught:
        inst(text)
    assert message in str(caught.value)


def test_yaml_flow_list_hint_for_unbalanced_parentheses():
    with pytest.raises(InformationError, match="write labels with commas in quotes"):
        inst('F_R(X')


@pytest.mark.parametrize('name', ['R1', 'X', 'local', '1robot', ''])
def test_entity_names_must_not_look_like_variables(name):
    with pytest.raises(InformationError):
        EntityCatalog(robots=frozenset({name}))


def test_instance_properties():
    instance = inst('F_X(X, local, goal)')
    assert instance.instantiated_positions == frozenset({1, 2})
    assert not instance.is_fully_instantiated and instance.has_local
    assert instance.variables == (Variable('X'),)
    assert inst('F_R(robot_1, goal)').is_fully_instantiated
    assert InformationInstance('F_R', (LOCAL, LOCAL)).is_degenerate
    bound = instance.substitute({Variable('X'): Entity('robot_2', robot=True)})
    assert str(bound) == 'F_X(robot_2, local, goal)'


# --- Definition 4.3 -------------------------------------------------------------------------

@pytest.mark.parametrize('general, specific', [
    ('F_R(X, Y)', 'F_R(local, Y)'),          # one more referent instantiated
    ('F_R(X, Y)', 'F_R(robot_1, goal)'),
    ('F_R(X, local)', 'F_R(robot_1, local)'),
    ('F_X(X, Y, goal)', 'F_X(X, local, goal)'),
])
def test_more_general(general, specific):
    assert is_more_general(inst(general), inst(specific))
    assert not is_more_general(inst(specific), inst(general))
    assert compare_generality(inst(general), inst(specific)) == '>'
    assert compare_generality(inst(specific), inst(general)) == '<'


@pytest.mark.parametrize('left, right', [
    ('F_R(local, X)', 'F_R(goal, Z)'),       # the same positions instantiated, other entities
    ('F_R(X, Y)', 'F_R(Z, W)'),
    ('F_G(local)', 'F_G(robot_2)'),
])
def test_same_generality(left, right):
    assert has_same_generality(inst(left), inst(right))
    assert not is_more_general(inst(left), inst(right))
    assert compare_generality(inst(left), inst(right)) == '='


def test_generality_is_partial():
    # "two information instances of the same type may or may not be comparable"
    left, right = inst('F_R(local, X)'), inst('F_R(X, local)')
    assert compare_generality(left, right) is None
    assert not is_more_general(left, right) and not is_more_general(right, left)
    assert not has_same_generality(left, right)


def test_different_types_are_not_comparable():
    assert compare_generality(inst('F_G(X)'), inst('F_R(X, Y)')) is None
    assert not has_same_generality(inst('F_G(X)'), inst('F_M'))


def test_match_template_binds_schema_variables_only():
    # The fiducial's label F_R(X, local) retrieves F_R(Z, local) and F_R(goal, local) ...
    assert match_template(inst('F_R(X, local)'), inst('F_R(Z, local)')) == {Variable('X'): Variable('Z')}
    assert match_template(inst('F_R(X, local)'), inst('F_R(goal, local)')) == {Variable('X'): Entity('goal', False)}
    # ... but cannot fix an entity the requirement leaves open, nor change an entity.
    assert match_template(inst('F_R(X, local)'), inst('F_R(local, X)')) is None
    assert match_template(inst('F_G(local)'), inst('F_G(X)')) is None
    assert match_template(inst('F_G(local)'), inst('F_R(X, local)')) is None


def test_bind_to_ground_enforces_one_entity_per_variable():
    label = inst('F_R(X, local)')
    binding = bind_to_ground(label, InformationInstance('F_R', (Entity('robot_1', True), LOCAL)), {})
    assert binding == {Variable('X'): Entity('robot_1', True)}
    assert bind_to_ground(label, inst('F_R(robot_2, local)'), binding) is None
    assert bind_to_ground(label, inst('F_R(X, local)'), {}) is None  # ground instances only


def test_canonical_instance_and_fresh_names():
    assert canonical_instance(inst('F_R(Z, W)')) == inst('F_R(X, Y)')
    assert canonical_instance(inst('F_R(local, Z)')) == inst('F_R(local, X)')
    assert fresh_variable('Z', {'X'}) == Variable('Z')
    assert fresh_variable('Z', {'Z', 'Z1'}) == Variable('Z2')


def test_split_conversion_enforces_iq_form():
    assert split_conversion('F_G(X) + F_R(Y, X) => F_G(Y)') == (['F_G(X)', 'F_R(Y, X)'], 'F_G(Y)')
    assert split_conversion('F_R(Y, X) ⇒ F_R(X, Y)') == (['F_R(Y, X)'], 'F_R(X, Y)')
    with pytest.raises(InformationError, match='single instance on the right'):
        split_conversion('F_R(X, Y) => F_R(Y, X) + F_G(X)')
    with pytest.raises(InformationError, match='iOR on the left'):
        split_conversion('F_G(X) iOR F_G(Y) => F_G(Z)')
    with pytest.raises(InformationError, match="exactly one '=>'"):
        split_conversion('F_G(X)')
