"""Colour tracking of the robots on the top-view image (``TrackPosition``, Algorithm 4 line 4).

Each robot is a disc of a known colour seen from above. Shading scales the brightness of
a colour but hardly its chromaticity ``rgb / (r + g + b)``, so pixels are matched by
chromaticity (within ``chroma_tolerance``) and by being bright enough for it to be
reliable. The robot's blob is the matching connected component nearest to the previous
position (or the largest one). Off the optical axis the camera also sees the side of
the robot facing it, so the blob is not the top disc alone: the position is the centre
of an upright cylinder of the robot's radius and height fitted to the blob's outline
(:meth:`ColorTracker._fit_cylinder`), which also ignores the notch of the dark heading
marker. The heading, when visible, points from the disc centre to the centroid of the
dark marker inside the disc.

:class:`TeamTracker` follows a whole team frame after frame (the robot_tracker node): each
robot's blob is searched near where it was last found, and its last seen heading is kept
while the marker is hidden.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from collab_tools.core.camera_geometry import TopViewGeometry

from .errors import RoleEngineError
from .top_view import check_rgb


@dataclass(frozen=True)
class TrackedTarget:
    """What to look for: a robot's name, colour (r, g, b in [0, 1]), radius and top height (m)."""

    name: str
    color: tuple[float, float, float]
    radius: float
    height: float = 0.0


@dataclass
class Observation:
    """One robot in one image. ``found`` False: nothing matched; the other fields are then NaN."""

    name: str
    found: bool
    position: tuple[float, float] = (math.nan, math.nan)
    heading: float | None = None
    pixel: tuple[float, float] = (math.nan, math.nan)
    area_px: int = 0


def chromaticity(rgb: np.ndarray) -> np.ndarray:
    rgb = np.asarray(rgb, dtype=float)
    return rgb / np.maximum(rgb.sum(axis=-1, keepdims=True), 1e-9)


