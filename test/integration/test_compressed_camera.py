"""The camera's compressed path: image_transport's ``compressed`` topics from the bridge.

``<camera>/image_raw/compressed`` (JPEG) and ``<camera>/labels/compressed`` (lossless PNG) are
encoded only for a subscriber and throttled to ``compressed_rate`` frames per simulated second;
``compressed_rate`` and ``jpeg_quality`` change at run time. The SGCM nodes with
``image_transport: compressed`` complete a case exactly as over raw images.

Rates are counted from header stamps (simulated time) of a paused bridge stepped frame by
frame, so a slow machine cannot fail them.
"""
import time

import numpy as np
import pytest
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import DescribeParameters, SetParameters
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CompressedImage, Image
from sgcm_interfaces.msg import Guidance

from bridge_helpers import FAST_SIM, bridge_spec, stamp_seconds, step
from collab_tools.core.image_codec import LABELS_PNG_FORMAT, RGB8_JPEG_FORMAT, decode_labels, decode_rgb
from collab_tools.images import image_array
from collab_tools.orchestration.node_process import NodeSpec
from collab_tools.orchestration.session import Session
from test_sgcm_nodes import FOLLOWER_NS, LEADER_NS, resume_once_heard, start_case

NODE = '/pybullet_bridge'
CAMERA = '/top_camera'
FRAME_STEPS = 48          # test_tabletop: 5 Hz camera, 240 Hz physics
FRAME_PERIOD = 0.2
BEST_EFFORT = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT,
                         durability=DurabilityPolicy.VOLATILE)


@pytest.fixture
def bridge(session, config_dir):
    def start(**parameters):
        session.start(bridge_spec(config_dir / 'scenarios' / 'test_tabletop.yaml', **parameters))
        session.wait_for_message(f'{NODE}/status', 'bridge_interfaces/msg/SimulationStatus', timeout=60.0)
        return session
    return start


class Stream:
    """Messages of one topic, by stamp; subscribe()/unsubscribe() at will."""

    def __init__(self, node, msg_type, topic):
        self.node, self.msg_type, self.topic = node, msg_type, topic
        self.messages = []
        self.subscription = None

    def subscribe(self, timeout=20.0):
        self.subscription = self.node.create_subscription(self.msg_type, self.topic, self.messages.append,
                                                          BEST_EFFORT)
        deadline = time.monotonic() + timeout
        while self.subscription.get_publisher_count() == 0:
            assert time.monotonic() < deadline, f'nobody publishes {self.topic}'
            time.sleep(0.05)
        time.sleep(0.5)   # the bridge's side of discovery: it must count this subscriber too
        return self

    def unsubscribe(self):
        self.node.destroy_subscription(self.subscription)
        self.subscription = None
        time.sleep(0.5)   # and it must see it gone

    def stamps(self, after=-1.0):
        return [round(stamp_seconds(m), 6) for m in self.messages if stamp_seconds(m) > after + 1e-6]

    def by_stamp(self):
        return {round(stamp_seconds(m), 6): m for m in self.messages}


def step_frames(session, frames, *streams):
    """Step `frames` camera frames, one at a time, then let the last messages arrive."""
    for _ in range(frames):
        assert step(session, FRAME_STEPS).success
    time.sleep(0.5)
    return [stream.stamps() for stream in streams]


def step_until(session, stream, what, max_frames=10):
    """Step frame by frame until `stream` has a new message; returns its stamp."""
    count = len(stream.messages)
    for _ in range(max_frames):
        assert step(session, FRAME_STEPS).success
        deadline = time.monotonic() + 2.0
        while len(stream.messages) == count and time.monotonic() < deadline:
            time.sleep(0.05)
        if len(stream.messages) > count:
            return stamp_seconds(stream.messages[count])
    raise AssertionError(f'no {what} in {max_frames} frames')


def set_parameter(session, name, value):
    response = session.call_service(f'{NODE}/set_parameters', 'rcl_interfaces/srv/SetParameters',
                                    SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()]))
    return response.results[0]


