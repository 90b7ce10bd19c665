"""Helpers for tests that drive the pybullet bridge over ROS."""

import time

from bridge_interfaces.srv import StepSimulation
from geometry_msgs.msg import Twist
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


def wait_for_subscriber(publisher, timeout=10.0):
    deadline = time.monotonic() + timeout
    while publisher.get_subscription_count() == 0:
        assert time.monotonic() < deadline, f'nobody subscribed to {publisher.topic_name}'
        time.sleep(0.05)
