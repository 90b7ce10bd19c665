"""Coalitions across robots: requests (footnote 9), Distinct Requests, coalition cost (Table V)."""
import pytest

from coalition_agents.core import (
    CoalitionError, CoalitionSearch, InformationRequest, RequestError, RequestLedger, RobotReasoner,
    SearchError, StaticSensing, addressees, load_capability_file, request_variants,
)

TEAM = ('robot_1', 'robot_2', 'robot_3')


def labels(instances):
    return [str(i) for i in instances]


# --- Requests ----------------------------------------------------------------------------------------

@pytest.mark.parametrize('label, variants', [
    ('F_G(X)', ['F_G(local)']),                                # instantiate X to me
    ('F_R(robot_1, X)', ['F_R(robot_1, local)']),
    ('F_R(X, Y)', ['F_R(local, Y)', 'F_R(X, local)']),         # every way to put me in
    ('F_R(robot_2, X)', ['F_R(local, X)']),                    # I am named: as it is
    ('F_G(goal)', ['F_G(goal)']),                              # objects only: as it is
    ('F_M', ['F_M']),
    ('F_R(robot_1, robot_3)', []),                             # about others: I could only relay it
])
def test_request_variants_footnote_9(parse, label, variants):
    assert labels(request_variants(parse(label, TEAM), 'robot_2')) == variants


def test_addressees(parse):
    assert addressees(parse('F_G(X)', TEAM), TEAM) == TEAM               # incl. the requester itself
    assert addressees(parse('F_R(robot_1, X)', TEAM), TEAM) == TEAM
    assert addressees(parse('F_R(robot_3, robot_1)', TEAM), TEAM) == ('robot_1', 'robot_3')
    assert addressees(parse('F_G(goal)', TEAM), TEAM) == TEAM


def test_request_ledger_distinct_requests(parse):
    ledger = RequestLedger('robot_1')
    assert ledger.admit(parse('F_R(robot_1, X)', TEAM))
    assert not ledger.admit(parse('F_R(robot_1, Z)', TEAM))   # the same instance up to renaming
    assert ledger.admit(parse('F_R(X, robot_1)', TEAM))
    assert ledger.suppressed == 1
    # A stateless responder applies it from the request's chain.
    chain = (('robot_2', parse('F_G(X)', TEAM)),)
    assert not RequestLedger('robot_2').admit(parse('F_G(Y)', TEAM), chain)
    assert RequestLedger('robot_3').admit(parse('F_G(Y)', TEAM), chain)


def test_request_round_trip_and_malformed_requests(library, parse):
    catalog = library.catalog.with_robots(TEAM)
    request = InformationRequest('robot_1', parse('F_R(robot_1, X)', TEAM), (('robot_3', parse('F_G(X)', TEAM)),))
    assert InformationRequest.from_dict(request.to_dict(), library.types, catalog) == request
    bad = [
        ('not a request', 'request: must be a mapping'),
        ({'requester': 'robot_1', 'label': 'F_G(X)', 'urgent': True}, 'request.urgent: unknown field'),
        ({'requester': 'robot_9', 'label': 'F_G(X)'}, "request.requester: unknown robot 'robot_9'"),
        ({'requester': 'robot_1', 'label': 'F_Q(X)'}, "request.label: unknown information type 'F_Q'"),
        ({'requester': 'robot_1', 'label': 'F_R(X)'}, 'request.label: F_R(X): information type F_R has 2 referents'),
        ({'requester': 'robot_1', 'label': 'F_G(local)'}, "request.label: a request names robots, not 'local'"),
        ({'requester': 'robot_1', 'label': None}, 'request.label: an information instance must be a string'),
        ({'requester': 'robot_1', 'label': 'F_G(X)', 'chain': [{'requester': 'robot_2'}]},
         'request.chain[0]: must be a mapping with requester and label'),
        ({'requester': 'robot_1', 'label': 'F_G(X)', 'chain': 'robot_2'}, 'request.chain: must be a list'),
    ]
    for data, message in bad:
        with pytest.raises(RequestError) as caught:
            InformationRequest.from_dict(data, library.types, catalog)
        assert message in str(caught.value)


# --- Coalitions in a situation ----------------------------------------------------------------------

def run_search(library, costs, task, team, readings, initiators, **options):
    sensing = StaticSensing.from_text(readings, library, list(team))
    search = CoalitionSearch(library, costs, task, team, sensing, **options)
    return search, search.run(initiators)


