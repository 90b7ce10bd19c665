"""The pybullet bodies of the passive scenario entities: obstacles, walls, tables, cubes, targets,
movable boxes.

Each class is its definition (:mod:`.obstacles`, :mod:`.tabletop`, :mod:`.targets`,
:mod:`.movable_boxes`) plus ``spawn``; none of them acts during a step.
"""
from __future__ import annotations

import pybullet as p

from .entity import SceneEntity
from .movable_boxes import MovableBox
from .obstacles import WALL_COLOR, BoxObstacle, WallSet
from .tabletop import Cube, Table
from .targets import Target

#: Grid lines float this far above the table top: visible, yet below any cube's top.
GRID_LINE_LIFT = 0.0005           # m
GRID_LINE_THICKNESS = 0.001       # m
# Contact parameters of cubes: wood-like friction, no bounce, so a cube set down settles at once.
CUBE_LATERAL_FRICTION = 0.8
CUBE_SPINNING_FRICTION = 0.001
CUBE_ROLLING_FRICTION = 0.0001


def _spawn_static_box(client: int, center_xy: tuple[float, float], size_xy: tuple[float, float],
                      height: float, yaw: float, color: tuple[float, float, float]) -> int:
    half_extents = [size_xy[0] / 2.0, size_xy[1] / 2.0, height / 2.0]
    collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half_extents, physicsClientId=client)
    visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half_extents, rgbaColor=[*color, 1.0],
                                 physicsClientId=client)
    return p.createMultiBody(
        baseMass=0.0, baseCollisionShapeIndex=collision, baseVisualShapeIndex=visual,
        basePosition=[center_xy[0], center_xy[1], height / 2.0],
        baseOrientation=p.getQuaternionFromEuler([0.0, 0.0, yaw]), physicsClientId=client)


class SimulatedBoxObstacle(BoxObstacle, SceneEntity):
    """A static (mass 0) box standing on the ground."""

    def spawn(self, client: int) -> list[int]:
        return [_spawn_static_box(client, self.center, self.size, self.height, self.yaw, self.color)]


class SimulatedWallSet(WallSet, SceneEntity):
    """Four static walls just outside ``world.bounds``."""

    def spawn(self, client: int) -> list[int]:
        return [_spawn_static_box(client, center, size, self.wall_height, 0.0, WALL_COLOR)
                for center, size in self.wall_boxes()]


class SimulatedTable(Table, SceneEntity):
    """A static block with its grid drawn as visual-only links."""

    def spawn(self, client: int) -> list[int]:
        half = [self.size[0] / 2.0, self.size[1] / 2.0, self.height / 2.0]
        collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=[*self.color, 1.0],
                                     physicsClientId=client)
        # Grid lines are links without collision shapes: seen by the camera (with the
        # table's label), invisible to physics.
        link_visuals, link_positions = [], []
        for (x, y), (sx, sy) in self.grid_lines():
            link_visuals.append(p.createVisualShape(
                p.GEOM_BOX, halfExtents=[sx / 2.0, sy / 2.0, GRID_LINE_THICKNESS / 2.0],
                rgbaColor=[*self.grid.color, 1.0], physicsClientId=client))
            link_positions.append([x - self.center[0], y - self.center[1],
                                   self.height / 2.0 + GRID_LINE_LIFT + GRID_LINE_THICKNESS / 2.0])
        count = len(link_visuals)
        body = p.createMultiBody(
            baseMass=0.0, baseCollisionShapeIndex=collision, baseVisualShapeIndex=visual,
            basePosition=[self.center[0], self.center[1], self.height / 2.0],
            linkMasses=[0.0] * count, linkCollisionShapeIndices=[-1] * count,
            linkVisualShapeIndices=link_visuals, linkPositions=link_positions,
            linkOrientations=[[0, 0, 0, 1]] * count, linkInertialFramePositions=[[0, 0, 0]] * count,
            linkInertialFrameOrientations=[[0, 0, 0, 1]] * count, linkParentIndices=[0] * count,
            linkJointTypes=[p.JOINT_FIXED] * count, linkJointAxis=[[0, 0, 1]] * count,
            physicsClientId=client)
        return [body]


class SimulatedCube(Cube, SceneEntity):
    """A dynamic cube with wood-like contact parameters."""

    def spawn(self, client: int) -> list[int]:
        half = [self.edge / 2.0] * 3
        collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=[*self.color, 1.0],
                                     physicsClientId=client)
        body = p.createMultiBody(
            baseMass=self.mass, baseCollisionShapeIndex=collision, baseVisualShapeIndex=visual,
            basePosition=[*self.position, self.initial_z],
            baseOrientation=p.getQuaternionFromEuler([0.0, 0.0, self.yaw]), physicsClientId=client)
        p.changeDynamics(body, -1, lateralFriction=CUBE_LATERAL_FRICTION,
                         spinningFriction=CUBE_SPINNING_FRICTION, rollingFriction=CUBE_ROLLING_FRICTION,
                         restitution=0.0, physicsClientId=client)
        return [body]


class SimulatedTarget(Target, SceneEntity):
    """An upright cylinder, static or pushable."""

    def spawn(self, client: int) -> list[int]:
        collision = p.createCollisionShape(p.GEOM_CYLINDER, radius=self.radius, height=self.height,
                                           physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_CYLINDER, radius=self.radius, length=self.height,
                                     rgbaColor=[*self.color, 1.0], physicsClientId=client)
        return [p.createMultiBody(baseMass=self.mass, baseCollisionShapeIndex=collision,
                                  baseVisualShapeIndex=visual,
                                  basePosition=[*self.position, self.height / 2.0], physicsClientId=client)]


class SimulatedMovableBox(MovableBox, SceneEntity):
    """A dynamic box with the scenario's ground friction."""

    def spawn(self, client: int) -> list[int]:
        half_extents = [self.size[0] / 2.0, self.size[1] / 2.0, self.height / 2.0]
        collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half_extents, physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half_extents, rgbaColor=[*self.color, 1.0],
                                     physicsClientId=client)
        body = p.createMultiBody(
            baseMass=self.mass, baseCollisionShapeIndex=collision, baseVisualShapeIndex=visual,
            basePosition=[*self.center, self.height / 2.0],
            baseOrientation=p.getQuaternionFromEuler([0.0, 0.0, self.yaw]), physicsClientId=client)
        p.changeDynamics(body, -1, lateralFriction=self.friction, restitution=0.0, physicsClientId=client)
        return [body]


#: The simulated class of each passive definition (the scene looks them up).
PASSIVE_BODIES: dict[type, type[SceneEntity]] = {
    BoxObstacle: SimulatedBoxObstacle, WallSet: SimulatedWallSet, Table: SimulatedTable, Cube: SimulatedCube,
    Target: SimulatedTarget, MovableBox: SimulatedMovableBox,
}
