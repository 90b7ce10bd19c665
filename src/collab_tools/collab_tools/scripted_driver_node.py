"""scripted_driver node: plays a timed velocity plan on <robot>/cmd_vel (relative to its namespace).

Stands in for a planner before one exists (and drives the demo and tests). Time is
the node clock, so with use_sim_time the plan follows the simulation. When every
segment has played it publishes zero commands and `~/done` (latched) = true.
``command_rate`` can change while it plays (the command timer is re-created).
"""

import sys

from geometry_msgs.msg import Twist
from rclpy.node import Node
from std_msgs.msg import Bool

from .core.drive_plan import PlanError
from .core.tool_settings import DRIVER_SETTINGS, read_plan_parameter
from .node_support import run
from .parameters import NodeParameters
from .qos import COMMAND_OUT, LATCHED


class ScriptedDriver(Node):

    def __init__(self):
        super().__init__('scripted_driver')
        params = NodeParameters(self)
        values = params.declare_schema(DRIVER_SETTINGS, on_change={'command_rate': self._set_rate})
        plan_file, rate = values['plan_file'], values['command_rate']
        self.plan = read_plan_parameter(plan_file)
        self.cmd_pubs = {robot: self.create_publisher(Twist, f'{robot}/cmd_vel', COMMAND_OUT)
                         for robot in self.plan.robots}
        self.done_pub = self.create_publisher(Bool, '~/done', LATCHED)
        self.done_pub.publish(Bool(data=False))
        self.start_time = None
        self.done = False
        self.timer = self.create_timer(1.0 / rate, self._on_timer)
        self.get_logger().info(f'playing a {self.plan.duration:.1f} s plan for '
                               f'{", ".join(self.plan.robots)}')

    def _set_rate(self, rate: float) -> None:
        self.destroy_timer(self.timer)
        self.timer = self.create_timer(1.0 / rate, self._on_timer)

    def _on_timer(self) -> None:
        now = self.get_clock().now().nanoseconds * 1e-9
        if now == 0.0:
            return  # simulated time has not started yet (/clock not heard)
        if self.start_time is None:
            self.start_time = now
        elapsed = now - self.start_time
        for robot, publisher in self.cmd_pubs.items():
            linear, angular = self.plan.command_at(robot, elapsed)
            msg = Twist()
            msg.linear.x, msg.angular.z = linear, angular
            publisher.publish(msg)
        if not self.done and elapsed >= self.plan.duration:
            self.done = True
            self.done_pub.publish(Bool(data=True))
            self.get_logger().info(f'plan finished after {elapsed:.2f} s')


def main(args=None) -> int:
    return run(ScriptedDriver, 'scripted_driver', args, config_errors=(PlanError,))


if __name__ == '__main__':
    sys.exit(main())