def fig7_situation(fig7_types, visible):
    """robot_red (no localisation) and two localising helpers; ``visible`` = fiducial readings."""
    team = {'robot_red': fig7_types['type1'], 'helper_1': fig7_types['type2'], 'helper_2': fig7_types['type2']}
    readings = {robot: {'laser': [f'F_A({robot})']} for robot in team}
    for helper in ('helper_1', 'helper_2'):
        readings[helper]['localization'] = [f'F_G({helper})']
    for robot, seen in visible.items():
        readings[robot]['fiducial'] = seen
    return team, readings


def test_table5_coalition_costs(library, costs, tasks, fig7_types):
    # robot_red sees helper_1; helper_2 sees robot_red (Fig. 7: "coalitions with cost 16 and 17.5").
    team, readings = fig7_situation(fig7_types, {'robot_red': ['F_R(helper_1, robot_red)'],
                                                 'helper_2': ['F_R(robot_red, helper_2)']})
    _, results = run_search(library, costs, tasks['navigation'], team, readings, ['robot_red'])
    result = results['robot_red']
    per_members = result.per_members()
    assert [(c.cost, c.members) for c in per_members[:2]] == [
        (16.0, ('robot_red', 'helper_1')), (17.5, ('robot_red', 'helper_2'))]
    best, second = per_members[:2]
    # 16 = Table III row 2 (8) + laser (1) + helper_1: localisation (1) + MS keeping the relative position (6)
    assert best.root.potential_solution.cost == 9.0 and best.root.potential_solution.rank == 0
    assert best.local_coalition == ('robot_red', 'helper_1')
    assert [line for line in best.root.step_lines() if line.startswith(('CS', 'EPS fiducial'))] == [
        'CS: F_G(helper_1) from helper_1', 'EPS fiducial: F_R(helper_1, robot_red)']
    # 17.5 = row 3 (8.5) + laser (1) + helper_2: localisation (1) + its fiducial sees robot_red (1) + MS (6)
    assert second.root.potential_solution.cost == 9.5
    assert sorted(str(o.instance) for o in second.root.offers) == ['F_G(helper_2)', 'F_R(robot_red, helper_2)']
    assert result.coalitions[0] is best


def test_executability_depends_on_the_configuration(library, costs, tasks, fig7_types):
    # Nobody sees anybody: the same potential solutions exist, but no coalition is executable.
    team, readings = fig7_situation(fig7_types, {})
    _, results = run_search(library, costs, tasks['navigation'], team, readings, ['robot_red'])
    assert results['robot_red'].potential_solutions and results['robot_red'].coalitions == ()
    # Every helper visible to robot_red: a coalition with each of them ("possible coalitions").
    team, readings = fig7_situation(fig7_types, {'robot_red': ['F_R(helper_1, robot_red)', 'F_R(helper_2, robot_red)']})
    _, results = run_search(library, costs, tasks['navigation'], team, readings, ['robot_red'])
    assert [(c.cost, c.members) for c in results['robot_red'].per_members()[:2]] == [
        (16.0, ('robot_red', 'helper_1')), (16.0, ('robot_red', 'helper_2'))]


def test_a_robot_that_localises_needs_no_helper(library, costs, tasks, fig7_types):
    team, readings = fig7_situation(fig7_types, {})
    _, results = run_search(library, costs, tasks['navigation'], team, readings, ['helper_1'])
    best = results['helper_1'].best
    assert (best.cost, best.members) == (6.0, ('helper_1',))   # MS 4 + localisation 1 + laser 1


def mutual_team(fig7_types):
    """Two robots that see each other and cannot localise: each needs the other's position."""
    team = {'robot_a': fig7_types['type1'], 'robot_b': fig7_types['type1']}
    readings = {'robot_a': {'laser': ['F_A(robot_a)'], 'fiducial': ['F_R(robot_b, robot_a)']},
                'robot_b': {'laser': ['F_A(robot_b)'], 'fiducial': ['F_R(robot_a, robot_b)']}}
    return team, readings


def test_distinct_requests_stop_request_loops(library, costs, tasks, fig7_types):
    team, readings = mutual_team(fig7_types)
    search, results = run_search(library, costs, tasks['navigation'], team, readings, ['robot_a'],
                                 max_messages=1000)
    assert results['robot_a'].coalitions == ()          # nobody can localise: nothing executable
    assert search.stats.duplicate_requests_suppressed['robot_a'] > 0
    assert search.stats.messages < 100
    # Each robot sent each label once (F_G(X), F_R(me, X), F_R(X, me), F_R(X, Y), ...).
    assert search.stats.requests_sent['robot_a'] == len(search.agents['robot_a'].reasoner.ledger.sent)
    # Without the constraint robot_a asks robot_b for F_G(X), which asks robot_a, which asks again...
    with pytest.raises(SearchError, match='request loop, which the Distinct Requests constraint prevents'):
        run_search(library, costs, tasks['navigation'], team, readings, ['robot_a'],
                   distinct_requests=False, max_messages=1000)


