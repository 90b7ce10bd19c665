"""The role engine's simulation experiments open their reports with a line that says what happened: the key
figures, not only 'every check holds'; a failed acceptance says why."""


def test_the_formation_outcome_gives_the_key_figures():
    from role_engine.experiments.formation import formation_acceptance, formation_outcome
    results = {'completed': True, 'final_round': 1, 'min_distance': 0.675, 'min_clearance': 0.366, 'collisions': 0,
               'min_obstacle_clearance': 0.1512,
               'robots': {'pioneer_1': {'arrived': True}, 'burger_1': {'arrived': True}}}
    assert formation_outcome(results, formation_acceptance(results)) == (
        'formed: 2/2 robots arrived (round 1); min distance 0.675 m (clearance 0.366 m), 0 collisions, '
        'min obstacle clearance 151.2 mm')
    crashed = dict(results, completed=False, collisions=1, min_clearance=-0.01,
                   robots={'pioneer_1': {'arrived': True}, 'burger_1': {'arrived': False}})
    line = formation_outcome(crashed, formation_acceptance(crashed))
    assert line.startswith('NOT formed: 1/2 robots arrived') and line.endswith(
        'failed: completed, no_collision, min_distance_at_least_sum_of_radii')


def test_the_collab_outcome_gives_each_scenarios_figures():
    from role_engine.experiments.collab import collab_acceptance, collab_outcome

    def run(completed, distance, collisions):
        return {'completed': completed, 'min_distance': distance, 'min_clearance': distance - 0.21,
                'collisions': collisions, 'obstacle_contacts': 0}
    results = {'scenarios': {'hallway_swap': {'task_based': run(True, 0.01, 1), 'role_based': run(True, 0.327, 0)},
                             'four_robots': {'role_based': run(False, 0.1, 2)}}}
    acceptance = collab_acceptance(results)
    assert collab_outcome(results, acceptance) == (
        'hallway_swap: role-based completed, min distance 0.327 m, 0 collisions (task-based 1); '
        'four_robots: role-based NOT completed, min distance 0.100 m, 2 collisions; '
        'four_robots: role-based completed is false; four_robots: role-based no collision is false; '
        'four_robots: role-based min distance at least sum of radii is false')
    del results['scenarios']['four_robots']
    assert collab_outcome(results, collab_acceptance(results)).endswith('0 collisions (task-based 1)')
