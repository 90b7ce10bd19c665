"""scripted_driver node: plays a timed velocity plan on /<robot>/cmd_vel.

Stands in for a planner before one exists (and drives the demo and tests). Time is
the node clock, so with use_sim_time the plan follows the simulation. When every
segment has played it publishes zero commands and `~/done` (latched) = true.
"""

import sys

from geometry_msgs.msg import Twist
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool

from .core.drive_plan import PlanError, load_plan
from .node_support import run


class ScriptedDriver(Node):

    def __init__(self):
        super().__init__('scripted_driver')
        self.declare_parameter('plan_file', '')
        self.declare_parameter('command_rate', 20.0)
        plan_file = self.get_parameter('plan_file').value
        if not plan_file:
            raise PlanError('parameter plan_file: required (path to a drive plan YAML)')
        self.plan = load_plan(plan_file)
        rate = self.get_parameter('command_rate').value
        if not 0.0 < rate <= 1000.0:
            raise PlanError(f'parameter command_rate: must be in (0, 1000] Hz (got {rate})')

        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.cmd_pubs = {robot: self.create_publisher(Twist, f'/{robot}/cmd_vel', qos)
                         for robot in self.plan.robots}
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.done_pub = self.create_publisher(Bool, '~/done', latched)
        self.done_pub.publish(Bool(data=False))
        self.start_time = None
        self.done = False
        self.timer = self.create_timer(1.0 / rate, self._on_timer)
        self.get_logger().info(f'playing a {self.plan.duration:.1f} s plan for '
                               f'{", ".join(self.plan.robots)}')

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
