"""The simulated world: one private pybullet client holding a scenario's entities.

The scene turns each entity definition of the scenario into its simulated counterpart
(:data:`SIMULATED_KINDS`; a section that returns :class:`SceneEntity` objects itself gets a
copy of each), spawns them, labels their bodies for segmentation and steps the physics. The camera's renderer
(:mod:`.renderer`: the EGL plugin or TinyRenderer) is chosen once per scene, when it connects.
"""
from __future__ import annotations

import copy
import dataclasses
import os
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import pybullet as p
import pybullet_data

from .arm.definition import Arm
from .arm.simulation import SimulatedArm
from .camera import TopViewCamera
from .entity import BACKGROUND_LABEL, BodyStateData, EntityDefinition, SceneEntity
from .mobile_robot import MobileRobot
from .mobile_robot_body import SimulatedMobileRobot
from .obstacles import WallSet
from .passive_bodies import PASSIVE_BODIES
from .renderer import TINY, RendererChoice, choose_renderer
from .scenario import Scenario

__all__ = ['BACKGROUND_LABEL', 'SIMULATED_KINDS', 'BodyStateData', 'CameraFrame', 'Scene', 'SceneEntity',
           'simulated_entity']

#: The simulated class of every built-in definition.
SIMULATED_KINDS: dict[type, type[SceneEntity]] = {
    **PASSIVE_BODIES, MobileRobot: SimulatedMobileRobot, Arm: SimulatedArm,
}


def simulated_entity(definition: EntityDefinition) -> SceneEntity:
    """A fresh simulated entity for ``definition`` (which stays untouched: scenarios are shared specs)."""
    if isinstance(definition, SceneEntity):
        return copy.deepcopy(definition)
    simulated_class = SIMULATED_KINDS.get(type(definition))
    if simulated_class is None:
        raise TypeError(f"no simulation for {type(definition).__name__} '{definition.name}' "
                        '(a section must return SceneEntity objects or definitions of a built-in kind)')
    values = {f.name: copy.deepcopy(getattr(definition, f.name)) for f in dataclasses.fields(definition) if f.init}
    return simulated_class(**values)


EntityT = TypeVar('EntityT')


@dataclass(frozen=True)
class CameraFrame:
    """One top-view image and its per-pixel entity labels."""

    sim_time: float
    rgb: np.ndarray     # (H, W, 3) uint8
    labels: np.ndarray  # (H, W) uint16, BACKGROUND_LABEL where no entity is seen


