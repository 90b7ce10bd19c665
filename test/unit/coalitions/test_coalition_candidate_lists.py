"""A CS leaf's candidate list grows with the offers instead of being rebuilt at every offer
(coalition._Candidates.extended): the same candidates, in the same order, with the same index,
as building them from the whole offer list."""
from __future__ import annotations

import random

import pytest

from coalition_agents.core.agent_spaces import ReceivedOffer
from coalition_agents.core.coalition import _Candidates
from coalition_agents.core.information import Entity, InformationInstance, Variable

X, Y = Variable('X'), Variable('Y')
LABEL = InformationInstance('F_R', (X, Y))
ROBOTS = [Entity(f'robot_{k}', robot=True) for k in range(1, 6)]


def random_offer(rng: random.Random) -> ReceivedOffer:
    first, second = rng.sample(ROBOTS, 2)
    return ReceivedOffer(rng.choice(['robot_1', 'robot_2', 'robot_3']), LABEL, InformationInstance('F_R', (first, second)),
                         None, float(rng.randint(1, 6)), ())


def offer_lists(rng: random.Random, steps: int):
    """Successive lists as an offer book hands them out: mostly appends, sometimes one offer
    replaced in place (a cheaper offer of the same provider and instance)."""
    current: list = []
    for _ in range(steps):
        current = list(current)
        if current and rng.random() < 0.2:
            current[rng.randrange(len(current))] = random_offer(rng)
        else:
            current.extend(random_offer(rng) for _ in range(rng.randint(1, 3)))
        yield current


def index_view(candidates: _Candidates) -> list:
    """What consistent() answers for every binding of X and of Y (builds the index)."""
    return [[(str(i), id(o)) for i, o in candidates.consistent({variable: entity})]
            for variable in (X, Y) for entity in ROBOTS] + [[(str(i), id(o)) for i, o in candidates.consistent({})]]


@pytest.mark.parametrize('cheapest', [False, True])
@pytest.mark.parametrize('seed', range(6))
def test_extended_candidates_equal_the_ones_built_from_the_whole_list(cheapest, seed):
    rng = random.Random(seed)
    previous = grown = None
    extended_at_least_once = replaced_at_least_once = False
    for offers in offer_lists(rng, 40):
        built = _Candidates.of_offers(LABEL, offers, cheapest)
        if grown is not None:
            following = grown.extended(previous, offers, cheapest)
            if following is None:
                replaced_at_least_once = True
                # An offer replaced in place is not an append: the caller builds again.
                assert any(a is not b for a, b in zip(offers, previous))
                following = _Candidates.of_offers(LABEL, offers, cheapest)
            else:
                extended_at_least_once = True
            grown = following
        else:
            grown = built
        if seed % 2:  # with and without an index built before the next offers arrive
            index_view(grown)
        assert [(str(i), id(o)) for i, o in grown.entries] == [(str(i), id(o)) for i, o in built.entries]
        assert index_view(grown) == index_view(built)
        assert grown.has_offers == built.has_offers
        previous = offers
    assert extended_at_least_once and replaced_at_least_once


def test_cheapest_candidates_keep_one_offer_per_instance_at_its_first_place():
    a, b = ROBOTS[0], ROBOTS[1]
    instance = InformationInstance('F_R', (a, b))
    other = InformationInstance('F_R', (b, a))
    dear = ReceivedOffer('robot_3', LABEL, instance, None, 5.0, ())
    second = ReceivedOffer('robot_3', LABEL, other, None, 2.0, ())
    cheap = ReceivedOffer('robot_2', LABEL, instance, None, 4.0, ())
    tie = ReceivedOffer('robot_1', LABEL, instance, None, 4.0, ())  # same cost: the smaller provider name wins
    candidates = _Candidates.of_offers(LABEL, [dear, second], True)
    candidates.consistent({})  # the index exists before the update
    grown = candidates.extended([dear, second], [dear, second, cheap, tie], True)
    assert [offer for _, offer in grown.entries] == [tie, second]
    assert [offer for _, offer in grown.consistent({X: a})] == [tie]
    # The earlier candidates are unchanged (an evaluation may still hold them).
    assert [offer for _, offer in candidates.entries] == [dear, second]
    assert [offer for _, offer in candidates.consistent({X: a})] == [dear]
