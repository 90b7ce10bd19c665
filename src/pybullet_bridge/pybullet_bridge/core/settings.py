"""The bridge node's parameters as pure data (declared by the node with NodeParameters.declare_schema).

Dynamic ones (changed with ``ros2 param set``): real_time_factor, ground_truth_rate, status_rate and
the camera's publish_camera, compressed_rate, jpeg_quality; the others are read-only after start.
A bad start value stops the node with exit code 2 and ``parameter <name>: <what is allowed>``.
"""
from __future__ import annotations

from collab_tools.core.settings import Setting, SettingsSchema

#: Upper bound of every rate parameter (Hz).
MAX_RATE = 1000.0
MAX_REAL_TIME_FACTOR = 1000.0
#: compressed_image_transport's default jpeg_quality.
DEFAULT_JPEG_QUALITY = 95
MAX_COMPRESSED_RATE = 1000.0
#: The camera's renderers (core/renderer.py): the EGL plugin, TinyRenderer, or EGL where it loads.
TINY, EGL, AUTO = 'tiny', 'egl', 'auto'
RENDERERS = (AUTO, EGL, TINY)

#: Parameters of the simulation loop (bridge_node.py).
BRIDGE_SETTINGS = SettingsSchema(
    Setting('scenario', '', 'path to the scenario YAML (see README: scenario files)', required=True),
    Setting('scenario_directories', [''], "directories ~/reset may load a requested scenario from (symlinks and "
            "'..' resolved first; a relative request is relative to the first); [''] = the workspace's "
            'config/scenarios (core/scenario_access.py)'),
    Setting('real_time_factor', 1.0, 'simulated seconds per wall second; 0 = as fast as possible',
            low=0.0, high=MAX_REAL_TIME_FACTOR, dynamic=True),
    Setting('control_period', 0.01, 'simulated seconds per tick (/clock and command update), '
            'rounded to a whole number of physics steps', low=0.0, high=1.0, low_open=True),
    Setting('fast_batch_period', 0.0, 'at real_time_factor 0: simulated seconds run per timer call '
            '(whole control ticks, at least one); commands and requests are handled between batches, so '
            'this is also their latency; 0 = one tick per call', low=0.0, high=1.0),
    Setting('clock_rate', 0.0, 'Hz of simulated time for /clock; 0 = every control tick. Every node '
            'on simulated time handles each /clock message (about 0.2 ms of Python each), so a case '
            'run fast gains from a lower rate; timers then fire at most this often',
            low=0.0, high=MAX_RATE),
    Setting('ground_truth_rate', 20.0, 'Hz of simulated time for ground_truth/bodies, /tf and the '
            "arms' joint_states", low=0.0, high=MAX_RATE, low_open=True, dynamic=True),
    Setting('status_rate', 1.0, 'Hz of wall-clock time for ~/status (also while paused)',
            low=0.0, high=MAX_RATE, low_open=True, dynamic=True),
    Setting('start_paused', False, 'start paused; advance with ~/step or ~/pause false'),
    Setting('camera_renderer', TINY, "the top-view camera's renderer: tiny (TinyRenderer, the reference), "
            "egl (pybullet's eglRenderer plugin, or exit 2) or auto (egl where it loads, else tiny); EGL "
            'frames differ (core/renderer.py): it draws no robot heading markers, which robot_tracker needs',
            choices=RENDERERS),
)

#: Parameters of the top-view camera's publishers (camera_adapter.py), all dynamic.
CAMERA_SETTINGS = SettingsSchema(
    Setting('publish_camera', True, 'the top-view camera on: streamed to subscribers (rendered only for them) '
            'and served on <camera>/get_frame', dynamic=True),
    Setting('compressed_rate', 0.0, 'Hz of simulated time for <camera>/image_raw/compressed '
            'and <camera>/labels/compressed (at most the camera rate); 0 = every frame',
            low=0.0, high=MAX_COMPRESSED_RATE, dynamic=True),
    Setting('jpeg_quality', DEFAULT_JPEG_QUALITY, 'JPEG quality of <camera>/image_raw/compressed '
            '(100 = best, largest)', low=1, high=100, dynamic=True),
)

#: Every parameter of the pybullet_bridge node, in declaration order.
NODE_SETTINGS = BRIDGE_SETTINGS.extended(*CAMERA_SETTINGS)
