"""ROS face of the robots' simulated sensors (core/sensors.py).

Replaces the plain mobile-robot adapter: a robot keeps its ``<robot>/cmd_vel`` and,
when its scenario entry lists ``sensors``, also gets

* ``<robot>/fiducials`` (bridge_interfaces/FiducialDetections, frame ``<robot>/fiducial_link``),
* ``<robot>/scan`` (sensor_msgs/LaserScan, frame ``<robot>/laser_link``),
* ``<robot>/gps`` (geometry_msgs/PoseWithCovarianceStamped, world frame),
* ``<robot>/bumper`` (bridge_interfaces/BumperState, frame ``<robot>/bumper_link``),

one per configured sensor (names relative to the node's namespace), each published as
sensor data (best effort) at its rate in simulated time while the sensor is active, and the
service ``<robot>/set_sensor_active`` (bridge_interfaces/SetSensorActive) that switches a
sensor on or off. The sensor links sit at ``<robot>/base_link`` (/tf_static, core/frames.py).
A scene reset recreates the adapters, so every sensor goes back to its configured ``active``
state.
"""

from __future__ import annotations

from bridge_interfaces.msg import BumperContact, BumperState, FiducialDetection, FiducialDetections
from bridge_interfaces.srv import SetSensorActive
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.node import Node
from rclpy.time import Time
from sensor_msgs.msg import LaserScan

from collab_tools.input_guard import InputGuard
from collab_tools.qos import SENSOR_OUT

from .core.frames import sensor_frame
from .core.mobile_robot import MobileRobot, yaw_quaternion
from .core.sensor_config import BUMPER, FIDUCIAL, GPS, LASER
from .core.sensors import BumperReading, FiducialReading, GpsReading, LaserReading, RobotSensors
from .entity_adapters import MobileRobotAdapter, RejectFn, register_adapter

TOPICS = {FIDUCIAL: 'fiducials', LASER: 'scan', GPS: 'gps', BUMPER: 'bumper'}
MESSAGE_TYPES = {FIDUCIAL: FiducialDetections, LASER: LaserScan, GPS: PoseWithCovarianceStamped,
                 BUMPER: BumperState}


class SensingMobileRobotAdapter(MobileRobotAdapter):
    """cmd_vel (inherited) plus the robot's sensor topics and on/off service."""

    def __init__(self, node: Node, entity: MobileRobot, reject: RejectFn):
        super().__init__(node, entity, reject)
        self.sensors: RobotSensors | None = None
        self.publishers = {}
        if entity.sensors is None:
            return
        self.sensors = RobotSensors(node.scene, entity)
        for name in self.sensors.names:
            publisher = node.create_publisher(MESSAGE_TYPES[name], f'{entity.name}/{TOPICS[name]}', SENSOR_OUT)
            self.publishers[name] = publisher
            self._ros_objects.append(publisher)
        self.service_name = f'{entity.name}/set_sensor_active'
        self._ros_objects.append(InputGuard.of(node).serve(SetSensorActive, self.service_name, self._on_set_active))

    def on_tick(self, sim_time: float) -> None:
        if self.sensors is None:
            return
        stamp = Time(nanoseconds=int(round(sim_time * 1e9))).to_msg()
        for name, reading in self.sensors.due(sim_time):
            msg = self._to_message(reading)
            msg.header.stamp = stamp
            self.publishers[name].publish(msg)

    def _on_set_active(self, request: SetSensorActive.Request, response: SetSensorActive.Response):
        try:
            self.sensors.set_active(request.sensor, bool(request.active), self.node.scene.sim_time)
        except KeyError as error:
            response.success = False
            response.message = error.args[0]
            return response
        response.success = True
        state = 'active' if request.active else 'inactive'
        response.message = (f"{self.entity.name}: sensor '{request.sensor}' is {state}"
                            + (f' (publishing on {self.entity.name}/{TOPICS[request.sensor]})'
                               if request.active else ''))
        return response

    # -- conversions ----------------------------------------------------------------------

    def _to_message(self, reading):
        if isinstance(reading, FiducialReading):
            msg = FiducialDetections(field_of_view=reading.field_of_view, max_range=reading.max_range)
            msg.header.frame_id = sensor_frame(self.entity.name, FIDUCIAL)
            msg.detections = [FiducialDetection(name=d.name, kind=d.kind, range=float(d.range),
                                                bearing=float(d.bearing), x=float(d.x), y=float(d.y),
                                                yaw=float(d.yaw))
                              for d in reading.detections]
            return msg
        if isinstance(reading, LaserReading):
            period = 1.0 / self.sensors.config[LASER].rate
            msg = LaserScan(angle_min=reading.angle_min, angle_max=reading.angle_max,
                            angle_increment=reading.angle_increment, time_increment=0.0, scan_time=period,
                            range_min=float(reading.range_min), range_max=float(reading.range_max),
                            ranges=[float(r) for r in reading.ranges])
            msg.header.frame_id = sensor_frame(self.entity.name, LASER)
            return msg
        if isinstance(reading, GpsReading):
            msg = PoseWithCovarianceStamped()
            msg.header.frame_id = self.node.scene.scenario.world.frame_id
            pose = msg.pose.pose
            pose.position.x, pose.position.y = reading.x, reading.y
            pose.position.z = self.entity.params.height / 2.0
            q = yaw_quaternion(reading.yaw)
            pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = q
            # Row-major 6x6 over (x, y, z, roll, pitch, yaw); z, roll, pitch are exact for a planar robot.
            covariance = [0.0] * 36
            covariance[0] = covariance[7] = reading.position_std ** 2
            covariance[35] = reading.yaw_std ** 2
            msg.pose.covariance = covariance
            return msg
        if isinstance(reading, BumperReading):
            msg = BumperState(pressed=reading.pressed,
                              contacts=[BumperContact(name=c.name, kind=c.kind, bearing=float(c.bearing))
                                        for c in reading.contacts])
            msg.header.frame_id = sensor_frame(self.entity.name, BUMPER)
            return msg
        raise TypeError(f'no message for sensor reading {type(reading).__name__}')


register_adapter(MobileRobot, SensingMobileRobotAdapter)
