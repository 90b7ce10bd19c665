"""A bag's top-view camera as a video (MP4 with OpenCV, GIF with Pillow), with markers drawn on the frames.

The camera frames a bag holds (``<camera>/image_raw/compressed``, else ``<camera>/image_raw``) are
decoded in bag order; the messages recorded before each frame give the markers drawn on it, each
world point projected with the camera's own model (:class:`.camera_geometry.TopViewGeometry`, from
the recorded ``<camera>/camera_info`` and the latched ``<camera>/pose``):

* every mobile robot (``bridge_interfaces/BodyStates``): its name and its trajectory so far, in its
  simulation colour (the scene's layout, :mod:`.scene_layout`);
* SGCM (``sgcm_interfaces/Guidance``): the table's grid cells with the leader's estimated cube counts,
  the leader's move and the recommended follower move as arrows, the round in the caption;
* the role engine (``role_interfaces/RoleAssignment``): each robot's formation target (a cross in
  its colour);
* coalitions (``coalition_interfaces/AgentStatus``): a line from each committed helper to its leader.

The caption gives the simulated time. Without camera_info and pose only the caption is drawn.
MP4 uses the ``mp4v`` codec (MPEG-4 Part 2), which the opencv-python-headless wheel writes and
reads back (its FFmpeg has no H.264 encoder); GIF frames are palettised by Pillow.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from .bag_analysis import BagSummary, read_messages
from .camera_geometry import CameraGeometryError, TopViewGeometry
from .image_codec import decode_rgb
from .scene_layout import SceneLayout

__all__ = ['FORMATS', 'MP4_FOURCC', 'VideoInfo', 'camera_topic', 'export_video', 'read_video', 'write_frames']

FORMATS = ('mp4', 'gif')
MP4_FOURCC = 'mp4v'
COMPRESSED_TYPE = 'sensor_msgs/msg/CompressedImage'
RAW_TYPE = 'sensor_msgs/msg/Image'
#: Frames smaller than this (pixels, the shorter side) are scaled up so the markers' text is legible.
MIN_SIDE = 480
PALETTE = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189), (140, 86, 75)]


@dataclass(frozen=True)
class VideoInfo:
    path: Path
    frames: int
    width: int
    height: int
    fps: float
    camera_topic: str


def camera_topic(summary: BagSummary) -> str | None:
    """The bag's top-view image topic with frames: compressed preferred, label images never."""
    for type_name, suffix in ((COMPRESSED_TYPE, '/image_raw/compressed'), (RAW_TYPE, '/image_raw')):
        for stats in summary.topics:
            if stats.type_name == type_name and stats.topic.endswith(suffix) and stats.count:
                return stats.topic
    return None


def _raw_rgb(msg) -> np.ndarray:
    channels = {'rgb8': 3, 'bgr8': 3, 'mono8': 1}.get(msg.encoding)
    if channels is None:
        raise ValueError(f'image encoding {msg.encoding!r} (expected rgb8, bgr8 or mono8)')
    rows = np.frombuffer(bytes(msg.data), np.uint8).reshape(msg.height, msg.step)
    image = rows[:, :msg.width * channels].reshape(msg.height, msg.width, channels)
    if channels == 1:
        return np.repeat(image, 3, axis=2)
    return image[..., ::-1].copy() if msg.encoding == 'bgr8' else image.copy()


def _stamp(header) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def _bgr(colour) -> tuple[int, int, int]:
    """A matplotlib-style (r, g, b) in [0, 1] or 0..255 -> OpenCV's BGR ints."""
    r, g, b = (float(c) for c in colour[:3])
    scale = 255.0 if max(r, g, b) <= 1.0 else 1.0
    return int(b * scale), int(g * scale), int(r * scale)


@dataclass
class _Markers:
    """What the messages before a frame say: the state the markers show."""
    layout: SceneLayout | None
    info_k: list[float] | None = None
    pose: tuple | None = None
    trails: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    guidance: object = None
    goals: dict[str, tuple[float, float]] = field(default_factory=dict)
    helpers: dict[str, str] = field(default_factory=dict)       # committed helper -> its leader
    _geometry: TopViewGeometry | None = None

    def update(self, topic: str, msg, camera_ns: str) -> None:
        kind = getattr(msg, '__msgtype__', type(msg).__name__)
        if topic == f'{camera_ns}/camera_info':
            if self.info_k != list(msg.k):
                self.info_k, self._geometry = list(msg.k), None
        elif topic == f'{camera_ns}/pose':
            p, q = msg.pose.position, msg.pose.orientation
            self.pose, self._geometry = ((p.x, p.y, p.z), (q.x, q.y, q.z, q.w)), None
        elif kind.endswith('BodyStates'):
            for body in msg.bodies:
                if body.kind == 'mobile_robot':
                    trail = self.trails.setdefault(body.name, [])
                    here = (body.pose.position.x, body.pose.position.y)
                    if not trail or np.hypot(here[0] - trail[-1][0], here[1] - trail[-1][1]) > 0.01:
                        trail.append(here)
        elif kind.endswith('Guidance'):
            self.guidance = msg
        elif kind.endswith('RoleAssignment') and msg.status == 'assigned':
            self.goals = {r: (float(x), float(y)) for r, x, y in zip(msg.robots, msg.goal_x, msg.goal_y)}
        elif kind.endswith('AgentStatus'):
            self.helpers = {h: l for h, l in self.helpers.items() if h != msg.robot}
            if msg.state == 4 and msg.leader and msg.leader != msg.robot:   # COMMITTED helper
                self.helpers[msg.robot] = msg.leader

    def geometry(self) -> TopViewGeometry | None:
        if self._geometry is None and self.info_k is not None and self.pose is not None:
            try:
                self._geometry = TopViewGeometry.from_camera_info(self.info_k, *self.pose)
            except CameraGeometryError:
                return None
        return self._geometry

    def colour(self, robot: str) -> tuple[int, int, int]:
        known = self.layout.robot_color(robot) if self.layout is not None else None
        if known is not None:
            return _bgr(known)
        names = sorted(set(self.trails) | set(self.goals))
        r, g, b = PALETTE[(names.index(robot) if robot in names else 0) % len(PALETTE)]
        return b, g, r


