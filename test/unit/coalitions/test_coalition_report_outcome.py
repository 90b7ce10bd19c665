"""The report's outcome line of a coalition bag: each leader's coalition, its cost and when it formed."""
import pytest
from test_coalition_sim_experiments import coalition_bag  # noqa: F401 - the fixture

from coalition_agents.experiments.coalition_bag import coalition_outcome

MEMBERS = ('robot_3', 'robot_1', 'robot_2')


def test_formed_names_the_helpers_cost_and_time_to_form(coalition_bag, tmp_path):  # noqa: F811
    statuses = [(10.0, 'robot_1', 'idle', 'none', '', '', (), 0),
                (10.1, 'robot_3', 'searching', 'navigation', '', '', (), 0),
                (12.25, 'robot_1', 'committed', 'none', 'c1', 'robot_3', MEMBERS, 25.5),
                (12.3, 'robot_3', 'committed', 'navigation', 'c1', 'robot_3', MEMBERS, 25.5)]
    outcome = coalition_outcome(coalition_bag(tmp_path / 'bag', statuses, []))
    assert (outcome.subject, outcome.status, outcome.passed) == ('coalitions', 'formed', True)
    assert outcome.summary == ('robot_3 with robot_1, robot_2 (cost 25.5, formed 2.20 s after its search started; '
                               'now committed)')
    assert outcome.figures['leaders'][0]['formed_s'] == pytest.approx(2.2)


def test_a_leader_without_a_coalition_is_not_formed(coalition_bag, tmp_path):  # noqa: F811
    statuses = [(1.0, 'a', 'searching', 'navigation', '', '', (), 0), (9.0, 'a', 'failed', 'navigation', '', '', (), 0),
                (1.0, 'helper', 'idle', 'none', '', '', (), 0)]
    outcome = coalition_outcome(coalition_bag(tmp_path / 'bag', statuses, []))
    assert (outcome.status, outcome.passed, outcome.summary) == ('not formed', False, 'a: no coalition (failed)')


def test_a_bag_without_leaders_has_no_coalition_outcome(coalition_bag, tmp_path):  # noqa: F811
    statuses = [(1.0, 'helper', 'idle', 'none', '', '', (), 0)]
    assert coalition_outcome(coalition_bag(tmp_path / 'bag', statuses, [])) is None
