"""Perturbed worlds: K variants of one object's imagination, drawn from a seed and run in the nominal batch.

World 0 is the nominal world; worlds 1..K each change, at once, the object's mesh scale (the whole world scales
with it about the world origin: the stable pose, its box, its basin and the plans' via-poses, so the plan is the
one made for the object at that size), the sliding friction of every geom, the agents' mass and size (their grid
spacing scales with them), and shift every plan sideways by a fraction of the pose's half extents. Each factor is
drawn stratified over its range (each of K equal slices of the range holds one draw), so a few worlds cover it.

The draws depend on the seed only, the same for every object, so two objects differ only in themselves; with every
amplitude 0 the perturbed worlds equal the nominal one. Backends build one compiled model per world
(:func:`world_models`) and step them in the same batched call.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from rail_mj.core.errors import ConfigError
from rail_mj.core.types import AgentSetup, Basin, RailObject, StablePose
from rail_mj.imagination.config import PERTURBATIONS_RANGE, ImaginationConfig
from rail_mj.mjcf import OBJECT_BODY, Scene, ScenePhysics, compose_scene

__all__ = ["Perturbation", "PerturbationSet", "draw", "scaled_object", "scaled_pose", "world_models",
           "world_trajectory"]


@dataclass(frozen=True)
class Perturbation:
    """One world's changes, as factors (1 = nominal) and a plan shift."""

    scale: float = 1.0  # the object's mesh scale (and the world's with it)
    friction: float = 1.0  # factor on every geom's sliding friction
    agent_mass: float = 1.0  # factor on each agent's mass
    agent_size: float = 1.0  # factor on each agent's size and on their grid spacing
    offset: tuple[float, float] = (0.0, 0.0)  # plan shift in x, y as a fraction of the pose's half extents x, y

    @property
    def nominal(self) -> bool:
        return self == Perturbation()

    def doc(self) -> str:
        """``scale 1.04, friction 0.83, agent mass 1.12, agent size 0.95, shift (+0.02, -0.03)``."""
        return (f"scale {self.scale:.3f}, friction {self.friction:.2f}, agent mass {self.agent_mass:.2f}, "
                f"agent size {self.agent_size:.3f}, shift ({self.offset[0]:+.3f}, {self.offset[1]:+.3f})")


@dataclass(frozen=True)
class PerturbationSet:
    """The worlds of one object's imagination (:func:`draw`: world 0 nominal, then the perturbed ones)."""

    worlds: tuple[Perturbation, ...] = (Perturbation(),)

    def __post_init__(self) -> None:
        if not self.worlds:
            raise ConfigError("a perturbation set holds at least one world")

    @property
    def n_worlds(self) -> int:
        return len(self.worlds)

    @property
    def scales(self) -> np.ndarray:
        return np.array([w.scale for w in self.worlds])

    @property
    def perturbed(self) -> PerturbationSet | None:
        """The worlds after the first (the perturbed ones of :func:`draw`); None when there are none."""
        return PerturbationSet(self.worlds[1:]) if len(self.worlds) > 1 else None


def _stratified(rng: np.random.Generator, k: int, amplitude: float) -> np.ndarray:
    """``k`` factors in [1 - a, 1 + a], one in each of ``k`` equal slices of the range, in random order."""
    u = (rng.permutation(k) + rng.random(k)) / k
    return 1.0 + amplitude * (2.0 * u - 1.0)


def draw(config: ImaginationConfig) -> PerturbationSet:
    """The nominal world and ``config.perturbations`` perturbed ones, from ``config.seed``."""
    k = config.perturbations
    lo, hi = PERTURBATIONS_RANGE
    if isinstance(k, bool) or not isinstance(k, int) or not lo <= k <= hi:
        raise ConfigError(f"perturbations must be a whole number in [{lo}, {hi}]; got {k!r}")
    rng = np.random.default_rng(config.seed)
    scale = _stratified(rng, k, config.perturb_scale)
    friction = _stratified(rng, k, config.perturb_friction)
    mass = _stratified(rng, k, config.perturb_agent_mass)
    size = _stratified(rng, k, config.perturb_agent_size)
    off = np.stack([_stratified(rng, k, config.perturb_offset) - 1.0 for _ in range(2)], axis=1)
    return PerturbationSet((Perturbation(), *(
        Perturbation(scale=float(scale[i]), friction=float(friction[i]), agent_mass=float(mass[i]),
                     agent_size=float(size[i]), offset=(float(off[i, 0]), float(off[i, 1])))
        for i in range(k))))


