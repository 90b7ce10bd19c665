"""Helpers for tests that drive the pybullet bridge over ROS."""

import time

from bridge_interfaces.srv import StepSimulation
from geometry_msgs.msg import Twist
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_srvs.srv import SetBool

from collab_tools.orchestration.node_process import NodeSpec

PHYSICS_HZ = 240


def bridge_spec(scenario, **parameters) -> NodeSpec:
    params = {'scenario': str(scenario), 'real_time_factor': 0.0, 'start_paused': True}
    params.update(parameters)
    return NodeSpec('pybullet_bridge', 'pybullet_bridge', name='pybullet_bridge',
                    parameters=[params], use_sim_time=False)


def body_pose(session, name, timeout=20.0):
    """Latest ground-truth pose of body `name` as (x, y, msg)."""
    msg = session.wait_for_message('/ground_truth/bodies', 'bridge_interfaces/msg/BodyStates',
                                   timeout=timeout, latched=True)
    for body in msg.bodies:
        if body.name == name:
            return body.pose.position.x, body.pose.position.y, body
    raise AssertionError(f'{name} not in ground truth: {[b.name for b in msg.bodies]}')


def step(session, steps):
    response = session.call_service('/pybullet_bridge/step', 'bridge_interfaces/srv/StepSimulation',
                                    StepSimulation.Request(steps=steps))
    return response


def set_paused(session, paused):
    return session.call_service('/pybullet_bridge/pause', 'std_srvs/srv/SetBool',
                                SetBool.Request(data=paused))


def drive(session, publisher, linear, angular, seconds, chunk=0.25):
    """Command (linear, angular) for `seconds` of simulated time, stepping a paused bridge."""
    msg = Twist()
    msg.linear.x, msg.angular.z = float(linear), float(angular)
    elapsed = 0.0
    while elapsed < seconds - 1e-9:
        publisher.publish(msg)
        time.sleep(0.05)  # let the bridge take the command before it steps
        response = step(session, int(round(chunk * PHYSICS_HZ)))
        assert response.success, response.message
        elapsed += chunk


def collect(ros_node, msg_type, topic, timeout=10.0, latched=False, reliable=False):
    """Subscribe and return the list the messages are appended to, once the bridge's publisher matched.

    Best effort (the bridge's sensors and camera are sensor data) unless `reliable` or
    `latched`; a deep history keeps everything a fast-stepped bridge sends.
    """
    received = []
    qos = QoSProfile(depth=100, reliability=(ReliabilityPolicy.RELIABLE if reliable or latched
                                             else ReliabilityPolicy.BEST_EFFORT),
                     durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE))
    subscription = ros_node.create_subscription(msg_type, topic, received.append, qos)
    deadline = time.monotonic() + timeout
    while subscription.get_publisher_count() == 0:
        assert time.monotonic() < deadline, f'nobody publishes {topic}'
        time.sleep(0.05)
    return received


def settle(received, at_least=1, timeout=5.0):
    """Wait until ``received`` holds ``at_least`` messages (then a little longer for stragglers)."""
    deadline = time.monotonic() + timeout
    while len(received) < at_least and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)
    return list(received)


def stamp_seconds(msg):
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def wait_for_subscriber(publisher, timeout=10.0):
    deadline = time.monotonic() + timeout
    while publisher.get_subscription_count() == 0:
        assert time.monotonic() < deadline, f'nobody subscribed to {publisher.topic_name}'
        time.sleep(0.05)


#: Bridge parameters that run a simulation on arms and camera faster at real_time_factor 0 without
#: changing what happens in it: /clock at 50 Hz instead of every control tick (each message wakes every
#: node on simulated time) and 50 ms of simulation per timer call (the arms tick at 20 Hz). The same
#: as config/experiments/sgcm_case.yaml.
FAST_SIM = {'clock_rate': 50.0, 'fast_batch_period': 0.05}
