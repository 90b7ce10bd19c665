"""Started in a namespace, the bridge moves every name there except /clock, /tf and /tf_static."""
import time
from dataclasses import replace

from bridge_helpers import bridge_spec


def test_every_name_but_clock_and_tf_follows_the_namespace(session, config_dir):
    spec = replace(bridge_spec(config_dir / 'scenarios' / 'test_sensors.yaml'), namespace='/sim1')
    session.start(spec)
    session.wait_for_message('/sim1/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus', timeout=30.0)
    node = session.observer.node
    expected_topics = {'/sim1/ground_truth/bodies', '/sim1/top_camera/image_raw', '/sim1/top_camera/labels',
                       '/sim1/top_camera/camera_info', '/sim1/top_camera/label_legend', '/sim1/top_camera/pose',
                       '/sim1/robot_1/cmd_vel', '/sim1/robot_1/scan', '/sim1/robot_1/fiducials',
                       '/sim1/robot_2/gps', '/sim1/pybullet_bridge/status', '/clock', '/tf', '/tf_static'}
    expected_services = {'/sim1/pybullet_bridge/step', '/sim1/pybullet_bridge/reset',
                         '/sim1/robot_1/set_sensor_active', '/sim1/pybullet_bridge/set_parameters'}
    deadline = time.monotonic() + 20.0
    while True:
        topics = {name for name, _ in node.get_topic_names_and_types()}
        services = {name for name, _ in node.get_service_names_and_types()}
        if expected_topics <= topics and expected_services <= services or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    assert expected_topics - topics == set()
    assert expected_services - services == set()
    bridge_names = {name for name in topics | services
                    if name.startswith(('/robot_', '/top_camera', '/ground_truth', '/pybullet_bridge'))}
    assert bridge_names == set(), 'names left outside the namespace'
