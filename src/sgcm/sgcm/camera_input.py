"""The top-view camera as the SGCM nodes see it: labelled frames turned into state estimates.

The frames, their geometry and the label legend come from the shared
:class:`collab_tools.top_camera.TopCamera` (with the label image); this adds which labels
are cubes and the state estimate of :mod:`sgcm.core.perception`. The nodes' ``camera`` and
``image_transport`` parameters are in :mod:`sgcm.core.settings`.
"""
from __future__ import annotations

from rclpy.node import Node
from rclpy.time import Time

from collab_tools.top_camera import TopCamera

from .core.perception import StateEstimate, estimate_state
from .core.task_config import TaskConfig

CUBE_KIND = 'cube'


class CameraInput:
    def __init__(self, node: Node, task: TaskConfig, camera: str = '/top_camera', transport: str = 'raw'):
        # camera: absolute namespace (a team-shared sensor); TopCamera subscribes with sensor-data QoS
        self.task = task
        self.camera = TopCamera(node, camera, with_labels=True, transport=transport)

    @property
    def cube_labels(self) -> dict[int, str]:
        return {label: name for label, (name, kind) in self.camera.legend.items() if kind == CUBE_KIND}

    def frame_time(self) -> Time | None:
        """Stamp of the newest complete (RGB + labels with equal stamps) frame."""
        return self.camera.frame_time()

    def estimate(self) -> StateEstimate:
        """State estimate from the newest complete frame; ValueError if it cannot be used."""
        _, rgb = self.camera.frame()
        ws = self.task.workspace
        return estimate_state(self.camera.labels(), rgb, self.cube_labels, self.camera.geometry(),
                              self.task, top_height=ws.table_height + ws.cube_size)
