"""What a scene holds, without the simulator: entity definitions and the simulated-entity interface.

A scenario section parses into *definitions* (:class:`EntityDefinition` subclasses: a dataclass
of what the file says plus its geometry, no pybullet), so every package can read a scenario
without the simulator. :class:`.scene.Scene` turns each definition into a *simulated entity*
(:class:`SceneEntity`: spawns bodies in a pybullet client and takes part in every physics step)
-- for the built-in kinds a subclass of the definition that lives in a simulating module, so a
simulated table is still a :class:`~.tabletop.Table`.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

#: Label of every pixel that shows no entity (ground plane, sky).
BACKGROUND_LABEL = 0


class EntityDefinition:
    """An entity as a scenario defines it: kind, unique name and where it was written."""

    kind: ClassVar[str]
    name: str
    #: Where the entity was written in the scenario, e.g. 'mobile_robots[1]' (for error messages).
    config_path: str = ''


class SceneEntity(EntityDefinition, ABC):
    """Something simulated in a scene (a robot, an obstacle, ...).

    The :class:`.scene.Scene` spawns it, assigns ``body_ids`` and ``label`` and calls the
    step hooks around every physics step. A section may return SceneEntity objects directly
    (the scene simulates a copy of each), or pure definitions with a simulated counterpart.
    """

    #: pybullet unique ids from the last spawn (first = main body); set by Scene.
    body_ids: list[int] = []
    #: Segmentation label (1..N); set by Scene.
    label: int = BACKGROUND_LABEL

    @abstractmethod
    def spawn(self, client: int) -> list[int]:
        """Create the entity's bodies in ``client``; return their unique ids, main body first.

        Called again after every reset, so it must also reset any runtime state.
        """

    def before_step(self, client: int, dt: float, sim_time: float) -> None:
        """Called before each physics step; ``sim_time`` is the time at its start."""

    def after_step(self, client: int, dt: float, sim_time: float) -> None:
        """Called after each physics step; ``sim_time`` is the time at its end."""

    @property
    def main_body(self) -> int:
        return self.body_ids[0]


@dataclass(frozen=True)
class BodyStateData:
    """Ground-truth state of an entity's main body, in the world frame."""

    name: str
    kind: str
    label: int
    position: tuple[float, float, float]
    orientation_xyzw: tuple[float, float, float, float]
    linear_velocity: tuple[float, float, float]
    angular_velocity: tuple[float, float, float]
