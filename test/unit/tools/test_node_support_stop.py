"""node_support.run: a RuntimeError raised while a stop shuts the context down (rclpy's signal thread does
it a moment after the error: a KeyboardInterrupt inside take_message's conversion surfaces as pybind11's
RuntimeError) ends the node with exit code 0; the same error with no stop under way is a crash (exit 1)."""

import os
import subprocess
import sys
import textwrap

NODE = textwrap.dedent('''
    import sys, threading
    import rclpy
    from rclpy.node import Node
    from collab_tools.node_support import run

    STOPPING = sys.argv[1] == 'stopping'

    class Failing(Node):
        def __init__(self):
            super().__init__('failing')
            self.create_timer(0.05, self.fail)

        def fail(self):
            if STOPPING:   # the context is shut down 0.3 s after the error, as rclpy's signal thread would
                threading.Timer(0.3, rclpy.try_shutdown).start()
            raise RuntimeError('Unable to convert call argument 0 to Python object')

    sys.exit(run(Failing, 'failing'))
    ''')


def run_node(mode: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-c', NODE, mode], capture_output=True, text=True, timeout=60,
                          env={**os.environ, 'ROS_DOMAIN_ID': '231', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'})


def test_an_error_during_a_stop_is_part_of_the_stop():
    result = run_node('stopping')
    assert result.returncode == 0 and 'Traceback' not in result.stderr, result.stderr


def test_the_same_error_without_a_stop_is_a_crash():
    result = run_node('no stop')
    assert result.returncode == 1 and 'RuntimeError: Unable to convert' in result.stderr
