"""A small TF tree: collect parent -> child transforms and look up any frame in any other.

What a tf2 buffer does for one instant, without ROS: tools and tests that read ``/tf`` and
``/tf_static`` (from a bag or a subscription) add every transform and ask for
``lookup('world', 'robot_1/base_link')``. Each child has one parent (a later transform of the
same child replaces the earlier one, as a newer sample does in tf2); a lookup composes the
transforms along the tree path, through the common ancestor when neither frame is the other's
ancestor.

Transforms are (translation xyz, rotation quaternion xyzw): the pose of the child frame in the
parent frame, as ``geometry_msgs/TransformStamped`` carries it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

Vector = tuple[float, float, float]
Quaternion = tuple[float, float, float, float]


class TfLookupError(LookupError):
    """No path between the two frames (unknown frame or disconnected trees)."""


@dataclass(frozen=True)
class Pose:
    """A rigid transform: the pose of a child frame in its parent frame."""

    translation: Vector = (0.0, 0.0, 0.0)
    rotation: Quaternion = (0.0, 0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        values = (*self.translation, *self.rotation)
        if len(self.translation) != 3 or len(self.rotation) != 4 or not all(math.isfinite(v) for v in values):
            raise ValueError(f'transform: need 3 finite translation and 4 finite rotation values (got {values})')
        norm = math.sqrt(sum(q * q for q in self.rotation))
        if abs(norm - 1.0) > 1e-3:
            raise ValueError(f'transform: rotation must be a unit quaternion (norm {norm:.6f})')
        object.__setattr__(self, 'rotation', tuple(q / norm for q in self.rotation))
        object.__setattr__(self, 'translation', tuple(float(v) for v in self.translation))

    def compose(self, other: Pose) -> Pose:
        """self * other: `other` expressed in self's parent frame."""
        return Pose(add(self.translation, rotate(self.rotation, other.translation)),
                    multiply(self.rotation, other.rotation))

    def inverse(self) -> Pose:
        conjugate = (-self.rotation[0], -self.rotation[1], -self.rotation[2], self.rotation[3])
        moved = rotate(conjugate, self.translation)
        return Pose((-moved[0], -moved[1], -moved[2]), conjugate)

    def apply(self, point: Vector) -> Vector:
        """A point given in the child frame, in the parent frame."""
        return add(self.translation, rotate(self.rotation, point))


def multiply(a: Quaternion, b: Quaternion) -> Quaternion:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def rotate(q: Quaternion, v: Vector) -> Vector:
    x, y, z, w = multiply(multiply(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def add(a: Vector, b: Vector) -> Vector:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


class TfTree:
    """Frames joined by parent -> child transforms (one parent per child)."""

    def __init__(self) -> None:
        self._parent: dict[str, tuple[str, Pose]] = {}

    def add(self, parent: str, child: str, transform: Pose) -> None:
        if not parent or not child:
            raise ValueError(f'transform {parent!r} -> {child!r}: frame ids must not be empty')
        if parent == child:
            raise ValueError(f'transform {parent!r} -> {child!r}: a frame cannot be its own parent')
        if child in self._chain(parent):
            raise ValueError(f'transform {parent!r} -> {child!r}: would close a loop')
        self._parent[child] = (parent, transform)

    def frames(self) -> set[str]:
        return set(self._parent) | {parent for parent, _ in self._parent.values()}

    def parent_of(self, frame: str) -> str | None:
        entry = self._parent.get(frame)
        return None if entry is None else entry[0]

    def _chain(self, frame: str) -> list[str]:
        """frame, its parent, its grandparent, ... up to its root."""
        chain = [frame]
        while chain[-1] in self._parent:
            chain.append(self._parent[chain[-1]][0])
        return chain

    def _to_ancestor(self, frame: str, ancestor: str) -> Pose:
        """Pose of `frame` in `ancestor` (which is on frame's chain)."""
        pose = Pose()
        while frame != ancestor:
            parent, transform = self._parent[frame]
            pose = transform.compose(pose)
            frame = parent
        return pose

    def lookup(self, target: str, source: str) -> Pose:
        """Pose of frame `source` in frame `target` (tf2's lookupTransform(target, source))."""
        known = self.frames()
        for frame in (target, source):
            if frame not in known:
                raise TfLookupError(f"frame '{frame}' is not in the tree (frames: {', '.join(sorted(known))})")
        target_chain = self._chain(target)
        common = next((frame for frame in self._chain(source) if frame in target_chain), None)
        if common is None:
            raise TfLookupError(f"frames '{target}' and '{source}' are not connected "
                                f"(roots '{target_chain[-1]}' and '{self._chain(source)[-1]}')")
        return self._to_ancestor(target, common).inverse().compose(self._to_ancestor(source, common))
