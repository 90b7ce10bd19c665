"""The report's outcome line of a role-engine bag: formed (every robot of the last round arrived) or not."""
from test_roles_formation_experiment import START, typestore, write_bag  # noqa: F401 - the fixture

from collab_tools.core.bag_analysis import summarize_bag
from role_engine.experiments.formation_bag import formation_outcome


def test_a_formed_formation_says_who_arrived_and_when(tmp_path, typestore):  # noqa: F811
    bag = write_bag(tmp_path / 'bag', typestore, pass_gap=0.5)
    outcome = formation_outcome(bag, summarize_bag(bag))
    assert (outcome.subject, outcome.status, outcome.passed) == ('roles', 'formed', True)
    assert outcome.figures['time_to_form_s'] == 13.0 - START      # the last arrival after the roles' start
    assert outcome.summary.startswith('2/2 robots arrived at their roles in round 1 after 11.0 s')


def test_a_robot_that_never_arrives_leaves_it_not_formed(tmp_path, typestore):  # noqa: F811
    bag = write_bag(tmp_path / 'bag', typestore, pass_gap=0.5, b_arrives=False)
    outcome = formation_outcome(bag, summarize_bag(bag))
    assert (outcome.status, outcome.passed, outcome.checks) == ('not formed', False, {'formed': False})
    assert outcome.summary.startswith('1/2 robots arrived')
