"""Algorithm 1: solution spaces, the GI/LR/EC constraints, potential solutions (Table III)."""
import pytest

from coalition_agents.core import (
    CoalitionError, Constraints, SchemaKind, SolutionSpaceCache, SolutionSpaceGenerator,
    capability_file_from_dict, external_communication_allows, generality_imposition_allows,
    load_capability_file, localness_allows,
)

TABLE3_COSTS = [5.0, 8.0, 8.5, 9.0, 9.5, 10.5, 11.0, 11.5, 11.5, 12.0, 12.0]


@pytest.fixture
def table3_space(library, costs, table3_robot, parse):
    """Table III: the navigation MS's F_G(local) input on a robot with fiducial, laser and GPS."""
    generator = SolutionSpaceGenerator(library, table3_robot, costs)
    return generator.motor_schema_space('navigate', [parse('F_G(local)')])


def chain(solution, kind):
    """Names of the schemas of ``kind`` in a potential solution, pre-order."""
    return [step.schema for step in solution.steps if step.kind is kind]


# --- Table III ---------------------------------------------------------------------------------

def test_table3_first_potential_solutions(table3_space):
    first = table3_space.potential_solutions(4, remove_dominated=False)
    assert [s.cost for s in first] == [5.0, 8.0, 8.5, 9.0]
    assert [s.summary() for s in first] == [
        'EPS gps: F_G(local)',                          # 1 + 4
        'CS: F_G(X), EPS fiducial: F_R(X, local)',      # 2 + 1 + 2 RPS + 4
        'CS: F_G(X), CS: F_R(local, X)',                # 2 + 2 + 1 RPS + 4
        'CS: F_G(X), CS: F_R(X, local)',                # 2 + 2 + 2 RPS + 4
    ]
    assert first[1].schemas() == [
        'MS navigate',
        'RPS global_from_relative: F_G(X) + F_R(local, X) => F_G(local)',
        'CS: F_G(X)',
        'RPS relative_inverse: F_R(X, local) => F_R(local, X)',
        'EPS fiducial: F_R(X, local)',
    ]


def test_table3_all_potential_solutions(table3_space):
    solutions = table3_space.potential_solutions(remove_dominated=False)
    assert [s.cost for s in solutions] == TABLE3_COSTS
    assert table3_space.count_potential_solutions() == 11
    # Rows 6-11 of Table III: the relative position comes through another entity Z.
    assert [s.summary() for s in solutions[5:7]] == [
        'CS: F_G(X), EPS fiducial: F_R(Z, local), CS: F_R(X, Z)',
        'CS: F_G(X), CS: F_R(local, Z), CS: F_R(X, Z)',
    ]
    # Row 5 (9.5) is row 3 with the relative position inverted twice.
    assert chain(solutions[4], SchemaKind.RPS) == ['global_from_relative', 'relative_inverse', 'relative_inverse']


def test_potential_solutions_are_in_non_descending_cost(library, costs, table3_robot, tasks):
    navigation = tasks['navigation']
    generator = SolutionSpaceGenerator(library, table3_robot, costs, extra_sensors=navigation.prior_sensors)
    space = generator.motor_schema_space('navigate', navigation.requires)
    solutions = space.potential_solutions(remove_dominated=False)
    assert len(solutions) == space.count_potential_solutions() == 11  # priors and laser are fixed
    assert [s.cost for s in solutions] == sorted(s.cost for s in solutions)
    # F_A(local) (laser, 1) and the a priori F_G(goal), F_M (0) are added to every solution.
    assert [s.cost for s in solutions] == [c + 1.0 for c in TABLE3_COSTS]
    assert solutions[0].summary() == 'EPS gps: F_G(local), PRIOR prior: F_G(goal), EPS laser: F_A(local), PRIOR prior: F_M'


def test_dominated_solutions_are_removed(table3_space):
    kept = table3_space.potential_solutions()
    # 9.5 needs what 8.5 needs; 11.5 (row 8) and both 12s need what 11.0 needs.
    assert [s.cost for s in kept] == [5.0, 8.0, 8.5, 9.0, 10.5, 11.0, 11.5]
    assert kept[-1].summary() == 'CS: F_G(X), CS: F_R(Z, local), CS: F_R(X, Z)'
    all_solutions = table3_space.potential_solutions(remove_dominated=False)
    assert all_solutions[6].information == all_solutions[7].information  # equal up to renaming
    assert all_solutions[6].information != all_solutions[8].information