def test_compressed_topics_as_image_transport_writes_them(bridge, ros_node):
    """Types, formats, stamps and frames of the raw ones; labels identical; bytes per frame printed."""
    session = bridge()
    raw = Stream(ros_node, Image, f'{CAMERA}/image_raw').subscribe()
    raw_labels = Stream(ros_node, Image, f'{CAMERA}/labels').subscribe()
    jpeg = Stream(ros_node, CompressedImage, f'{CAMERA}/image_raw/compressed').subscribe()
    png = Stream(ros_node, CompressedImage, f'{CAMERA}/labels/compressed').subscribe()
    types = dict(ros_node.get_topic_names_and_types())
    assert types[f'{CAMERA}/image_raw/compressed'] == ['sensor_msgs/msg/CompressedImage']
    assert types[f'{CAMERA}/labels/compressed'] == ['sensor_msgs/msg/CompressedImage']
    step_until(session, jpeg, 'compressed frame')
    step_frames(session, 3)

    sizes = {}
    raw_by_stamp, labels_by_stamp, png_by_stamp = raw.by_stamp(), raw_labels.by_stamp(), png.by_stamp()
    compared = 0
    for stamp, compressed in jpeg.by_stamp().items():
        if stamp not in raw_by_stamp or stamp not in labels_by_stamp or stamp not in png_by_stamp:
            continue  # best effort: a frame may miss one of the four topics
        image, labels, compressed_labels = raw_by_stamp[stamp], labels_by_stamp[stamp], png_by_stamp[stamp]
        assert compressed.format == RGB8_JPEG_FORMAT and compressed_labels.format == LABELS_PNG_FORMAT
        assert compressed.header.frame_id == image.header.frame_id == compressed_labels.header.frame_id
        assert np.array_equal(decode_labels(compressed_labels.format, compressed_labels.data), image_array(labels))
        error = np.abs(decode_rgb(compressed.format, compressed.data).astype(int) - image_array(image).astype(int))
        assert error.mean() < 2.0, f'JPEG error {error.mean():.2f} at the default quality'
        sizes = {'image_raw (rgb8)': len(image.data), 'labels (16UC1)': len(labels.data),
                 'image_raw/compressed (JPEG q95)': len(compressed.data),
                 'labels/compressed (PNG)': len(compressed_labels.data)}
        compared += 1
    assert compared >= 2

    # The same frame at lower JPEG qualities (jpeg_quality set at run time).
    for quality in (80, 50):
        assert set_parameter(session, 'jpeg_quality', quality).successful
        count = len(jpeg.messages)
        step_frames(session, 2)
        assert len(jpeg.messages) > count
        sizes[f'image_raw/compressed (JPEG q{quality})'] = len(jpeg.messages[-1].data)
    raw_total = sizes['image_raw (rgb8)'] + sizes['labels (16UC1)']
    compressed_total = sizes['image_raw/compressed (JPEG q95)'] + sizes['labels/compressed (PNG)']
    print('\nbytes per frame, test_tabletop (320x320):')
    for name, size in sizes.items():
        print(f'  {name:34s} {size:8d}')
    print(f'  raw image + labels {raw_total} -> compressed (q95) {compressed_total} '
          f'({raw_total / compressed_total:.1f}x less)')
    assert compressed_total * 5 < raw_total
    assert sizes['image_raw/compressed (JPEG q50)'] < sizes['image_raw/compressed (JPEG q95)']


