"""The one backend interface: a physics engine, its config locked at construction, runs a prepared batch.

Every backend takes the same :class:`~rail_mj.imagination.batch.RolloutBatch` and returns the same
:class:`~rail_mj.core.types.Outcomes`; it composes its own scene of the object (native: hull meshes; mjx: the
hull-box bucket) with :mod:`rail_mj.mjcf`. Backends are chosen and shared by name in
:mod:`rail_mj.imagination.registry`.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from typing import ClassVar

from rail_mj.core.errors import ImaginationError, SceneError
from rail_mj.core.types import AgentSetup, Outcomes, RailObject
from rail_mj.imagination.batch import RolloutBatch
from rail_mj.imagination.config import ImaginationConfig
from rail_mj.mjcf import Scene, ScenePhysics, compose_scene

__all__ = ["Backend", "Progress"]

#: progress(done, total) with simulated steps
Progress = Callable[[int, int], None]


class Backend(abc.ABC):
    """Simulates every rollout of a batch: drive the agents, release them, settle, report in the task frame."""

    name: ClassVar[str]

    def __init__(self, config: ImaginationConfig | None = None):
        self._config = config or ImaginationConfig()
        #: the last scene composed, with the object and agents it was for: a case's batched calls (the nominal
        #: world, each round of perturbed worlds) step one object with one agent setup, compiled once
        self._last: tuple[RailObject, AgentSetup, Scene] | None = None

    @property
    def config(self) -> ImaginationConfig:
        """The settings this backend was built with (frozen)."""
        return self._config

    @abc.abstractmethod
    def scene(self, obj: RailObject, agents: AgentSetup) -> Scene:
        """The compiled one-world scene this backend steps for ``obj`` and ``agents``."""

    @abc.abstractmethod
    def run(self, batch: RolloutBatch, *, progress: Progress | None = None) -> Outcomes:
        """Simulate every rollout of ``batch``."""

    def _compose(self, obj: RailObject, agents: AgentSetup, physics: ScenePhysics, hull_boxes: int = 0) -> Scene:
        """``obj`` and ``agents`` composed with this backend's ``physics`` (which its config fixes), or the same
        scene again when they are the last ones composed (the same objects, not equal copies)."""
        if self._last is not None and self._last[0] is obj and self._last[1] is agents:
            return self._last[2]
        try:
            scene = compose_scene(obj, agents, physics, hull_boxes=hull_boxes)
        except SceneError as exc:
            raise ImaginationError(f"the imagination scene for {obj.name!r} cannot be built: {exc}") from exc
        self._last = (obj, agents, scene)
        return scene