def test_outputs_reading_of_generality_imposition_adds_two_solutions(library, costs, table3_robot, parse):
    generator = SolutionSpaceGenerator(library, table3_robot, costs,
                                       constraints=Constraints(generality_reading='outputs'))
    solutions = generator.motor_schema_space('navigate', [parse('F_G(local)')]).potential_solutions(
        remove_dominated=False)
    assert [s.cost for s in solutions] == TABLE3_COSTS + [14.0, 14.0]
    assert all(chain(s, SchemaKind.RPS).count('relative_composition') == 2 for s in solutions[11:])
    assert solutions[11].information == solutions[12].information
    with pytest.raises(CoalitionError, match="generality_reading: must be one of inputs, outputs"):
        Constraints(generality_reading='both')


# --- Generality Imposition -----------------------------------------------------------------------

def test_generality_imposition_predicate(parse):
    inverse = 'relative_inverse'
    # The path already converted F_R(X, local) (inputs reading) with relative_inverse.
    downstream = frozenset({(inverse, 'F_R', parse('F_R(X, local)').instantiated_positions)})
    assert generality_imposition_allows(inverse, [parse('F_R(local, X)')], downstream)   # not comparable
    assert not generality_imposition_allows(inverse, [parse('F_R(Z, local)')], downstream)  # as general
    assert not generality_imposition_allows(inverse, [parse('F_R(goal, local)')], downstream)  # less general
    assert generality_imposition_allows(inverse, [parse('F_R(X, Y)')], downstream)   # more general
    assert generality_imposition_allows('relative_composition', [parse('F_R(Z, local)')], downstream)
    # Several inputs: allowed while one of them is not dominated.
    composition = frozenset({('c', 'F_R', frozenset()), ('c', 'F_R', frozenset({0}))})
    assert not generality_imposition_allows('c', [parse('F_R(local, Z)'), parse('F_R(X, Z)')], composition)
    assert generality_imposition_allows('c', [parse('F_R(local, Z)')], frozenset({('c', 'F_R', frozenset({1}))}))


def test_generality_imposition_prunes_loops_but_allows_double_inversion(table3_space, library, costs,
                                                                       table3_robot, parse):
    solutions = table3_space.potential_solutions(remove_dominated=False)
    inversions = [len(_longest_run(s.root, 'relative_inverse')) for s in solutions]
    assert max(inversions) == 2       # F_R(local,X) <- F_R(X,local) <- F_R(local,X) is allowed
    # Without GI the same space (bounded by depth) contains a third inversion in a row.
    unbounded = SolutionSpaceGenerator(library, table3_robot, costs, max_depth=4,
                                       constraints=Constraints(generality_imposition=False))
    space = unbounded.motor_schema_space('navigate', [parse('F_G(local)')])
    assert space.count_potential_solutions() > 11
    assert max(len(_longest_run(s.root, 'relative_inverse'))
               for s in space.potential_solutions(remove_dominated=False)) >= 3


def _longest_run(step, schema, run=()):
    here = run + (step,) if step.schema == schema else ()
    best = here
    for child in step.inputs:
        found = _longest_run(child, schema, here)
        if len(found) > len(best):
            best = found
    return best


def test_without_generality_imposition_a_depth_bound_is_required(library, costs, table3_robot):
    with pytest.raises(CoalitionError, match='infinite .Lemma 4.2.; give max_depth'):
        SolutionSpaceGenerator(library, table3_robot, costs, constraints=Constraints(generality_imposition=False))


# --- Localness in Reasoning -----------------------------------------------------------------------

@pytest.mark.parametrize('text, allowed', [
    ('F_R(local, X)', True), ('F_G(local)', True), ('F_G(goal)', True), ('F_M', True),
    ('F_R(X, Z)', False), ('F_G(X)', False), ('F_R(goal, X)', False),
])
def test_localness_predicate(parse, text, allowed):
    assert localness_allows(parse(text)) is allowed


def test_localness_predicate_robot_entities(parse):
    assert not localness_allows(parse('F_R(robot_1, goal)', robots=('robot_1',)))
    assert localness_allows(parse('F_R(robot_1, local)', robots=('robot_1',)))