class Scene:
    """A running simulation of one scenario in its own pybullet DIRECT client."""

    def __init__(self, scenario: Scenario, renderer: str = TINY):
        """renderer: core.renderer's tiny (the reference), egl or auto."""
        # Never the default client: several scenes (e.g. parallel tests) must not share state.
        self.client = p.connect(p.DIRECT)
        if self.client < 0:
            raise RuntimeError('could not start a pybullet DIRECT client')
        try:  # the plugin must be there before the first body
            self.renderer: RendererChoice = choose_renderer(renderer, self._load_plugin)
        except Exception:
            self.close()
            raise
        self.scenario = scenario
        self.entities: list[SceneEntity] = []
        self._label_of_body = np.zeros(0, dtype=np.uint16)
        self._build(scenario, self._fresh_entities(scenario))

    # -- construction -------------------------------------------------------

    def _load_plugin(self, path: str) -> int:
        return p.loadPlugin(path, '_eglRendererPlugin', physicsClientId=self.client)

    @staticmethod
    def _fresh_entities(scenario: Scenario) -> list[SceneEntity]:
        # Fresh entities keep the Scenario an immutable spec that several scenes may share.
        walls = [] if scenario.world.walls is None else [WallSet.around(scenario.world)]
        return [simulated_entity(definition) for definition in walls + scenario.entities()]

    def _build(self, scenario: Scenario, entities: list[SceneEntity]) -> None:
        client = self.client
        p.resetSimulation(physicsClientId=client)
        world = scenario.world
        p.setGravity(0.0, 0.0, world.gravity, physicsClientId=client)
        p.setPhysicsEngineParameter(fixedTimeStep=world.physics_dt, numSubSteps=0,
                                    deterministicOverlappingPairs=1, physicsClientId=client)
        self._plane = p.loadURDF(os.path.join(pybullet_data.getDataPath(), 'plane.urdf'),
                                 physicsClientId=client)
        self.scenario = scenario
        self.physics_dt = world.physics_dt
        self.step_count = 0
        self.frames_rendered = 0
        self.camera = TopViewCamera(scenario.camera)
        self.entities = entities
        self._by_name = {entity.name: entity for entity in entities}
        body_labels: dict[int, int] = {}
        for label, entity in enumerate(entities, start=1):
            body_ids = [int(body) for body in entity.spawn(client)]
            if not body_ids:
                raise RuntimeError(f"entity '{entity.name}' spawned no body")
            entity.body_ids = body_ids
            entity.label = label
            for body in body_ids:
                body_labels[body] = label
        lookup = np.full(max(body_labels, default=self._plane) + 1, BACKGROUND_LABEL, dtype=np.uint16)
        for body, label in body_labels.items():
            lookup[body] = label
        self._label_of_body = lookup

    def reset(self, scenario: Scenario | None = None) -> None:
        """Rebuild the world at sim_time 0.

        Without ``scenario`` the same entity objects are re-spawned (references
        held by callers stay valid, their runtime state is reset); with a new
        scenario, new entities replace the old ones.
        """
        if scenario is None:
            self._build(self.scenario, self.entities)
        else:
            self._build(scenario, self._fresh_entities(scenario))

    def close(self) -> None:
        if self.client >= 0:
            p.disconnect(physicsClientId=self.client)
            self.client = -1

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # -- queries --------------------------------------------------------------

    @property
    def sim_time(self) -> float:
        """Simulated seconds since the last build (exact multiple of physics_dt)."""
        return self.step_count * self.physics_dt

    def entity(self, name: str) -> SceneEntity:
        try:
            return self._by_name[name]
        except KeyError:
            raise KeyError(f"no entity named '{name}' (known: {', '.join(self._by_name)})") from None

    def entities_of(self, kind_cls: type[EntityT]) -> list[EntityT]:
        return [entity for entity in self.entities if isinstance(entity, kind_cls)]

    def label_legend(self) -> list[tuple[int, str, str]]:
        """(label, name, kind) of every entity; label 0 is the background."""
        return [(entity.label, entity.name, entity.kind) for entity in self.entities]

    @property
    def body_label_lookup(self) -> np.ndarray:
        """uint16 array indexed by pybullet body id giving the entity label (0 = none)."""
        return self._label_of_body

    def label_of_body(self, body_id: int) -> int:
        if 0 <= body_id < len(self._label_of_body):
            return int(self._label_of_body[body_id])
        return BACKGROUND_LABEL

    def body_pose(self, body_id: int) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        """World position and xyzw orientation of a body's base."""
        return p.getBasePositionAndOrientation(body_id, physicsClientId=self.client)

    def body_states(self) -> list[BodyStateData]:
        """Ground truth of every entity's main body, in entity order."""
        states = []
        for entity in self.entities:
            body = entity.body_ids[0]
            position, orientation = p.getBasePositionAndOrientation(body, physicsClientId=self.client)
            linear, angular = p.getBaseVelocity(body, physicsClientId=self.client)
            states.append(BodyStateData(
                name=entity.name, kind=entity.kind, label=entity.label,
                position=tuple(position), orientation_xyzw=tuple(orientation),
                linear_velocity=tuple(linear), angular_velocity=tuple(angular)))
        return states

    # -- simulation -----------------------------------------------------------

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps, calling every entity's hooks around each."""
        dt = self.physics_dt
        for _ in range(n):
            start = self.sim_time
            for entity in self.entities:
                entity.before_step(self.client, dt, start)
            p.stepSimulation(physicsClientId=self.client)
            self.step_count += 1
            end = self.sim_time
            for entity in self.entities:
                entity.after_step(self.client, dt, end)

    def render(self) -> CameraFrame:
        """The camera's frame of the current state (counted in ``frames_rendered``)."""
        self.frames_rendered += 1
        rgb, labels = self.camera.render(self.client, self._label_of_body)
        return CameraFrame(sim_time=self.sim_time, rgb=rgb, labels=labels)
