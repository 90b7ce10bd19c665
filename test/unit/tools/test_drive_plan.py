import pytest

from collab_tools.core.drive_plan import PlanError, load_plan, parse_plan


def test_segments_play_in_order_then_stop():
    plan = parse_plan({'robots': {'a': [{'linear': 0.5, 'angular': 0.0, 'duration': 2.0},
                                        {'linear': 0.0, 'angular': 1.0, 'duration': 1.0}],
                                  'b': [{'linear': 0.1, 'angular': 0.0, 'duration': 4.0}]}})
    assert plan.duration == 4.0
    assert plan.command_at('a', 0.0) == (0.5, 0.0)
    assert plan.command_at('a', 1.99) == (0.5, 0.0)
    assert plan.command_at('a', 2.0) == (0.0, 1.0)
    assert plan.command_at('a', 3.0) == (0.0, 0.0)
    assert plan.command_at('b', 3.5) == (0.1, 0.0)


@pytest.mark.parametrize('data, message', [
    ({'robots': {}}, 'robots:'),
    ({'robots': {'a': [{'linear': 0.1, 'angular': 0.0}]}}, r'robots.a\[0\].duration: missing'),
    ({'robots': {'a': [{'linear': float('nan'), 'angular': 0.0, 'duration': 1}]}},
     r'robots.a\[0\].linear: must be finite'),
    ({'robots': {'a': [{'linear': 0.1, 'angular': 0.0, 'duration': 0}]}},
     r'robots.a\[0\].duration: must be > 0'),
    ({'robots': {'a': [{'linear': 0.1, 'angular': 0.0, 'duration': 1, 'speed': 2}]}},
     r'robots.a\[0\].speed: unknown field'),
    ({'robots': {'1a': [{'linear': 0.1, 'angular': 0.0, 'duration': 1}]}}, 'robots.1a'),
])
def test_invalid_plans_name_the_field(data, message):
    with pytest.raises(PlanError, match=message):
        parse_plan(data)


def test_demo_plan_in_config_is_valid(config_dir):
    plan = load_plan(config_dir / 'plans' / 'demo_plan.yaml')
    assert set(plan.robots) == {'robot_1', 'robot_2', 'robot_3'}
