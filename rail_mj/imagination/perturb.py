"""Perturbed worlds: K variants of one object's imagination, drawn from a seed and run in the nominal batch.

World 0 is the nominal world; worlds 1..K each change, at once, the object's mesh scale (the whole world scales
with it about the world origin: the stable pose, its box, its basin and the plans' via-poses, so the plan is the
one made for the object at that size), the sliding friction of every geom, the agents' mass and size (their grid
spacing scales with them; an articulated body scales whole: its segments, joints and posture springs), and shift
every plan sideways by a fraction of the pose's half extents. Each factor is drawn stratified over its range (each
of K equal slices of the range holds one draw), so a few worlds cover it.

The draws depend on the seed only, the same for every object, so two objects differ only in themselves; with every
amplitude 0 the perturbed worlds equal the nominal one. Backends make one model per world (:func:`world_models`:
the nominal scene's model with these fields edited, so every world keeps its MjData layout) and step them in one
batched call.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import mujoco
import numpy as np

from rail_mj.core.errors import ConfigError
from rail_mj.core.types import Basin, StablePose
from rail_mj.imagination.config import ImaginationConfig
from rail_mj.mjcf import OWNER_OBJECT, Scene

__all__ = ["Perturbation", "PerturbationSet", "draw_perturbations", "scaled_pose", "resting_on", "world_model",
           "world_models", "world_trajectory"]


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
    """The worlds of one object's imagination (:func:`draw_perturbations`: world 0 nominal, then the perturbed ones)."""

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
        """The worlds after the first (the perturbed ones of :func:`draw_perturbations`); None when there are none."""
        return PerturbationSet(self.worlds[1:]) if len(self.worlds) > 1 else None


def _stratified(rng: np.random.Generator, k: int, amplitude: float) -> np.ndarray:
    """``k`` factors in [1 - a, 1 + a], one in each of ``k`` equal slices of the range, in random order."""
    u = (rng.permutation(k) + rng.random(k)) / k
    return 1.0 + amplitude * (2.0 * u - 1.0)


def draw_perturbations(config: ImaginationConfig) -> PerturbationSet:
    """The nominal world and ``config.perturbations`` perturbed ones, from ``config.seed``."""
    k = config.perturbations  # its range is ImaginationConfig's, checked when the config was made
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


def scaled_pose(pose: StablePose, s: float) -> StablePose:
    """``pose`` of the object scaled ``s`` times: the world scaled about its origin (the ground stays at z = 0)."""
    if s == 1.0:
        return pose
    basin = pose.basin
    return dataclasses.replace(
        pose, pos=np.asarray(pose.pos, dtype=np.float64) * s,
        half_extents=np.asarray(pose.half_extents, dtype=np.float64) * s,
        basin=None if basin is None else Basin(rim=basin.rim * s, opening=np.asarray(basin.opening) * s,
                                               length=basin.length * s, floor=basin.floor * s))


def resting_on(pose: StablePose, hulls: tuple[np.ndarray, ...], other: tuple[np.ndarray, ...]) -> StablePose:
    """``pose`` for the object collided as ``other`` hulls instead of ``hulls`` (its second decomposition): the same
    orientation, raised or lowered so that the lowest point of ``other`` rests where the lowest of ``hulls`` did
    (hulls of a coarser decomposition may reach a little below the first ones', and would start in the ground)."""
    up = pose.up_in_mesh_frame  # a mesh-frame point's height above the pose's origin is its dot with it

    def lowest(hs: tuple[np.ndarray, ...]) -> float:
        return float(min((np.asarray(h) @ up).min() for h in hs))

    pos = np.asarray(pose.pos, dtype=np.float64).copy()
    pos[2] += lowest(hulls) - lowest(other)
    return dataclasses.replace(pose, pos=pos)


def world_trajectory(via: np.ndarray, half_extents: np.ndarray, w: Perturbation) -> np.ndarray:
    """World ``w``'s (K, 7) via-poses of a plan made for a pose of half extents ``half_extents`` (nominal): the task
    frame scaled with the object, the plan shifted sideways by its fraction of the pose's half extents x, y."""
    out = np.array(via, dtype=np.float64)
    shift = np.array([w.offset[0] * half_extents[0], w.offset[1] * half_extents[1], 0.0]) * w.scale
    out[:, :3] = out[:, :3] * w.scale + shift
    return out