def _text(image, text: str, origin, colour=(255, 255, 255), scale: float = 0.45, outline=(0, 0, 0)) -> None:
    """Outlined text, kept inside the image."""
    (width, height), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    x = int(min(max(origin[0], 2), image.shape[1] - width - 2))
    y = int(min(max(origin[1], height + 2), image.shape[0] - 4))
    # The outline is the same text shifted by a pixel: a thicker stroke would advance each glyph further.
    for dx, dy in ((-1, -1), (-1, 1), (1, -1), (1, 1), (0, -1), (0, 1), (-1, 0), (1, 0)):
        cv2.putText(image, text, (x + dx, y + dy), cv2.FONT_HERSHEY_SIMPLEX, scale, outline, 1, cv2.LINE_AA)
    cv2.putText(image, text, (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def _draw(image: np.ndarray, markers: _Markers, scale: float, caption: str) -> None:
    """Markers onto a BGR image (already scaled by ``scale`` from the camera's pixels)."""
    geometry = markers.geometry()

    def px(points) -> np.ndarray | None:
        if geometry is None or not len(points):
            return None
        try:
            return np.round(geometry.world_to_pixel(np.asarray(points, dtype=float)) * scale).astype(np.int32)
        except CameraGeometryError:
            return None

    if geometry is not None:
        _draw_sgcm(image, markers, px)
        for helper, leader in markers.helpers.items():
            ends = [markers.trails.get(helper, [None])[-1], markers.trails.get(leader, [None])[-1]]
            if None not in ends and (points := px(ends)) is not None:
                cv2.line(image, tuple(points[0]), tuple(points[1]), (255, 255, 255), 2, cv2.LINE_AA)
        for robot, goal in markers.goals.items():
            if (point := px([goal])) is not None:
                cv2.drawMarker(image, tuple(point[0]), markers.colour(robot), cv2.MARKER_TILTED_CROSS, 18, 3)
        for robot, trail in markers.trails.items():
            points = px(trail)
            if points is None:
                continue
            colour = markers.colour(robot)
            if len(points) > 1:
                cv2.polylines(image, [points.reshape(-1, 1, 2)], False, colour, 2, cv2.LINE_AA)
            cv2.circle(image, tuple(points[-1]), 4, colour, -1, cv2.LINE_AA)
            _text(image, robot, points[-1] + (8, -8), colour, scale=0.5, outline=(255, 255, 255))
    _text(image, caption, (8, image.shape[0] - 10), scale=0.5)
    if markers.guidance is not None and geometry is not None:
        _text(image, 'red: leader move   cyan: advised follower move', (8, 18), scale=0.45)


def _draw_sgcm(image: np.ndarray, markers: _Markers, px) -> None:
    g = markers.guidance
    tables = [t for t in (markers.layout.tables if markers.layout is not None else ()) if t.rows * t.cols > 1]
    if g is None or not tables:
        return
    table = tables[0]
    if table.rows != g.state.rows or table.cols != g.state.cols:
        return
    colours = list(g.state.colours)
    counts = np.asarray(g.state.counts).reshape(g.state.rows * g.state.cols, max(1, len(colours)))
    width, depth = table.size[0] / table.cols, table.size[1] / table.rows
    for cell, cell_counts in enumerate(counts):
        text = ' '.join(f'{c[0]}{n}' for c, n in zip(colours, cell_counts) if n)
        x, y = table.cell_center(cell)
        if text and (point := px([(x - 0.42 * width, y + 0.3 * depth)])) is not None:   # the cell's top left
            _text(image, text, point[0], scale=0.4)
    for move, colour in ((g.leader_move, (0, 0, 255)), (g.recommended_follower_move, (255, 200, 0))):
        if move.empty:
            continue
        ends = px([table.cell_center(move.source_cell), table.cell_center(move.target_cell)])
        if ends is not None:
            cv2.arrowedLine(image, tuple(ends[0]), tuple(ends[1]), colour, 2, cv2.LINE_AA, tipLength=0.2)


def _caption(t: float, markers: _Markers) -> str:
    text = f't = {t:.2f} s'
    if markers.guidance is not None:
        text += f'   round {markers.guidance.round}'
    return text


class _Writer:
    """MP4 through OpenCV's VideoWriter or GIF frames collected for Pillow."""

    def __init__(self, path: Path, fmt: str, fps: float):
        if fmt not in FORMATS:
            raise ValueError(f'video format {fmt!r} (expected one of {", ".join(FORMATS)})')
        self.path, self.fmt, self.fps = Path(path), fmt, fps
        self.frames: list = []
        self.count = 0
        self.size: tuple[int, int] | None = None
        self._mp4 = None

    def write(self, bgr: np.ndarray) -> None:
        height, width = bgr.shape[:2]
        if self.size is None:
            self.size = (width, height)
            if self.fmt == 'mp4':
                self._mp4 = cv2.VideoWriter(str(self.path), cv2.VideoWriter_fourcc(*MP4_FOURCC), self.fps,
                                            (width, height))
                if not self._mp4.isOpened():
                    raise RuntimeError(f'OpenCV cannot write {MP4_FOURCC} MP4 to {self.path}')
        elif (width, height) != self.size:
            bgr = cv2.resize(bgr, self.size, interpolation=cv2.INTER_AREA)
        if self._mp4 is not None:
            self._mp4.write(bgr)
        else:
            from PIL import Image
            self.frames.append(Image.fromarray(bgr[..., ::-1]).convert('P', palette=Image.Palette.ADAPTIVE))
        self.count += 1

    def close(self) -> None:
        if self._mp4 is not None:
            self._mp4.release()
        elif self.frames:
            self.frames[0].save(self.path, save_all=True, append_images=self.frames[1:],
                                duration=max(20, int(round(1000 / self.fps))), loop=0, optimize=False)
            self.frames = []


def write_frames(frames: Iterable[np.ndarray], path: Path, fmt: str = 'mp4', fps: float = 4.0) -> VideoInfo:
    """Write RGB frames (H, W, 3 uint8) as a video; frames of another size are resized to the first's."""
    writer = _Writer(path, fmt, fps)
    try:
        for rgb in frames:
            writer.write(np.ascontiguousarray(rgb[..., ::-1]))
    finally:
        writer.close()
    width, height = writer.size or (0, 0)
    return VideoInfo(Path(path), writer.count, width, height, fps, '')


def export_video(bag: Path, summary: BagSummary, path: Path, fmt: str = 'mp4', speed: float = 4.0,
                 layout: SceneLayout | None = None) -> VideoInfo | None:
    """The bag's top-view camera as ``path`` (markers drawn), played ``speed`` times faster than
    simulated time; None when the bag has no camera frames."""
    topic = camera_topic(summary)
    if topic is None:
        return None
    camera_ns = topic.split('/image_raw')[0]
    stats = summary.topic(topic)
    recorded_hz = stats.rate_hz if stats.rate_hz > 0 else 1.0
    fps = float(min(30.0, max(1.0, round(recorded_hz * speed, 2))))
    wanted = {topic, f'{camera_ns}/camera_info', f'{camera_ns}/pose'}
    wanted |= {t.topic for t in summary.topics if t.type_name.split('/')[-1] in
               ('BodyStates', 'Guidance', 'RoleAssignment', 'AgentStatus')}
    markers = _Markers(layout)
    writer = _Writer(path, fmt, fps)
    try:
        for name, _ns, msg in read_messages(bag, sorted(wanted)):
            if name != topic:
                markers.update(name, msg, camera_ns)
                continue
            rgb = decode_rgb(msg.format, bytes(msg.data)) if hasattr(msg, 'format') else _raw_rgb(msg)
            scale = max(1.0, MIN_SIDE / min(rgb.shape[:2]))
            bgr = np.ascontiguousarray(rgb[..., ::-1])
            if scale > 1.0:
                bgr = cv2.resize(bgr, None, fx=scale, fy=scale, interpolation=cv2.INTER_LINEAR)
            _draw(bgr, markers, scale, _caption(_stamp(msg.header), markers))
            writer.write(bgr)
    finally:
        writer.close()
    if writer.count == 0:
        Path(path).unlink(missing_ok=True)
        return None
    width, height = writer.size
    return VideoInfo(Path(path), writer.count, width, height, fps, topic)


def read_video(path: Path) -> tuple[int, int, int]:
    """(frames, width, height) of a video as OpenCV reads it back (every frame decoded)."""
    capture = cv2.VideoCapture(str(path))
    try:
        frames, width, height = 0, 0, 0
        while True:
            ok, frame = capture.read()
            if not ok:
                break
            frames += 1
            height, width = frame.shape[:2]
        return frames, width, height
    finally:
        capture.release()