class ColorTracker:
    """Finds every target in an RGB image and reports world positions (see module docstring)."""

    def __init__(self, targets: list[TrackedTarget], geometry: TopViewGeometry, *,
                 chroma_tolerance: float = 0.06, min_brightness: float = 60.0, min_area_px: int = 4):
        names = [t.name for t in targets]
        if len(set(names)) != len(names):
            raise RoleEngineError(f'tracker targets: names must be unique (got {names})')
        for target in targets:
            color = np.asarray(target.color, dtype=float)
            if color.shape != (3,) or not np.isfinite(color).all() or (color < 0).any() or (color > 1).any() \
                    or color.sum() <= 0:
                raise RoleEngineError(f'tracker target {target.name!r}.color: must be r g b in [0, 1], '
                                      f'not all zero (got {target.color})')
            if not (math.isfinite(target.radius) and target.radius > 0):
                raise RoleEngineError(f'tracker target {target.name!r}.radius: must be > 0 (got {target.radius})')
        self.targets = list(targets)
        self.geometry = geometry
        self.chroma_tolerance = chroma_tolerance
        self.min_brightness = min_brightness
        self.min_area_px = min_area_px

    def _mask(self, chroma: np.ndarray, bright: np.ndarray, target: TrackedTarget) -> np.ndarray:
        wanted = chromaticity(np.asarray(target.color))
        # Squared distance channel by channel: the same test as a norm over axis 2, ~10x faster.
        squared = sum((chroma[..., k] - wanted[k]) ** 2 for k in range(3))
        return (squared <= self.chroma_tolerance ** 2) & bright

    def track(self, rgb: np.ndarray, previous: dict[str, Observation] | None = None) -> dict[str, Observation]:
        """Observations of every target; a target not seen gets ``found=False``."""
        rgb = check_rgb(rgb)
        chroma = chromaticity(rgb)
        bright = rgb.astype(float).sum(axis=2) >= self.min_brightness
        observations = {}
        for target in self.targets:
            mask = self._mask(chroma, bright, target).astype(np.uint8)
            before = previous.get(target.name) if previous else None
            observations[target.name] = self._locate(mask, target, rgb, before)
        return observations

    def _locate(self, mask: np.ndarray, target: TrackedTarget, rgb: np.ndarray,
                before: Observation | None) -> Observation:
        count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
        candidates = [k for k in range(1, count) if stats[k, cv2.CC_STAT_AREA] >= self.min_area_px]
        if not candidates:
            return Observation(target.name, False)
        if before is not None and before.found:
            choice = min(candidates, key=lambda k: np.hypot(*(centroids[k] - np.asarray(before.pixel))))
        else:
            choice = max(candidates, key=lambda k: stats[k, cv2.CC_STAT_AREA])
        blob = (labels == choice).astype(np.uint8)
        contours, _ = cv2.findContours(blob, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        outline = np.vstack(contours).reshape(-1, 2).astype(float)
        # The enclosing circle's centre ignores the marker's hole or notch in the blob.
        (u, v), radius_px = cv2.minEnclosingCircle(outline.astype(np.float32))
        x, y = self._fit_cylinder(outline, (u, v), target)
        (u, v), = self.geometry.world_to_pixel(np.array([[x, y]]), z=target.height)
        heading = self._heading(rgb, (u, v), radius_px, target)
        return Observation(target.name, True, (float(x), float(y)), heading, (float(u), float(v)),
                           int(stats[choice, cv2.CC_STAT_AREA]))

    def _fit_cylinder(self, outline: np.ndarray, centre_px: tuple[float, float],
                      target: TrackedTarget) -> tuple[float, float]:
        """World centre of an upright cylinder whose silhouette has this outline.

        Seen from above off the optical axis, a robot's blob is its top disc plus the side
        facing the camera. Every outline pixel lies on the rim of the top disc (plane z =
        height) or of the bottom disc (z = 0); the centre is the point from which the
        back-projected outline lies at the known radius, each pixel on whichever rim it
        fits better (Gauss-Newton, outline pixels fitting neither, e.g. the marker's
        notch, are ignored).
        """
        top = self.geometry.pixel_to_world(outline, z=target.height)
        bottom = self.geometry.pixel_to_world(outline, z=0.0) if target.height > 0 else top
        centre = self.geometry.pixel_to_world(np.array([centre_px]), z=target.height / 2.0)[0]
        half_pixel = 0.5 * self.geometry.metres_per_pixel(target.height)
        # Outline pixels are the blob's boundary pixels, whose centres lie half a pixel inside its edge.
        radius = max(target.radius - half_pixel, half_pixel)
        for _ in range(10):
            offsets_top, offsets_bottom = top - centre, bottom - centre
            residual_top = np.hypot(*offsets_top.T) - radius
            residual_bottom = np.hypot(*offsets_bottom.T) - radius
            use_top = np.abs(residual_top) <= np.abs(residual_bottom)
            offsets = np.where(use_top[:, None], offsets_top, offsets_bottom)
            residual = np.where(use_top, residual_top, residual_bottom)
            keep = np.abs(residual) < 0.3 * radius + half_pixel
            if keep.sum() < 3:
                break
            norms = np.maximum(np.hypot(*offsets[keep].T), 1e-9)
            jacobian = -offsets[keep] / norms[:, None]
            step, *_ = np.linalg.lstsq(jacobian, -residual[keep], rcond=None)
            centre = centre + step
            if np.hypot(*step) < 1e-5:
                break
        return float(centre[0]), float(centre[1])

    def _heading(self, rgb: np.ndarray, centre: tuple[float, float], radius_px: float,
                 target: TrackedTarget) -> float | None:
        """Direction from the disc centre to the dark marker inside the disc, or None."""
        height, width = rgb.shape[:2]
        # Only the window around the disc can hold its marker (the whole image gives the same answer).
        reach = 0.95 * radius_px
        x0, x1 = max(0, math.floor(centre[0] - reach)), min(width, math.ceil(centre[0] + reach) + 1)
        y0, y1 = max(0, math.floor(centre[1] - reach)), min(height, math.ceil(centre[1] + reach) + 1)
        if x0 >= x1 or y0 >= y1:
            return None
        rows, cols = np.mgrid[y0:y1, x0:x1]
        inside = np.hypot(cols - centre[0], rows - centre[1]) <= reach
        dark = inside & (rgb[y0:y1, x0:x1].astype(float).sum(axis=2) < self.min_brightness)
        if not dark.any():
            return None
        rows, cols = np.nonzero(dark)
        marker = np.array([cols.mean() + x0, rows.mean() + y0])
        if np.hypot(*(marker - centre)) < 0.5:
            return None
        world = self.geometry.pixel_to_world(np.vstack([np.asarray(centre), marker]), z=target.height)
        dx, dy = world[1] - world[0]
        return float(math.atan2(dy, dx))


@dataclass(frozen=True)
class TrackingSettings:
    """The colour matching thresholds of :class:`ColorTracker` (the robot_tracker's parameters)."""

    chroma_tolerance: float = 0.06     # max chromaticity distance of a robot's pixel from its colour
    min_brightness: float = 60.0       # r + g + b (0..765) below which a pixel is too dark to match
    min_area_px: int = 4               # smallest blob taken for a robot

    def __post_init__(self) -> None:
        if not (math.isfinite(self.chroma_tolerance) and self.chroma_tolerance > 0.0):
            raise RoleEngineError(f'chroma_tolerance: must be > 0 (got {self.chroma_tolerance})')
        if not (math.isfinite(self.min_brightness) and 0.0 <= self.min_brightness <= 765.0):
            raise RoleEngineError(f'min_brightness: must be in [0, 765] (got {self.min_brightness})')
        if int(self.min_area_px) != self.min_area_px or self.min_area_px < 1:
            raise RoleEngineError(f'min_area_px: must be an integer >= 1 (got {self.min_area_px})')


@dataclass(frozen=True)
class TrackedPose:
    """A robot's planar pose in one frame; ``heading_seen`` False: the yaw is the last one seen."""

    name: str
    x: float
    y: float
    yaw: float
    heading_seen: bool


class TeamTracker:
    """Every robot of a team, frame after frame (module docstring).

    :meth:`update` returns the pose of each robot found in the frame whose heading has been seen
    at least once (a pose needs a yaw); a robot not found has no pose in that frame.
    """

    def __init__(self, targets: list[TrackedTarget], settings: TrackingSettings = TrackingSettings()):
        self.targets = list(targets)
        self.settings = settings
        ColorTracker(self.targets, None)          # validates the targets now, not at the first frame
        self.last_found: dict[str, Observation] = {}
        self.headings: dict[str, float] = {}

    def update(self, rgb: np.ndarray, geometry: TopViewGeometry) -> dict[str, TrackedPose]:
        s = self.settings
        tracker = ColorTracker(self.targets, geometry, chroma_tolerance=s.chroma_tolerance,
                               min_brightness=s.min_brightness, min_area_px=int(s.min_area_px))
        poses = {}
        for name, observation in tracker.track(rgb, self.last_found).items():
            if not observation.found:
                continue
            self.last_found[name] = observation
            if observation.heading is not None:
                self.headings[name] = observation.heading
            if name in self.headings:
                poses[name] = TrackedPose(name, *observation.position, self.headings[name],
                                          observation.heading is not None)
        return poses