def scaled_object(obj: RailObject, s: float) -> RailObject:
    """``obj`` scaled ``s`` times about its mesh-frame origin, at the same density (its mesh, used only by the ray
    probe, stays; the probe scales its rays instead)."""
    if s == 1.0:
        return obj
    return replace(obj, hulls=tuple(np.asarray(h, dtype=np.float64) * s for h in obj.hulls),
                   obb_dims=np.asarray(obj.obb_dims) * s, com=np.asarray(obj.com) * s, mass=obj.mass * s**3)


def scaled_pose(pose: StablePose, s: float) -> StablePose:
    """``pose`` of the object scaled ``s`` times: the world scaled about its origin (the ground stays at z = 0)."""
    if s == 1.0:
        return pose
    basin = pose.basin
    return dataclasses.replace(
        pose, pos=np.asarray(pose.pos, dtype=np.float64) * s,
        half_extents=np.asarray(pose.half_extents, dtype=np.float64) * s,
        basin=None if basin is None else Basin(rim=basin.rim * s, opening=np.asarray(basin.opening) * s,
                                               length=basin.length * s))


def world_trajectory(via: np.ndarray, half_extents: np.ndarray, w: Perturbation) -> np.ndarray:
    """World ``w``'s (K, 7) via-poses of a plan made for a pose of half extents ``half_extents`` (nominal): the task
    frame scaled with the object, the plan shifted sideways by its fraction of the pose's half extents x, y."""
    out = np.array(via, dtype=np.float64)
    shift = np.array([w.offset[0] * half_extents[0], w.offset[1] * half_extents[1], 0.0]) * w.scale
    out[:, :3] = out[:, :3] * w.scale + shift
    return out


def _agents_edit(w: Perturbation):
    """The spec edit of world ``w``'s agents: sizes and positions in their body × agent_size, mass × agent_mass,
    sliding friction × friction (the ground's and the object's come through the scene physics)."""

    def edit(spec: mujoco.MjSpec) -> None:
        for body in spec.worldbody.bodies:
            if body.name == OBJECT_BODY:
                continue
            for g in body.find_all(mujoco.mjtObj.mjOBJ_GEOM):
                assert isinstance(g, mujoco.MjsGeom)
                g.size = np.asarray(g.size) * w.agent_size  # pyright: ignore[reportAttributeAccessIssue]
                g.pos = np.asarray(g.pos) * w.agent_size  # pyright: ignore[reportAttributeAccessIssue]
                fromto = np.asarray(g.fromto)
                if np.all(np.isfinite(fromto)):
                    g.fromto = fromto * w.agent_size  # pyright: ignore[reportAttributeAccessIssue]
                if np.isfinite(g.mass):
                    g.mass = g.mass * w.agent_mass
                else:
                    g.density = g.density * w.agent_mass
                friction = np.asarray(g.friction, dtype=np.float64).copy()
                friction[0] *= w.friction
                g.friction = friction  # pyright: ignore[reportAttributeAccessIssue]

    return edit


def world_models(base: Scene, obj: RailObject, agents: AgentSetup, physics: ScenePhysics,
                 perturbations: PerturbationSet, hull_boxes: int = 0) -> list[mujoco.MjModel]:
    """One compiled model per world, ``base.model`` for a nominal one: the same MjData layout throughout."""
    models = []
    for w in perturbations.worlds:
        if w.nominal:
            models.append(base.model)
            continue
        scene = compose_scene(scaled_object(obj, w.scale), agents,
                              replace(physics, friction=physics.friction * w.friction), hull_boxes=hull_boxes,
                              edit=_agents_edit(w), surface=False)
        scene.model.opt.jacobian = base.model.opt.jacobian
        models.append(scene.model)
    return models