def _options_for(space, text, parse):
    """Kinds of the alternatives of the first requirement node for ``text`` in the space."""
    wanted = parse(text)
    stack, seen = [space.root], set()
    while stack:
        node = stack.pop()
        if node.uid in seen:
            continue
        seen.add(node.uid)
        if hasattr(node, 'options'):
            if node.instance == wanted:
                return sorted({option.kind.value for option in node.options})
            stack.extend(node.options)
        else:
            stack.extend(node.inputs)
    raise AssertionError(f'{text} not in the space')


def test_localness_in_the_space(table3_space, library, costs, table3_robot, parse):
    # F_R(X, Z) names neither this robot nor only objects: only a CS may provide it.
    assert _options_for(table3_space, 'F_R(X, Z)', parse) == ['cs']
    assert _options_for(table3_space, 'F_R(local, X)', parse) == ['cs', 'rps']
    no_lr = SolutionSpaceGenerator(library, table3_robot, costs,
                                   constraints=Constraints(localness_in_reasoning=False))
    space = no_lr.motor_schema_space('navigate', [parse('F_G(local)')])
    assert _options_for(space, 'F_R(X, Z)', parse) == ['cs', 'rps']
    assert space.count_potential_solutions() > table3_space.count_potential_solutions()


# --- External Communication -----------------------------------------------------------------------

@pytest.mark.parametrize('text, allowed', [
    ('F_G(local)', False), ('F_R(local, X)', True), ('F_G(X)', True), ('F_G(goal)', True), ('F_M', True),
])
def test_external_communication_predicate(parse, text, allowed):
    assert external_communication_allows(parse(text)) is allowed


def test_external_communication_in_the_space(table3_space, library, costs, table3_robot, parse):
    # A robot may not request its own global position: it must compute it (Table III has no
    # "CS: F_G(local)" row); without EC that request would be the second cheapest solution.
    assert _options_for(table3_space, 'F_G(local)', parse) == ['es_eps', 'rps']
    no_ec = SolutionSpaceGenerator(library, table3_robot, costs,
                                   constraints=Constraints(external_communication=False))
    solutions = no_ec.motor_schema_space('navigate', [parse('F_G(local)')]).potential_solutions(3)
    assert [(s.cost, s.summary()) for s in solutions[:2]] == [(5.0, 'EPS gps: F_G(local)'), (6.0, 'CS: F_G(local)')]


# --- Other tasks, robots and properties --------------------------------------------------------------

def test_robot_without_gps_starts_at_table3_row_two(library, costs, fig7_types, parse):
    generator = SolutionSpaceGenerator(library, fig7_types['type1'], costs)
    solutions = generator.motor_schema_space('navigate', [parse('F_G(local)')]).potential_solutions(
        remove_dominated=False)
    assert [s.cost for s in solutions] == TABLE3_COSTS[1:]


def test_robot_specific_perceptual_schema_is_used(library, costs, tasks, parse):
    robot = capability_file_from_dict({'robot_types': {'lidar_bot': {
        'sensors': [{'name': 'laser', 'provides': ['F_A(local)']}],
        'perceptual_schemas': [{'name': 'laser_localization', 'conversion': 'F_A(local) + F_M => F_G(local)'}],
    }}}, library).types['lidar_bot']
    generator = SolutionSpaceGenerator(library, robot, costs, extra_sensors=tasks['navigation'].prior_sensors)
    best = generator.motor_schema_space('navigate', [parse('F_G(local)')]).potential_solutions(1)[0]
    assert best.cost == 4.0 + 0.5 + 1.0 + 0.0
    assert best.schemas()[1] == 'PS laser_localization: F_A(local) + F_M => F_G(local)'


def test_box_pushing_torque_space(library, costs, tasks):
    pusher = capability_file_from_dict({'robot_types': {'pusher': {'sensors': [
        {'name': 'bumper', 'provides': ['F_B(local)']},
        {'name': 'force', 'provides': ['F_F(local)']},
        {'name': 'sonar', 'provides': ['F_R(box, local)']},
    ]}}}, library).types['pusher']
    task = tasks['box_pushing_torque']
    first, second = SolutionSpaceGenerator(library, pusher, costs).motor_schema_space(
        task.motor_schema, task.requires).potential_solutions(2)
    # Requesting the own torque (EC allows it: the box is not this robot) is cheaper than
    # computing it; whether anyone can provide it is decided when coalitions are formed.
    assert (first.cost, first.summary()) == (11.0, 'EPS bumper: F_B(local), CS: F_B(Y), CS: F_T(local, box), '
                                                   'CS: F_T(Y, box)')
    # MS 4 + bumper 1 + CS F_B(Y) 2 + torque (RPS 0.5 + force 1 + inverse 0.5 + sonar 1) + CS F_T(Y, box) 2
    assert second.cost == 12.0
    assert second.summary() == ('EPS bumper: F_B(local), CS: F_B(Y), EPS force: F_F(local), '
                                'EPS sonar: F_R(box, local), CS: F_T(Y, box)')
    assert 'RPS torque_from_force: F_F(local) + F_R(local, box) => F_T(local, box)' in second.schemas()


