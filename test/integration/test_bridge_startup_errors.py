"""A bad scenario or parameter stops the bridge at start with a message naming the field."""

from dataclasses import replace

from bridge_helpers import bridge_spec

GOOD_ROBOT = '{name: robot_1, type: pioneer_3dx, pose: [0, 0, 0], color: [1, 0, 0]}'
CAMERA = 'camera: {rate: 10.0, width: 64, height: 64, altitude: 4.0, fov_deg: 45.0}\n'


def start_and_wait_for_exit(session, scenario_text, tmp_path, **params):
    path = tmp_path / 'scenario.yaml'
    path.write_text(scenario_text)
    spec = bridge_spec(path)
    spec.parameters[0].update(params)  # may replace the scenario too
    process = session.start(spec)
    code = session.wait_for_exit('pybullet_bridge', timeout=60.0)
    return code, process.log_path.read_text()


def test_bad_scenario_names_the_field(session, tmp_path):
    # The other scenario fields are checked by the parser's unit tests (test/unit/bridge/test_bridge_scenario.py).
    scenario_text = ('name: t\n' + CAMERA + 'mobile_robots:\n  - {name: robot_1, type: pioneer_3dx, '
                     'pose: [0, 0, 0], color: [1, 0, 0], max_linear_velocity: -1}\n')
    code, log = start_and_wait_for_exit(session, scenario_text, tmp_path)
    assert code == 2
    assert 'mobile_robots[0].max_linear_velocity:' in log


GOOD_SCENARIO = 'name: t\n' + CAMERA + 'mobile_robots:\n  - ' + GOOD_ROBOT + '\n'


def test_bad_parameter_names_the_parameter(session, tmp_path):
    # Every parameter's bad values are unit tests of the schema (test/unit/bridge/test_bridge_settings.py);
    # this proves the node applies it: exit code 2 and the message, no traceback.
    code, log = start_and_wait_for_exit(session, GOOD_SCENARIO, tmp_path, real_time_factor=-1.0)
    assert code == 2
    assert 'parameter real_time_factor' in log and '[0, 1000]' in log
    assert 'Traceback' not in log


def test_use_sim_time_is_refused_at_once(session, tmp_path):
    """The bridge is the clock source: with use_sim_time it would wait for its own /clock for ever."""
    path = tmp_path / 'scenario.yaml'
    path.write_text(GOOD_SCENARIO)
    spec = replace(bridge_spec(path), use_sim_time=True)
    process = session.start(spec)
    code = session.wait_for_exit('pybullet_bridge', timeout=60.0)
    log = process.log_path.read_text()
    assert code == 2
    assert 'use_sim_time' in log and 'clock source' in log