def test_compressed_frames_only_while_subscribed_and_at_the_throttled_rate(bridge, ros_node):
    session = bridge(compressed_rate=1.0)
    raw = Stream(ros_node, Image, f'{CAMERA}/image_raw').subscribe()
    jpeg = Stream(ros_node, CompressedImage, f'{CAMERA}/image_raw/compressed').subscribe()
    png = Stream(ros_node, CompressedImage, f'{CAMERA}/labels/compressed').subscribe()
    first = step_until(session, jpeg, 'compressed frame')

    # 1 Hz of a 5 Hz camera, counted over 4 s of simulated time.
    step_frames(session, 20)
    window = [s for s in jpeg.stamps(first) if s <= first + 4.0 + 1e-6]
    raw_window = [s for s in raw.stamps(first) if s <= first + 4.0 + 1e-6]
    assert len(raw_window) >= 18, 'the raw camera kept its 5 Hz'
    assert 3 <= len(window) <= 4, window                # 4 (one per second) unless best effort lost one
    assert set(window) <= set(raw.stamps()), 'a compressed frame is a rendered frame'
    assert set(png.stamps(first)) <= set(jpeg.stamps(first)) and len(png.stamps(first)) >= 3, \
        'labels come with the image of the same frame'

    # Nobody subscribed: nothing is encoded, so the throttle spends no slot on the frame due
    # meanwhile. Resubscribed 1.2 s after the last frame sent, the very next frame comes;
    # had the bridge encoded the frame at +1.0 s for nobody, the next would wait until +2.0 s.
    png.unsubscribe()
    jpeg.unsubscribe()
    last = max(jpeg.stamps())
    step_frames(session, 6)
    jpeg.subscribe()
    resumed = step_until(session, jpeg, 'compressed frame after resubscribing', max_frames=5)
    assert last + 1.0 + FRAME_PERIOD / 2 < resumed < last + 2.0 - FRAME_PERIOD / 2, (last, resumed)


def test_compressed_rate_and_jpeg_quality_apply_at_run_time(bridge, ros_node):
    session = bridge(compressed_rate=1.0)
    response = session.call_service(f'{NODE}/describe_parameters', 'rcl_interfaces/srv/DescribeParameters',
                                    DescribeParameters.Request(names=['compressed_rate', 'jpeg_quality']))
    rate, quality = response.descriptors
    assert rate.type == ParameterType.PARAMETER_DOUBLE and not rate.read_only and rate.description
    assert (rate.floating_point_range[0].from_value, rate.floating_point_range[0].to_value) == (0.0, 1000.0)
    assert quality.type == ParameterType.PARAMETER_INTEGER and not quality.read_only
    assert (quality.integer_range[0].from_value, quality.integer_range[0].to_value) == (1, 100)
    for name, value in (('compressed_rate', -1.0), ('jpeg_quality', 0), ('jpeg_quality', 101),
                        ('jpeg_quality', 'high')):
        result = set_parameter(session, name, value)
        assert not result.successful, (name, value)

    raw = Stream(ros_node, Image, f'{CAMERA}/image_raw').subscribe()
    jpeg = Stream(ros_node, CompressedImage, f'{CAMERA}/image_raw/compressed').subscribe()
    first = step_until(session, jpeg, 'compressed frame')
    step_frames(session, 10)
    slow = jpeg.stamps(first)                                       # 1 Hz over 2 s: 2
    assert len(slow) <= 2, slow

    assert set_parameter(session, 'compressed_rate', 0.0).successful   # every frame
    start = max(raw.stamps())
    step_frames(session, 10)
    every = jpeg.stamps(start)
    assert len(every) >= 9 and set(every) <= set(raw.stamps(start)), (every, raw.stamps(start))

    assert set_parameter(session, 'compressed_rate', 2.5).successful   # every other frame
    start = max(raw.stamps())
    step_frames(session, 10)
    half = jpeg.stamps(start)
    assert 4 <= len(half) <= 5, half

    # Quality: the (still) table at 95 and at 10.
    assert set_parameter(session, 'compressed_rate', 0.0).successful
    sizes = {}
    for value in (95, 10):
        assert set_parameter(session, 'jpeg_quality', value).successful
        count = len(jpeg.messages)
        step_frames(session, 3)
        sizes[value] = [len(m.data) for m in jpeg.messages[count:]]
        assert sizes[value]
    assert max(sizes[10]) < 0.6 * min(sizes[95]), sizes