def test_monitoring_space_requests_what_names_no_local_robot(library, costs, fig7_types, tasks, parse):
    task = tasks['monitoring']
    space = SolutionSpaceGenerator(library, fig7_types['type2'], costs).motor_schema_space(
        task.motor_schema, task.requires)
    first, second = space.potential_solutions(2)
    assert (first.cost, first.summary()) == (6.0, 'CS: F_G(target)')   # ask who knows it
    assert (second.cost, second.summary()) == (8.5, 'CS: F_G(X), CS: F_R(target, X)')
    # LR: F_R(target, X) names no robot of ours and not only objects, so only a CS provides it.
    assert _options_for(space, 'F_R(target, X)', parse) == ['cs']


def test_generation_is_deterministic_and_memoised(library, costs, table3_robot, tasks):
    navigation = tasks['navigation']

    def solutions():
        generator = SolutionSpaceGenerator(library, table3_robot, costs, extra_sensors=navigation.prior_sensors,
                                           constraints=Constraints(generality_reading='outputs'))
        space = generator.motor_schema_space('navigate', navigation.requires)
        return generator, [(s.cost, s.schemas()) for s in space.potential_solutions(remove_dominated=False)]

    generator, first = solutions()
    assert first == solutions()[1]
    assert generator.stats.memo_hits > 0   # shared sub-trees were expanded once
    space = generator.motor_schema_space('navigate', navigation.requires)
    assert space.potential_solutions(2)[1] is space.potential_solutions()[1]   # extracted once
    cache = SolutionSpaceCache(library, costs)
    assert cache.generator(table3_robot) is cache.generator(table3_robot)
    assert cache.generator(table3_robot, navigation.prior_sensors) is not cache.generator(table3_robot)


def test_unsatisfiable_requirement_gives_an_empty_space(library, costs, fig7_types, parse):
    # Nobody can provide the own range information without a laser (F_A(local): no CS, EC).
    robot = capability_file_from_dict({'robot_types': {'blind': {}}}, library).types['blind']
    space = SolutionSpaceGenerator(library, robot, costs).motor_schema_space('navigate', [parse('F_A(local)')])
    assert space.is_empty and space.unsatisfiable == (parse('F_A(local)'),)
    assert space.potential_solutions() == [] and space.count_potential_solutions() == 0


@pytest.mark.parametrize('team_file', ['fig7_team.yaml', 'box_pushing_team.yaml'])
def test_reply_solutions_shared_through_placeholders_equal_generating_each_request(library, costs, config_dir,
                                                                                  team_file):
    """A request naming teammates is generated once with placeholder robots and renamed: the
    solutions, their order, costs and ranks equal those generated for the request itself."""
    team = dict(load_capability_file(config_dir / 'capabilities' / team_file, library).robots)
    robots = list(team)
    checked = 0
    for robot, capabilities in team.items():
        first, second = [r for r in robots if r != robot][:2]
        shared = SolutionSpaceCache(library, costs).generator(capabilities)
        for text in (f'F_R({first}, local)', f'F_R(local, {second})', f'F_G({first})', f'F_R({first}, {second})',
                     'F_R(X, local)', 'F_G(local)'):
            variant = library.parse(text, robots)
            direct = SolutionSpaceCache(library, costs).generator(capabilities).request_space(variant)
            expected = [(s.cost, s.rank, s.fixed_variables, s.schemas()) for s in direct.potential_solutions()]
            got = [(s.cost, s.rank, s.fixed_variables, s.schemas()) for s in shared.reply_solutions(variant)]
            assert got == expected, text
            checked += bool(expected)
    assert checked > 10
    # Requests naming different teammates share one generation: the renamed solutions name the
    # requested teammate, never a placeholder.
    solutions = shared.reply_solutions(library.parse(f'F_R({second}, local)', robots))
    assert solutions and all('_robot' not in line for s in solutions for line in s.schemas())
    assert any(second in line for s in solutions for line in s.schemas())