def _scale_bodies(m: mujoco.MjModel, bodies: np.ndarray, geoms: np.ndarray, length: float, mass: float) -> None:
    """Scale ``bodies`` (their ``geoms``, the geoms' meshes and bounding volumes) by ``length`` about each body's
    frame, and their mass by ``mass`` (inertia by mass x length squared)."""
    m.geom_pos[geoms] *= length
    m.geom_size[geoms] *= length
    m.geom_rbound[geoms] *= length
    m.geom_aabb[geoms] *= length  # centre and half sizes, in the geom frame
    for mesh in {int(i) for i in m.geom_dataid[geoms[m.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_MESH]]}:
        verts = slice(m.mesh_vertadr[mesh], m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh])
        m.mesh_vert[verts] *= length
        m.bvh_aabb[m.mesh_bvhadr[mesh] : m.mesh_bvhadr[mesh] + m.mesh_bvhnum[mesh]] *= length
    for b in bodies:
        m.bvh_aabb[m.body_bvhadr[b] : m.body_bvhadr[b] + m.body_bvhnum[b]] *= length
    m.body_ipos[bodies] *= length
    m.body_mass[bodies] *= mass
    m.body_inertia[bodies] *= mass * length**2


def _scale_joints(m: mujoco.MjModel, base: Scene, length: float, mass: float) -> None:
    """An articulated agent (:mod:`rail_mj.mjcf.body`) scaled whole about its root: each segment's place on its
    parent and its hinges' places by ``length``, as its geoms are. A posture spring holds what its joint carries
    (stiffness = mass x g x lever / sag, :func:`rail_mj.mjcf.body._spring`): its stiffness x mass x length keeps
    the posture's sag, and its damping (2 x ratio x sqrt(stiffness x mass x lever^2)) x mass x length^1.5 keeps the
    damping ratio."""
    segments = base.agent_bodies[:, 1:].ravel()  # the root's place is its free joint's
    m.body_pos[segments] *= length
    joints = m.dof_jntid[base.hinge_dofs]
    m.jnt_pos[joints] *= length
    m.jnt_stiffness[joints] *= mass * length
    m.dof_damping[base.hinge_dofs] *= mass * length**1.5
    m.dof_armature[base.hinge_dofs] *= mass * length**2  # a rotor inertia, were one set


def world_model(base: Scene, w: Perturbation) -> mujoco.MjModel:
    """``base``'s model in world ``w``: a copy with the object scaled about its frame (mass x scale^3 at the same
    density), every geom's sliding friction x friction, each agent's size (its geoms about its frame; an
    articulated agent's segments and joints about its root, :func:`_scale_joints`) x agent_size and its mass x
    agent_mass. Edited in place of a recompile, so the MjData layout stays the batch's (a recompiled
    scaled hull may triangulate its flat faces otherwise)."""
    m = copy.copy(base.model)
    if w.nominal:
        return m
    owner = base.geom_owner
    obj_geoms = np.nonzero(owner == OWNER_OBJECT)[0]
    _scale_bodies(m, np.unique(m.geom_bodyid[obj_geoms]), obj_geoms, w.scale, w.scale**3)
    agent_geoms = np.nonzero(owner >= 0)[0]
    _scale_bodies(m, np.unique(m.geom_bodyid[agent_geoms]), agent_geoms, w.agent_size, w.agent_mass)
    if base.articulated:
        _scale_joints(m, base, w.agent_size, w.agent_mass)
    m.geom_friction[:, 0] *= w.friction
    mujoco.mj_setConst(m, mujoco.MjData(m))
    return m


def world_models(base: Scene, perturbations: PerturbationSet) -> list[mujoco.MjModel]:
    """One model per world (:func:`world_model`), ``base.model`` itself for a nominal one."""
    return [base.model if w.nominal else world_model(base, w) for w in perturbations.worlds]
