"""Checking a pick-and-place request against the scene, and choosing where the object goes.

A request names a cube and a place region [xmin, ymin, xmax, ymax]. It is rejected, with a
message saying why, when the object is unknown, not a cube, too big for the gripper, not
resting, out of reach, or when the region is empty, out of reach, smaller than the object's
footprint or outside the camera view. Where to put the object is decided once, when the task
starts and the arm is still at home (it does not hide the table then): a label image is
rendered through the scene's camera and :func:`..placement.find_place_position` runs the
paper's pixel test on it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, TypeVar

import numpy as np
from collab_tools.core.fields import check_vector

from ..entity import BACKGROUND_LABEL, SceneEntity
from ..mobile_robot import yaw_of
from ..placement import PixelCamera, find_place_position, meters_to_pixels, region_to_pixels
from ..tabletop import Cube, Table
from .definition import Arm
from .task import PickPlaceTask

#: Height of the approach / travel poses above the grasp and place poses (m).
CLEARANCE_HEIGHT = 0.10
#: Gap left under the object when it is set down, so it never hits the table while moving (m).
DROP_GAP = 0.003
#: Gap between a flange and the top of the cube it holds (m); the flange also hovers this
#: far above neighbouring cubes of the same size while it grasps or sets one down.
FLANGE_GAP = 0.004
#: An object whose centre is this close to a resting height counts as resting (m).
RESTING_TOLERANCE = 0.01

EntityT = TypeVar('EntityT')


class ArmCamera(PixelCamera, Protocol):
    """The camera a request is checked against (:class:`..camera.TopViewCamera` is one)."""

    def ground_footprint(self) -> tuple[float, float, float, float]: ...


class ArmScene(Protocol):
    """What an arm's task needs from the scene (:class:`..scene.Scene` is one)."""

    sim_time: float
    camera: ArmCamera
    entities: list[SceneEntity]

    def entity(self, name: str) -> SceneEntity: ...

    def entities_of(self, kind_cls: type[EntityT]) -> list[EntityT]: ...

    def body_pose(self, body_id: int) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]: ...

    def render(self): ...


@dataclass(frozen=True)
class PickPlaceRequest:
    """A checked pick-and-place request: where the object is and where it may go."""

    cube: Cube
    center: np.ndarray            # object centre now (world)
    yaw: float                    # object yaw now (rad)
    grasp_height: float           # tool point above the object's centre at the grasp (m)
    region: tuple[float, float, float, float]
    place_table: Table | None     # surface under the region's centre; None = the ground
    support_height: float         # its height (m)
    place_center_z: float         # object centre height when it is let go (m)
    half_extent: float            # half side of the footprint tested in the image, clearance included (m)


def check_request(arm: Arm, scene: ArmScene, task: PickPlaceTask) -> PickPlaceRequest | str:
    """The request's geometry, or why it cannot be done."""
    cubes = ', '.join(entity.name for entity in scene.entities_of(Cube)) or 'none'
    try:
        cube = scene.entity(task.object_name)
    except KeyError:
        return f"unknown object '{task.object_name}' (cubes in the scene: {cubes})"
    if not isinstance(cube, Cube):
        return (f"'{task.object_name}' is a {cube.kind}, not a cube; only cubes can be picked "
                f'(cubes: {cubes})')
    try:
        region = check_vector(list(task.region), 'place_region', 4)
    except ValueError as error:
        return f'{error}: [xmin, ymin, xmax, ymax] in metres'
    xmin, ymin, xmax, ymax = region
    if not (xmin < xmax and ymin < ymax):
        return (f'place_region {list(region)} is empty: need xmin < xmax and ymin < ymax '
                '([xmin, ymin, xmax, ymax] in metres)')
    if cube.edge > arm.model.max_cube_edge:
        return (f"cube '{cube.name}' (edge {cube.edge} m) does not fit the {arm.model.name} gripper "
                f'(at most {arm.model.max_cube_edge:.3f} m)')

    position, orientation = scene.body_pose(cube.body_ids[0])
    center = np.array(position)
    tables = scene.entities_of(Table)
    if resting_height(tables, cube, center) is None:
        return (f"object '{cube.name}' is not resting on a table or the ground (centre at z "
                f'{center[2]:.3f} m); another arm may be holding it')
    grasp_height = (cube.edge / 2.0 + FLANGE_GAP) if arm.model.grasps_from_top else 0.0
    problem = arm.reach_problem(f"object '{cube.name}'", center[0], center[1], center[2] + grasp_height)
    if problem:
        return problem

    place_table = next((t for t in tables if t.contains((xmin + xmax) / 2.0, (ymin + ymax) / 2.0)), None)
    support_height = place_table.height if place_table else 0.0
    place_center_z = support_height + cube.edge / 2.0 + DROP_GAP
    for corner_x, corner_y in ((xmin, ymin), (xmin, ymax), (xmax, ymin), (xmax, ymax)):
        problem = arm.reach_problem('place_region corner', corner_x, corner_y,
                                    place_center_z + grasp_height)
        if problem:
            return problem

    # The object keeps its yaw, so its footprint is the bounding box of the turned square.
    object_yaw = yaw_of(orientation)
    half_extent = cube.edge / 2.0 * (abs(math.cos(object_yaw)) + abs(math.sin(object_yaw)))
    half_extent += arm.placement_clearance
    if 2.0 * half_extent > min(xmax - xmin, ymax - ymin):
        return (f"place_region {list(region)} is smaller than the footprint of '{cube.name}' "
                f'({2 * half_extent:.3f} m with {arm.placement_clearance} m clearance)')
    camera = scene.camera
    if region_to_pixels(camera, region, support_height) is None:
        return f'place_region {list(region)} is outside the camera view {list(camera.ground_footprint())}'
    if meters_to_pixels(camera, 2.0 * half_extent, support_height) < 1.0:
        return 'the camera resolution is too coarse for the pixel test (footprint below one pixel)'
    return PickPlaceRequest(cube=cube, center=center, yaw=object_yaw, grasp_height=grasp_height,
                            region=tuple(region), place_table=place_table, support_height=support_height,
                            place_center_z=place_center_z, half_extent=half_extent)


def choose_place_spot(scene: ArmScene, request: PickPlaceRequest) -> tuple[float, float] | None:
    """Centre for the object in the region, from a label image taken now (the arm is at home)."""
    labels = scene.render().labels
    # Not obstacles: the object itself, the arms, and the surface it will stand on.
    free = {request.cube.label} | {arm.label for arm in scene.entities_of(Arm)}
    every = {BACKGROUND_LABEL} | {entity.label for entity in scene.entities}
    free.add(request.place_table.label if request.place_table is not None else BACKGROUND_LABEL)
    return find_place_position(scene.camera, labels, every - free, request.region, request.half_extent,
                               request.support_height)


def resting_height(tables: list[Table], cube: Cube, center: np.ndarray) -> float | None:
    """Height of the surface the cube rests on, or None if it is not resting."""
    for table in tables:
        if table.contains(center[0], center[1]) and abs(center[2] - table.height - cube.edge / 2.0) \
                < RESTING_TOLERANCE:
            return table.height
    if abs(center[2] - cube.edge / 2.0) < RESTING_TOLERANCE:
        return 0.0
    return None
