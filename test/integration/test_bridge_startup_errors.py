"""A bad scenario or parameter stops the bridge at start with a message naming the field."""

import pytest

from bridge_helpers import bridge_spec

GOOD_ROBOT = '{name: robot_1, type: pioneer_3dx, pose: [0, 0, 0], color: [1, 0, 0]}'
CAMERA = 'camera: {rate: 10.0, width: 64, height: 64, altitude: 4.0, fov_deg: 45.0}\n'


def start_and_wait_for_exit(session, scenario_text, tmp_path, **params):
    path = tmp_path / 'scenario.yaml'
    path.write_text(scenario_text)
    process = session.start(bridge_spec(path, **params))
    code = session.wait_for_exit('pybullet_bridge', timeout=60.0)
    return code, process.log_path.read_text()


@pytest.mark.parametrize('scenario_text, field', [
    (CAMERA + 'mobile_robots:\n  - ' + GOOD_ROBOT + '\n', 'name'),
    ('name: t\n' + CAMERA + 'mobile_robots:\n  - {name: robot_1, type: hovercraft, pose: [0, 0, 0], '
     'color: [1, 0, 0]}\n', 'mobile_robots[0].type'),
    ('name: t\n' + CAMERA + 'mobile_robots:\n  - {name: robot_1, type: pioneer_3dx, pose: [0, 0, 0], '
     'color: [1, 0, 0], max_linear_velocity: -1}\n', 'mobile_robots[0].max_linear_velocity'),
])
def test_bad_scenario_names_the_field(session, tmp_path, scenario_text, field):
    code, log = start_and_wait_for_exit(session, scenario_text, tmp_path)
    assert code == 2
    assert field + ':' in log


def test_bad_parameter_names_the_parameter(session, tmp_path):
    code, log = start_and_wait_for_exit(
        session, 'name: t\n' + CAMERA + 'mobile_robots:\n  - ' + GOOD_ROBOT + '\n', tmp_path,
        real_time_factor=-1.0)
    assert code == 2
    assert 'parameter real_time_factor' in log