def column(fig7_types, n):
    """Fig. 9: robots in a column, only the front one localises, each sees the one in front."""
    names = [f'robot_{i}' for i in range(1, n + 1)]
    team = {name: fig7_types['type2' if i == 0 else 'type1'] for i, name in enumerate(names)}
    readings = {name: {'laser': [f'F_A({name})']} for name in names}
    readings['robot_1']['localization'] = ['F_G(robot_1)']
    for front, back in zip(names, names[1:]):
        readings[back]['fiducial'] = [f'F_R({front}, {back})']
    return names, team, readings


def test_column_coalition_includes_every_robot(library, costs, tasks, fig7_types):
    names, team, readings = column(fig7_types, 4)
    _, results = run_search(library, costs, tasks['navigation'], team, readings, [names[-1]])
    best = results['robot_4'].best
    assert best.members == ('robot_4', 'robot_1', 'robot_2', 'robot_3')
    # robot_4: Table III row 2 + laser = 9; robot_3 localises from robot_1's position and robot_2's
    # report of robot_1 relative to it (row 6 as a reply: 8.5 - the reply CS 2 = 6.5); robot_1 and
    # robot_2 each sense what they send (1 each); three helpers keep their relative position (3 x 6).
    assert best.cost == 9.0 + 6.5 + 1.0 + 1.0 + 18.0
    text = best.describe()
    assert 'robot_3 provides F_G(robot_3)' in text and 'robot_2 provides F_R(robot_1, robot_2)' in text


def test_search_is_deterministic(library, costs, tasks, fig7_types):
    names, team, readings = column(fig7_types, 3)
    first = run_search(library, costs, tasks['navigation'], team, readings, [names[-1]])
    second = run_search(library, costs, tasks['navigation'], team, readings, [names[-1]])
    assert [c.describe() for c in first[1]['robot_3'].coalitions] == [
        c.describe() for c in second[1]['robot_3'].coalitions]
    assert first[0].stats.to_dict() == second[0].stats.to_dict()


def test_monitoring_through_a_sensor_connected_network(library, costs, tasks, config_dir):
    types = load_capability_file(config_dir / 'capabilities' / 'monitoring_team.yaml', library).types
    # robot_gps localises and sees robot_eye; robot_eye sees the target; robot_m reports it.
    team = {'robot_m': types['watcher'], 'robot_eye': types['watcher'], 'robot_gps': types['localizer']}
    readings = {'robot_gps': {'localization': ['F_G(robot_gps)'], 'fiducial': ['F_R(robot_eye, robot_gps)']},
                'robot_eye': {'fiducial': ['F_R(target, robot_eye)']}}
    _, results = run_search(library, costs, tasks['monitoring'], team, readings, ['robot_m'])
    best = results['robot_m'].best
    assert best is not None and set(best.members) == {'robot_m', 'robot_eye', 'robot_gps'}
    assert 'F_G(target)' in best.describe()
    # Without the link between the two helpers nobody can tell where the target is.
    del readings['robot_gps']['fiducial']
    _, results = run_search(library, costs, tasks['monitoring'], team, readings, ['robot_m'])
    assert results['robot_m'].coalitions == ()


def test_box_pushing_partner_must_be_one_robot(library, costs, tasks, config_dir):
    types = load_capability_file(config_dir / 'capabilities' / 'box_pushing_team.yaml', library).types
    team = {'robot_a': types['torque_pusher'], 'robot_b': types['torque_pusher'], 'robot_c': types['bumper_only']}
    readings = {robot: {'bumper': [f'F_B({robot})'], 'force': [f'F_F({robot})'], 'sonar': [f'F_R(box, {robot})']}
                for robot in team}
    _, results = run_search(library, costs, tasks['box_pushing_torque'], team, readings, ['robot_a'])
    coalitions = results['robot_a'].per_members()
    # robot_c offers its bumper but cannot offer its torque: Y must be the same robot in F_B(Y)
    # and F_T(Y, box) (referent instantiation constraint), so robot_b is the only partner.
    assert {c.members for c in coalitions} == {('robot_a', 'robot_b')}
    best = coalitions[0]
    assert dict(best.root.binding)[next(v for v, _ in best.root.binding if v.name == 'Y')].name == 'robot_b'


