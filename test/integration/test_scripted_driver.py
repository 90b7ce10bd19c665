"""scripted_driver's parameters: command_rate is applied while the plan plays (the command rate
in simulated time follows it); plan_file is read-only; a bad start exits 2 naming the parameter."""
import time

from geometry_msgs.msg import Twist
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.parameter import Parameter

from rosgraph_msgs.msg import Clock

from bridge_helpers import bridge_spec, collect, settle
from collab_tools.orchestration.node_process import NodeSpec

NODE = '/scripted_driver'


def set_parameter(session, name, value):
    response = session.call_service(f'{NODE}/set_parameters', 'rcl_interfaces/srv/SetParameters',
                                    SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()]))
    return response.results[0]


def get_value(session, name):
    response = session.call_service(f'{NODE}/get_parameters', 'rcl_interfaces/srv/GetParameters',
                                    GetParameters.Request(names=[name]))
    return Parameter.from_parameter_msg(ParameterMsg(name=name, value=response.values[0])).value


def commands_per_sim_second(commands, clock, wall_seconds=3.0):
    """Commands per simulated second over a few wall seconds of a running bridge."""
    before, start = len(commands), clock[-1]
    time.sleep(wall_seconds)
    elapsed = (clock[-1].clock.sec + clock[-1].clock.nanosec * 1e-9) - (start.clock.sec + start.clock.nanosec * 1e-9)
    assert elapsed > 0.5, f'simulated time barely moved ({elapsed:.2f} s)'
    return (len(commands) - before) / elapsed


def test_command_rate_is_applied_while_playing(session, ros_node, config_dir, tmp_path):
    plan = tmp_path / 'plan.yaml'
    plan.write_text('robots:\n  robot_1:\n    - {linear: 0.1, angular: 0.0, duration: 60.0}\n')
    session.start(bridge_spec(config_dir / 'scenarios' / 'test_single_robot.yaml', real_time_factor=1.0,
                              start_paused=False))
    session.start(NodeSpec('collab_tools', 'scripted_driver', parameters=[{'plan_file': str(plan),
                                                                           'command_rate': 20.0}]))
    commands = collect(ros_node, Twist, '/robot_1/cmd_vel', reliable=True)
    clock = collect(ros_node, Clock, '/clock', reliable=True)
    settle(clock)
    first = commands_per_sim_second(commands, clock)
    assert set_parameter(session, 'command_rate', 5.0).successful
    time.sleep(0.5)
    second = commands_per_sim_second(commands, clock)
    assert 12 <= first <= 24, first
    assert 2 <= second <= 7, second

    refused = set_parameter(session, 'plan_file', '/tmp/other.yaml')
    assert not refused.successful and 'read-only' in refused.reason
    refused = set_parameter(session, 'command_rate', 0.0)
    assert not refused.successful and 'command_rate' in refused.reason
    assert get_value(session, 'command_rate') == 5.0


def test_bad_start_parameter_exits_2(session, tmp_path):
    process = session.start(NodeSpec('collab_tools', 'scripted_driver', use_sim_time=False,
                                     parameters=[{'plan_file': str(tmp_path / 'p.yaml'), 'command_rate': -1.0}]))
    assert session.wait_for_exit(process.name, timeout=60.0) == 2
    log = process.log_path.read_text()
    assert 'parameter command_rate: must be in (0, 1000]' in log and 'Traceback' not in log
