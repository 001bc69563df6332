"""The batched drops: random orientations dropped in one MuJoCo batch, and quasi-static poses verified in physics."""

from __future__ import annotations

import mujoco
import mujoco.batch
import numpy as np
import trimesh

from rail_mj.core.geometry import rotation_to_z, up_in_mesh_frame
from rail_mj.core.types import RailObject
from rail_mj.imagination.config import ImaginationConfig
from rail_mj.mjcf import compose_scene
from rail_mj.stable_poses.cluster import cluster_ups

__all__ = ["uniform_quats", "quasi_static", "drop", "verified"]

#: quasi-static poses are checked by setting the object down this much off the pose and simulating this long (s)
_VERIFY_TILT_DEG = 3.0
_VERIFY_TIME = 1.5


def uniform_quats(rng: np.random.Generator, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def quasi_static(obj: RailObject) -> tuple[np.ndarray, np.ndarray]:
    """Mesh-frame ups (n, 3) and probabilities (n,) of trimesh's quasi-static poses (symmetric copies apart)."""
    transforms, probs = trimesh.poses.compute_stable_poses(obj.mesh, center_mass=obj.com)
    return np.array([t[2, :3] for t in transforms]).reshape(-1, 3), np.asarray(probs, dtype=np.float64).reshape(-1)


def drop(
    obj: RailObject, quats: np.ndarray, settle_time: float, drop_height: float, cfg: ImaginationConfig,
    min_time: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Drop the object from each orientation ``quats`` (n, 4) in one batch with the physics ``cfg``; return the
    final orientations (n, 4) and whether each settled (n,). Rest before ``min_time`` does not count: an object
    set down on an unstable balance point starts at rest and needs a moment to fall."""
    size = float(np.max(obj.extents))
    mass_scale = max(obj.mass, 1e-3)
    n_drops = len(quats)
    # damping and rolling friction let round objects (a cup on its side) come to rest within the settle time
    scene = compose_scene(obj, None, cfg.physics, joint_damping=0.05 * mass_scale, rolling_friction=0.01 * size)
    verts = np.concatenate([np.asarray(h) for h in obj.hulls])
    o = scene.object_qpos
    qpos0 = np.tile(scene.model.qpos0, (n_drops, 1))
    for i, q in enumerate(quats):
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, q)
        qpos0[i, o + 2] = drop_height - (verts @ rot.reshape(3, 3).T)[:, 2].min()
    qpos0[:, o + 3 : o + 7] = quats
    batch = mujoco.batch.Batch(scene.model, n_drops, nthread=cfg.nthread)
    qpos, qvel = batch.bind("qpos"), batch.bind("qvel")
    batch.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)  # pyright: ignore[reportArgumentType]  # it takes int(stage)
    qpos[:] = qpos0
    qvel[:] = 0.0
    batch.forward()
    settled = np.zeros(n_drops, dtype=bool)
    quiet = np.zeros(n_drops, dtype=bool)
    steps, limit = 0, int(np.ceil(settle_time / cfg.timestep))
    first_check = int(np.ceil(min_time / cfg.timestep))
    while steps < limit:
        running = np.nonzero(~settled)[0]
        if len(running) == 0:
            break
        batch.step(ids=running, nstep=cfg.check_every)
        steps += cfg.check_every
        rest = scene.at_rest(qpos, qvel, cfg.settle_speed) & (steps >= first_check)
        settled |= rest & quiet
        quiet = rest
    final = np.array(qpos[:, o + 3 : o + 7])
    return final / np.linalg.norm(final, axis=1, keepdims=True), settled


def verified(
    obj: RailObject, ups: np.ndarray, probs: np.ndarray, tol: float, rng: np.random.Generator,
    physics: ImaginationConfig,
) -> list[tuple[np.ndarray, float]]:
    """Quasi-static poses (mesh-frame ups, probabilities) that hold in physics: each cluster of ups within ``tol``
    is set on the ground tilted by ``_VERIFY_TILT_DEG`` about a random horizontal axis, and kept when its up is
    back within ``tol`` after ``_VERIFY_TIME`` (an unstable balance falls well past ``tol`` in that time).
    Returns (up, summed probability) per kept cluster."""
    if len(ups) == 0:
        return []
    clusters = cluster_ups(ups, tol)
    seeds = [ups[m[np.argmax(probs[m])]] for m in clusters]
    quats = []
    for up in seeds:
        angle = rng.uniform(0, 2 * np.pi)
        half = np.deg2rad(_VERIFY_TILT_DEG) / 2
        tilt = np.array([np.cos(half), np.sin(half) * np.cos(angle), np.sin(half) * np.sin(angle), 0.0])
        q = np.zeros(4)
        mujoco.mju_mulQuat(q, tilt, rotation_to_z(up))
        quats.append(q)
    # judged by where it ends, not by coming to rest: a legged table rocks on its hulls' corners for a while
    final, _ = drop(obj, np.array(quats), _VERIFY_TIME, 0.002, physics, min_time=_VERIFY_TIME)
    kept = np.einsum("ij,ij->i", up_in_mesh_frame(final), np.array(seeds)) > np.cos(tol)
    return [(seeds[i], float(probs[clusters[i]].sum())) for i in np.nonzero(kept)[0]]