def test_step_by_step_reasoning_matches_table5(library, costs, tasks, fig7_types, parse):
    """What a schema_agent node does, by hand: robot_red sees helper_1 and asks for F_G(X)."""
    navigation = tasks['navigation']
    red = RobotReasoner('robot_red', fig7_types['type1'], library, costs, navigation)
    helper = RobotReasoner('helper_1', fig7_types['type2'], library, costs, navigation)
    solution = red.task_solutions()[0]                                  # Table III row 2 (+ laser)
    assert red.sensing_needs(solution)[0] == ('fiducial', parse('F_R(X, robot_red)', ['robot_red']))
    (request,) = red.requests_to_send(solution)
    assert str(request.label) == 'F_G(X)' and red.requests_to_send(solution) == []   # Distinct Requests
    (variant,) = helper.variants(request)
    reply = helper.reply_solutions(variant)[0]
    (lcs,) = helper.local_coalition_solutions(reply, {'localization': [parse('F_G(helper_1)', ['helper_1'])]}, {},
                                              reply=True)
    offer = helper.offer(request, lcs)
    assert (str(offer.instance), offer.cost) == ('F_G(helper_1)', 7.0)    # localisation 1 + helper MS 6
    sensed = {'fiducial': [parse('F_R(helper_1, robot_red)', ['helper_1', 'robot_red'])],
              'laser': [parse('F_A(robot_red)', ['robot_red'])]}
    (mine,) = red.local_coalition_solutions(solution, sensed, {request.label: [offer]})
    assert red.coalition(mine).cost == 16.0
    # The referent instantiation constraint: an offer about a robot it does not see is useless.
    other = helper.offer(request, lcs)
    unseen = {'fiducial': [parse('F_R(helper_2, robot_red)', ['helper_2', 'robot_red'])],
              'laser': sensed['laser']}
    assert list(red.local_coalition_solutions(solution, unseen, {request.label: [other]})) == []
    with pytest.raises(RequestError, match='does not answer'):
        helper.offer(InformationRequest('robot_red', parse('F_G(goal)')), lcs)
    with pytest.raises(RequestError, match="unknown information type 'F_Q'"):
        helper.variants(InformationRequest('robot_red', parse('F_G(X)').__class__('F_Q', ())))


def test_search_input_errors(library, costs, tasks, fig7_types):
    team = {'robot_1': fig7_types['type1']}
    search = CoalitionSearch(library, costs, tasks['navigation'], team, StaticSensing({}))
    with pytest.raises(CoalitionError, match="initiator 'robot_9' is not in the team"):
        search.run(['robot_9'])
    pushing = CoalitionSearch(library, costs, tasks['box_pushing_torque'], team, StaticSensing({}))
    with pytest.raises(CoalitionError, match="robot robot_1 cannot activate motor schema 'push_box_cooperatively'"):
        pushing.run(['robot_1'])
    with pytest.raises(CoalitionError, match=r"readings.robot_1.fiducial\[0\]: a reading names entities only"):
        StaticSensing.from_text({'robot_1': {'fiducial': ['F_R(X, robot_1)']}}, library, ['robot_1'])
    with pytest.raises(CoalitionError, match=r"readings.robot_1.fiducial\[0\]: unknown entity 'robot_7'"):
        StaticSensing.from_text({'robot_1': {'fiducial': ['F_R(robot_7, robot_1)']}}, library, ['robot_1'])


def test_plan_reply_applies_distinct_requests_along_the_chain(library, costs, tasks, fig7_types, parse):
    """robot_a asked helper_x for F_G(X) while helper_x was serving robot_a's own F_G(X) request:
    the loop of Lemma 4.3 -- helper_x must not request F_G(X) again."""
    navigation = tasks['navigation']
    team = ['robot_a', 'helper_x']
    helper = RobotReasoner('helper_x', fig7_types['type1'], library, costs, navigation)
    earlier = (('helper_x', parse('F_G(X)')),)
    request = InformationRequest('robot_a', parse('F_G(X)'), earlier)
    (plan,) = helper.plan_reply(request)
    assert str(plan.variant) == 'F_G(local)' and plan.request is request
    sent = labels(r.label for r in plan.requests)
    assert 'F_G(X)' not in sent                          # already requested up the chain
    assert sent == ['F_R(helper_x, X)', 'F_R(X, helper_x)', 'F_R(X, Y)']
    assert all(r.chain == request.extended_chain for r in plan.requests)
    assert ('fiducial', parse('F_R(X, helper_x)', team)) in plan.sensors
    # The ledger: a second request needing the same labels sends nothing new.
    (again,) = helper.plan_reply(InformationRequest('robot_a', parse('F_G(X)')))
    assert labels(r.label for r in again.requests) == ['F_G(X)']
    assert helper.plan_reply(InformationRequest('robot_a', parse('F_R(robot_a, goal)', team))) == []
    # The robot's own task, for comparison: Table III rows 2-7 (no GPS), laser, priors.
    task_plan = helper.plan_task()
    assert [s.cost for s in task_plan.solutions] == [9.0, 9.5, 10.0, 11.5, 12.0, 12.5]
    assert task_plan.requests == ()                       # everything was requested already
