"""The QoS profiles of the workspace, one per kind of data (README: "Topics and QoS").

Compatibility rules that decide them (a subscription matches a publisher when it asks for no
more than the publisher offers): a best-effort subscription matches reliable and best-effort
publishers; a volatile subscription matches volatile and transient-local publishers.

* ``SENSOR_IN``: every sensor-like *input* (images, camera info, scans, fiducials, bumper, GPS,
  cmd_vel): best effort, volatile, so a camera driver with sensor-data QoS or a best-effort
  teleop is accepted as well as a reliable publisher.
* ``SENSOR_OUT``: what the bridge publishes as a sensor (rclpy's sensor-data profile): best
  effort, volatile, so no subscriber -- slow, remote or dead -- can stall the publisher.
* ``COMMAND_OUT``: cmd_vel as teleop publishes it: reliable, volatile, depth 10.
* ``LATCHED``: state published once or on change (legend, camera pose, assignments, statuses):
  reliable, transient local, depth 1; subscribers use it too, so late joiners get the last value.
* ``RELIABLE``: events that must arrive (channels, guidance, reports): reliable, volatile.
* ``STREAM``: a fast reliable stream a recorder keeps whole (/clock): RELIABLE with a 100-sample
  writer history. (A latched topic keeps depth 1: a deeper transient-local history is replayed
  oldest first to late joiners, who then read a stale value as the latest.)
"""
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

SENSOR_IN = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                       durability=DurabilityPolicy.VOLATILE)
SENSOR_OUT = qos_profile_sensor_data
COMMAND_OUT = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)
#: A fast reliable stream a recorder must keep whole (/clock at up to 250 Hz): a reliable writer
#: with KEEP_LAST overwrites samples a slow reader has not acknowledged, so its history must cover a reader's stall (100 samples: 0.4 s at 250 Hz) or the bag has gaps.
STREAM = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
