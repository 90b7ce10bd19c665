"""The reasoning caches (core.reasoning_caches) the node's agent and the in-process team search
share: the offer view is one object until an offer arrives, the answer memo equals
answers_request, both users hold the same implementation, and the search's results are those
of a search without the memos."""
from __future__ import annotations

from coalition_agents.core import reasoning_caches
from coalition_agents.core.agent import SchemaAgent
from coalition_agents.core.coalition_search import CoalitionSearch, _Agent
from coalition_agents.core.reasoning_caches import AnswerMemo, OfferBook
from coalition_agents.core.requests import answers_request

TEAM = ('robot_1', 'robot_2', 'robot_3')


def test_the_offer_view_is_one_object_until_an_offer_arrives(library):
    book = OfferBook(lambda entry: entry[0])
    label = library.parse('F_G(X)', TEAM)
    assert book.view() == {} and book.view() is book.view()
    book.put(label, ('robot_2', 'a'), ('offer a', ('robot_2',)))
    first = book.view()
    assert first == {label: ['offer a']} and book.view() is first
    book.put(label, ('robot_3', 'b'), ('offer b', ('robot_3',)))
    second = book.view()
    assert second is not first and second == {label: ['offer a', 'offer b']}
    assert first == {label: ['offer a']}  # a view handed out never changes
    book.put(label, ('robot_2', 'a'), ('cheaper a', ('robot_2',)))  # a replacement keeps its place
    assert book.view() == {label: ['cheaper a', 'offer b']} and book.get(label, ('robot_3', 'b'))[0] == 'offer b'
    assert book.get(label, ('robot_9', 'c')) is None and list(book.labels()) == [label]
    book.clear()
    assert book.view() == {}


def test_a_labels_offer_list_stays_one_object_until_an_offer_of_that_label_arrives(library):
    book = OfferBook(lambda entry: entry[0])
    fg, fr = library.parse('F_G(X)', TEAM), library.parse('F_R(X, robot_1)', TEAM)
    book.put(fg, ('robot_2', 'a'), ('offer a', ('robot_2',)))
    book.put(fr, ('robot_3', 'b'), ('offer b', ('robot_3',)))
    first = book.view()
    assert list(first) == [fg, fr]
    book.put(fr, ('robot_2', 'c'), ('offer c', ('robot_2',)))
    second = book.view()
    assert second is not first and second[fg] is first[fg]      # F_G's list untouched
    assert second[fr] is not first[fr] and second[fr] == ['offer b', 'offer c'] and first[fr] == ['offer b']
    assert list(second) == [fg, fr]                              # labels keep their first-offer order
    book.clear()
    book.put(fr, ('robot_3', 'b'), ('offer b', ('robot_3',)))
    assert book.view() == {fr: ['offer b']} and book.view()[fr] is not second[fr]


def test_the_agents_offers_and_coalitions_equal_those_of_candidates_built_at_every_call(
        library, costs, tasks, monkeypatch):
    """The reasoner keeps a leaf's candidates while the view holds the same offer list / readings
    (an offer rebuilds only its label's): the scripted 4-robot column run (readings appearing,
    lapsing and returning; offers replaced) sends the same offers and reaches the same answers
    and coalitions at every step as with candidates built afresh at every instantiation."""
    from test_coalition_agent_incremental import scripted_run
    from coalition_agents.core.coalition import RobotReasoner
    kept, kept_snapshots = scripted_run(library, costs, tasks, incremental=True)
    monkeypatch.setattr(RobotReasoner, '_view_cache', lambda self, sensed, offers: {})
    fresh, fresh_snapshots = scripted_run(library, costs, tasks, incremental=True)
    assert kept.offers == fresh.offers and kept_snapshots == fresh_snapshots
    assert kept_snapshots[-1]['robot_4']['coalitions']


def test_the_answer_memo_answers_as_answers_request(library):
    memo = AnswerMemo()
    pairs = [('F_G(robot_2)', 'F_G(X)'), ('F_G(robot_2)', 'F_G(robot_3)'), ('F_R(robot_1, robot_2)', 'F_R(X, robot_2)'),
             ('F_R(robot_1, robot_2)', 'F_R(robot_2, X)'), ('F_R(robot_1, robot_2)', 'F_G(X)')]
    for answer, label in pairs * 2:
        a, b = library.parse(answer, TEAM), library.parse(label, TEAM)
        assert memo(a, b) == answers_request(a, b)
    assert len(memo) == len(pairs)


def test_the_agent_and_the_search_share_one_implementation(library, costs, tasks, fig7_types):
    class Silent:
        def set_sensor(self, *_):
            pass

        send_request = send_offer = set_sensor
    robots = {'robot_1': fig7_types['type1'], 'robot_2': fig7_types['type2']}
    task = tasks['navigation']
    agent = SchemaAgent(next(iter(robots)), robots, library, costs, task, Silent())
    search = CoalitionSearch(library, costs, task, robots, sensing=None)
    assert isinstance(agent.offers, OfferBook) and isinstance(agent._answers, AnswerMemo)
    assert isinstance(search._answers, AnswerMemo)
    assert all(isinstance(a, _Agent) and isinstance(a.offers, OfferBook) for a in search.agents.values())
    assert reasoning_caches.__all__ == ['AnswerMemo', 'OfferBook']


def test_the_search_finds_what_it_found_without_the_memos(library, costs, tasks, fig7_types, monkeypatch):
    """The Fig. 9 column of 6 (bench layout): the same coalitions, costs and message counts with a
    fresh offer view and answer test at every call (the search before the memos)."""
    from coalition_agents.core.geometric_sensing import GeometricSensing
    from coalition_agents.experiments.benchmark import column_layout

    def run():
        layout = column_layout(fig7_types, 6)
        search = CoalitionSearch(library, costs, tasks['navigation'], layout.team,
                                 GeometricSensing(layout.team, layout.poses, layout.fields_of_view),
                                 potential_solution_limit=4)
        results = search.run(layout.initiators)
        return ({robot: [(c.cost, tuple(c.members)) for c in result.coalitions] for robot, result in results.items()},
                search.stats.messages)
    memoised = run()
    monkeypatch.setattr(OfferBook, 'view', lambda self: {label: [self._offer_of(e) for e in entries.values()]
                                                         for label, entries in self._entries.items()})
    monkeypatch.setattr(AnswerMemo, '__call__', lambda self, answer, label: answers_request(answer, label))
    assert run() == memoised
    assert memoised[0]['robot_6'] and len(memoised[0]['robot_6'][0][1]) == 6


def test_a_reasoners_variants_are_remembered_per_label_and_bad_labels_still_refused(library, costs, tasks, fig7_types):
    import pytest
    from coalition_agents.core.coalition import RobotReasoner
    from coalition_agents.core.errors import RequestError
    from coalition_agents.core.information import InformationInstance
    from coalition_agents.core.requests import InformationRequest, request_variants
    reasoner = RobotReasoner('robot_2', fig7_types['type1'], library, costs, tasks['navigation'])
    for text in ('F_G(X)', 'F_R(X, Y)', 'F_R(robot_1, X)', 'F_R(robot_2, robot_1)', 'F_R(robot_1, robot_3)') * 2:
        label = library.parse(text, TEAM)
        request = InformationRequest('robot_1', label)
        assert reasoner.variants(request) == request_variants(label, 'robot_2')
    assert reasoner.variants(request) is reasoner.variants(request)
    bad = InformationRequest('robot_1', InformationInstance('F_NONE', ()))
    for _ in range(2):
        with pytest.raises(RequestError, match='request.label'):
            reasoner.variants(bad)