def run_case(session, tmp_path, task_file, config_dir, transport):
    """case_8 with both SGCM nodes on `transport`; the rounds' guidance and the final one."""
    # Guidance is not latched: the simulation runs only once our subscription has matched the
    # leader's publisher, so round 1 cannot be missed however slow discovery is.
    guidance = []
    subscription = session.observer.node.create_subscription(Guidance, '/sgcm/guidance', guidance.append, 10)
    # compressed_rate: the compressed stream (each frame rendered and encoded) at 2 frames per simulated
    # second instead of the camera's 5; a node looks once per round, at the first frame after settling.
    start_case(session, tmp_path, task_file, config_dir, 'case_8', start_paused=True,
               leader_params={'image_transport': transport}, follower_params={'image_transport': transport},
               compressed_rate=2.0, **FAST_SIM)
    session.wait_for_nodes([f'{LEADER_NS}/leader_planner', f'{FOLLOWER_NS}/follower_executor'], 60.0)
    resume_once_heard(session, subscription)
    deadline = time.monotonic() + 180.0
    while not guidance:   # the first round: both nodes have long been reading the camera
        assert time.monotonic() < deadline, 'no guidance'
        session.check_alive()
        time.sleep(0.1)
    # Which camera topics each SGCM node reads (the graph, as `ros2 topic info -v` shows it).
    readers = {}
    for topic in ('image_raw', 'labels', 'image_raw/compressed', 'labels/compressed'):
        infos = session.observer.node.get_subscriptions_info_by_topic(f'{CAMERA}/{topic}')
        readers[topic] = {f'{i.node_namespace.rstrip("/")}/{i.node_name}' for i in infos}
    final = session.wait_for_message('/sgcm/guidance', 'sgcm_interfaces/msg/Guidance',
                                     predicate=lambda m: m.task_complete or bool(m.status), timeout=240)
    assert session.wait_for_exit('leader_arm/leader_planner', 30) == 0
    rounds = [(g.round, list(g.state.counts), (g.leader_move.empty, g.leader_move.source_cell,
                                               g.leader_move.target_cell, g.leader_move.colour),
               g.leader_move_succeeded, (g.recommended_follower_move.empty, g.recommended_follower_move.source_cell,
                                         g.recommended_follower_move.target_cell,
                                         g.recommended_follower_move.colour))
              for g in guidance if not g.task_complete]
    return final, rounds, readers


def test_sgcm_case_over_compressed_images_ends_as_over_raw(session, tmp_path, config_dir):
    task_file = config_dir / 'sgcm' / 'task.yaml'
    with Session('raw_reference', run_dir=tmp_path / 'raw_run', log=None, stop_timeout=10.0) as raw_session:
        raw_final, raw_rounds, _ = run_case(raw_session, tmp_path / 'raw_run', task_file, config_dir, 'raw')
    assert raw_final.task_complete, raw_final.status

    final, rounds, readers = run_case(session, tmp_path, task_file, config_dir, 'compressed')
    sgcm_nodes = {f'{LEADER_NS}/leader_planner', f'{FOLLOWER_NS}/follower_executor'}
    assert sgcm_nodes <= readers['image_raw/compressed'] and sgcm_nodes <= readers['labels/compressed']
    assert not sgcm_nodes & (readers['image_raw'] | readers['labels']), 'a node still reads raw images'
    assert final.task_complete, final.status
    # Same rounds: the same estimates (labels identical, colours within JPEG error), moves and outcome.
    assert rounds and rounds == raw_rounds
    assert list(final.state.counts) == list(raw_final.state.counts)


def test_an_unknown_image_transport_stops_the_sgcm_node(session, config_dir):
    process = session.start(NodeSpec('sgcm', 'leader_planner', name='leader_planner', namespace=LEADER_NS,
                                     parameters=[{'task_file': str(config_dir / 'sgcm' / 'task.yaml'),
                                                  'image_transport': 'theora'}]))
    assert session.wait_for_exit(process.name, timeout=60.0) == 2
    log = process.log_path.read_text()
    assert "parameter image_transport: must be one of raw, compressed (got 'theora')" in log
    assert 'Traceback' not in log
