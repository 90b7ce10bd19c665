"""Markers as plain data: what a visualisation shows, built without ROS.

Each subsystem's core turns its own messages into :class:`MarkerSpec` lists (``sgcm.core.markers``,
``role_engine.core.markers``, ``coalition_agents.core.markers``); the visualiser node
(``collab_tools.visualiser_node``) converts them into ``visualization_msgs/MarkerArray`` one to one
(``collab_tools.markers_ros``). A builder reads messages by attribute only, so it works on the ROS
messages and on plain stand-ins in unit tests.

A subsystem exposes a *marker source* (see :class:`MarkerInput`): the topics it reads, the
handlers that take their messages, and ``markers(now)`` for the current picture. Sources are
listed by name in :data:`MARKER_SOURCES` and imported only when the visualiser is asked for them,
so this package does not depend on the subsystems.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

#: visualization_msgs/Marker types by name (the message's constants).
KINDS = {'arrow': 0, 'cube': 1, 'sphere': 2, 'cylinder': 3, 'line_strip': 4, 'line_list': 5,
         'cube_list': 6, 'sphere_list': 7, 'points': 8, 'text': 9, 'triangle_list': 11}

#: Marker sources the visualiser knows: name -> 'module:Class' (imported on demand). The name is
#: also the output topic, ``markers/<name>``, relative to the visualiser's namespace.
MARKER_SOURCES = {
    'sgcm': 'sgcm.core.markers:SgcmMarkers',
    'roles': 'role_engine.core.markers:RoleMarkers',
    'coalitions': 'coalition_agents.core.markers:CoalitionMarkers',
}

Colour = tuple[float, float, float, float]
Point = tuple[float, float, float]

#: Colours for things that have none of their own (cycled by index).
PALETTE: tuple[Colour, ...] = (
    (0.12, 0.47, 0.71, 1.0), (1.0, 0.5, 0.05, 1.0), (0.17, 0.63, 0.17, 1.0), (0.84, 0.15, 0.16, 1.0),
    (0.58, 0.4, 0.74, 1.0), (0.55, 0.34, 0.29, 1.0), (0.89, 0.47, 0.76, 1.0), (0.5, 0.5, 0.5, 1.0),
)
WHITE: Colour = (1.0, 1.0, 1.0, 1.0)


def palette(index: int, alpha: float = 1.0) -> Colour:
    r, g, b, _ = PALETTE[index % len(PALETTE)]
    return (r, g, b, alpha)


def rgba(rgb: Sequence[float], alpha: float = 1.0) -> Colour:
    """An (r, g, b[, a]) in [0, 1] as a colour with ``alpha``; out-of-range parts are clipped."""
    parts = [min(max(float(c), 0.0), 1.0) if math.isfinite(float(c)) else 0.0 for c in list(rgb)[:3]]
    while len(parts) < 3:
        parts.append(0.0)
    return (parts[0], parts[1], parts[2], alpha)


def finite(*values: float) -> bool:
    try:
        return all(math.isfinite(float(v)) for v in values)
    except (TypeError, ValueError):
        return False


@dataclass(frozen=True)
class MarkerSpec:
    """One visualization_msgs/Marker: ``kind`` (a key of :data:`KINDS`) in ``frame``.

    ``position``/``yaw`` place the marker (lists and lines: their points are in the frame as
    given); ``scale`` as the Marker message means it (a line's width is ``scale[0]``, a text's
    height ``scale[2]``); ``colors`` one per point where given.
    """

    ns: str
    id: int
    kind: str
    frame: str
    position: Point = (0.0, 0.0, 0.0)
    yaw: float = 0.0
    scale: Point = (0.05, 0.05, 0.05)
    color: Colour = WHITE
    points: tuple[Point, ...] = ()
    colors: tuple[Colour, ...] = ()
    text: str = ''

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f'marker {self.ns}/{self.id}: kind {self.kind!r} is not one of {", ".join(KINDS)}')
        if not self.frame:
            raise ValueError(f'marker {self.ns}/{self.id}: frame must not be empty')
        if self.colors and len(self.colors) != len(self.points):
            raise ValueError(f'marker {self.ns}/{self.id}: {len(self.colors)} colors for {len(self.points)} points')
        numbers = [*self.position, self.yaw, *self.scale, *self.color]
        numbers += [c for p in self.points for c in p] + [c for col in self.colors for c in col]
        if not finite(*numbers):
            raise ValueError(f'marker {self.ns}/{self.id}: non-finite number')


@dataclass(frozen=True)
class MarkerInput:
    """A topic a marker source reads.

    ``topic``: relative to the visualiser's namespace; None = every topic of ``type_name`` found in
    that namespace (per-robot topics, e.g. ``<robot>/coalition``). ``qos``: 'latched', 'reliable'
    or 'sensor' (the visualiser's subscription; 'sensor' accepts best-effort publishers).
    ``handler``: the source's method that takes ``(message, topic)``.
    ``publisher_parameter``: a parameter of the topic's publishing node the source needs
    (``source.set_parameter(name, value)`` once it is read), e.g. the SGCM leader's ``task_file``.
    ``redraw``: publish the picture after each message; False for fast inputs (poses, sensors) of a
    ``time_dependent`` source, whose picture is published at the visualiser's rate instead.
    """

    topic: str | None
    type_name: str
    qos: str
    handler: str
    publisher_parameter: str | None = None
    redraw: bool = True

    def __post_init__(self):
        if self.qos not in ('latched', 'reliable', 'sensor'):
            raise ValueError(f'marker input {self.topic or self.type_name}: qos {self.qos!r} is not '
                             'latched, reliable or sensor')


def line_list(pairs: Iterable[tuple[Point, Point]]) -> tuple[Point, ...]:
    """The points of a line_list marker from (start, end) pairs, skipping non-finite ones."""
    points: list[Point] = []
    for start, end in pairs:
        if finite(*start, *end):
            points.extend((tuple(map(float, start)), tuple(map(float, end))))
    return tuple(points)


def fan(radius: float, opening: float, segments: int = 16, z: float = 0.0) -> tuple[Point, ...]:
    """A triangle_list wedge (circle sector) at the origin, centred on +x, ``opening`` rad wide."""
    if not finite(radius, opening) or radius <= 0 or opening <= 0:
        return ()
    opening = min(opening, 2 * math.pi)
    points: list[Point] = []
    for k in range(segments):
        a0 = -opening / 2 + opening * k / segments
        a1 = -opening / 2 + opening * (k + 1) / segments
        points += [(0.0, 0.0, z), (radius * math.cos(a0), radius * math.sin(a0), z),
                   (radius * math.cos(a1), radius * math.sin(a1), z)]
    return tuple(points)
