"""Coalitions as markers: who helps whom with which information, and what the sensors see.

Built from the schema agents' ``<robot>/coalition`` statuses (AgentStatus: the coalitions each robot
is committed to and what its part uses), the robots' positions (``ground_truth/bodies``: a tool's
view, never a planner's) and the fiducial sensors' readings (``<robot>/fiducials``: field of view
and range) into plain :class:`~collab_tools.core.marker_specs.MarkerSpec` lists, published by the
visualiser node on ``markers/coalitions``. Messages are read by attribute only.

Marker namespaces: ``helps`` (a line from each helper to the leader it serves, in the coalition's
colour) and ``uses`` (the information it provides, at the line's middle), ``states`` (each robot's
state and coalition above it), ``fov`` (each fiducial sensor's field of view in its own frame, so
it turns with the robot) and ``seen`` (what the sensor detects).
"""
from __future__ import annotations

import math

from collab_tools.core.marker_specs import MarkerInput, MarkerSpec, fan, palette

#: AgentStatus.state names (the message's constants).
STATES = {0: 'IDLE', 1: 'HELPING', 2: 'SEARCHING', 3: 'NEGOTIATING', 4: 'COMMITTED', 5: 'COMPLETED', 6: 'FAILED'}
LINE_Z, TEXT_Z = 0.3, 0.6


def describe_use(use: str) -> str:
    """'information:F_R(X,robot_1)' -> 'F_R(X,robot_1)'; 'sensor:camera:F_G(X)' -> 'camera: F_G(X)'."""
    kind, _, rest = str(use).partition(':')
    if kind == 'information':
        return rest
    if kind in ('sensor', 'aimed_sensor'):
        sensor, _, what = rest.partition(':')
        return f'{sensor}: {what}' if what else sensor
    if kind == 'motor':
        schema, _, target = rest.partition(':')
        return f'{schema} ({target})' if target else schema
    return str(use)


def help_links(statuses: dict) -> list[tuple[str, str, str, list[str]]]:
    """(helper, leader, coalition id, what the helper's part uses) of every commitment to another robot."""
    links = []
    for robot, status in sorted(statuses.items()):
        for commitment in status.commitments:
            leader = str(commitment.leader)
            if leader and leader != robot:
                links.append((robot, leader, str(commitment.coalition_id), [describe_use(u) for u in commitment.uses]))
    return links


def coalition_markers(statuses: dict, positions: dict[str, tuple[float, float]], frame: str) -> list[MarkerSpec]:
    """Lines helper -> leader with the information it shares, and every robot's state."""
    coalitions = sorted({cid for _, _, cid, _ in help_links(statuses)} |
                        {str(s.coalition_id) for s in statuses.values() if s.coalition_id})
    colour_of = {cid: palette(i) for i, cid in enumerate(coalitions)}
    specs = []
    for index, (helper, leader, cid, uses) in enumerate(help_links(statuses)):
        if helper not in positions or leader not in positions:
            continue
        (x0, y0), (x1, y1) = positions[helper], positions[leader]
        colour = colour_of.get(cid, palette(index))
        specs.append(MarkerSpec('helps', index, 'arrow', frame, scale=(0.03, 0.08, 0.1), color=colour,
                                points=((x0, y0, LINE_Z), (x1, y1, LINE_Z))))
        # halves first: the middle of two finite positions is finite (1e308 + 1e308 is not)
        specs.append(MarkerSpec('uses', index, 'text', frame, position=(x0 / 2 + x1 / 2, y0 / 2 + y1 / 2, LINE_Z + 0.1),
                                scale=(0, 0, 0.1), color=colour, text=', '.join(uses) or cid))
    for index, (robot, status) in enumerate(sorted(statuses.items())):
        if robot not in positions:
            continue
        x, y = positions[robot]
        state = STATES.get(int(status.state), str(status.state))
        text = f'{robot}: {state}' + (f' [{status.coalition_id}]' if status.coalition_id else '')
        specs.append(MarkerSpec('states', index, 'text', frame, position=(x, y, TEXT_Z), scale=(0, 0, 0.12),
                                color=colour_of.get(str(status.coalition_id), (1.0, 1.0, 1.0, 1.0)), text=text))
    return specs


def fov_markers(readings: dict, index_of: dict[str, int]) -> list[MarkerSpec]:
    """Each fiducial sensor's field of view (a translucent wedge) and its detections, in its own frame."""
    specs = []
    for topic, msg in sorted(readings.items()):
        frame = str(msg.header.frame_id)
        if not frame:
            raise ValueError(f'{topic}.header.frame_id: empty')
        index = index_of.setdefault(topic, len(index_of))
        r, g, b, _ = palette(index)
        wedge = fan(float(msg.max_range), float(msg.field_of_view), z=0.05)
        if wedge:
            specs.append(MarkerSpec('fov', index, 'triangle_list', frame, scale=(1, 1, 1), color=(r, g, b, 0.2),
                                    points=wedge))
        seen = tuple((float(d.x), float(d.y), 0.1) for d in msg.detections
                     if math.isfinite(float(d.x)) and math.isfinite(float(d.y)))
        if seen:
            specs.append(MarkerSpec('seen', index, 'sphere_list', frame, scale=(0.1, 0.1, 0.1), color=(r, g, b, 0.9),
                                    points=seen))
    return specs


class CoalitionMarkers:
    """The visualiser's coalition source (collab_tools.core.marker_specs)."""

    INPUTS = (MarkerInput(None, 'coalition_interfaces/msg/AgentStatus', 'latched', 'on_status'),
              MarkerInput(None, 'bridge_interfaces/msg/FiducialDetections', 'sensor', 'on_fiducials', redraw=False),
              MarkerInput('ground_truth/bodies', 'bridge_interfaces/msg/BodyStates', 'latched', 'on_bodies',
                          redraw=False))
    time_dependent = True  # the robots move: the lines between them follow at the visualiser's rate

    def __init__(self, world_frame: str = 'world'):
        self.frame = world_frame
        self.statuses: dict[str, object] = {}
        self.positions: dict[str, tuple[float, float]] = {}
        self.readings: dict[str, object] = {}
        self._fov_index: dict[str, int] = {}

    def on_status(self, msg, topic: str = '') -> None:
        if not msg.robot:
            raise ValueError(f'{topic}.robot: empty')
        self.statuses[str(msg.robot)] = msg

    def on_bodies(self, msg, topic: str = '') -> None:
        positions = {}
        for body in msg.bodies:
            x, y = float(body.pose.position.x), float(body.pose.position.y)
            if math.isfinite(x) and math.isfinite(y):
                positions[str(body.name)] = (x, y)
        self.positions = positions

    def on_fiducials(self, msg, topic: str = '') -> None:
        float(msg.max_range), float(msg.field_of_view)
        self.readings[topic or str(msg.header.frame_id)] = msg

    def markers(self, now: float = 0.0) -> list[MarkerSpec] | None:
        if not self.statuses and not self.readings:
            return None
        return coalition_markers(self.statuses, self.positions, self.frame) + fov_markers(self.readings,
                                                                                          self._fov_index)
