"""MJX backend: one world's step in JAX, ``jax.vmap`` over pose × plan, one ``lax.while_loop`` over steps.

Compiled once per shape bucket: the object's hulls become oriented boxes (MJX-JAX box contacts are exact,
its sphere-vs-general-hull contacts are not, see design.md), padded to 8/16/32/64 geoms with tiny massless
boxes hidden inside the first hull, and drive tables are padded to a power of two of steps. Every numeric
model array is a jit argument, so a new object in the same bucket reuses the compiled rollout.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

from rail_mj.errors import ImaginationError
from rail_mj.imagination.common import (
    ImaginationConfig,
    Scene,
    assemble_outcomes,
    build_scene_model,
    count_contacts,
    drive_table,
    initial_state,
)
from rail_mj.types import AgentSetup, Outcomes, RailObject, StablePose

__all__ = ["run_mjx", "compile_count", "hull_bucket", "bucket_scene", "HULL_BUCKETS"]

HULL_BUCKETS = (8, 16, 32, 64)
_CONTACT_FORCE = 1e-9
_compiles = 0


def compile_count() -> int:
    """Traces (= compiles) of the rollout so far in this process."""
    return _compiles


@dataclass(frozen=True)
class _Layout:
    """Structural, hashable facts of a bucket's scene: the jit's static argument."""

    agent_qpos: tuple[int, ...]
    agent_dof: tuple[int, ...]
    free_dofs: tuple[int, ...]
    check_every: int


def hull_bucket(n_hulls: int) -> int:
    """The padded geom count the object's hulls compile to."""
    for b in HULL_BUCKETS:
        if n_hulls <= b:
            return b
    raise ImaginationError(f"the mjx backend takes at most {HULL_BUCKETS[-1]} hulls; the object has {n_hulls}")


def _world_step(m, layout: _Layout, d, k, driven, n_drive, row_pose, row_vel):
    """One world, one step: put driven agents on their drive row, step, release those that touch something."""
    active = driven & (k < n_drive)
    qpos, qvel = d.qpos, d.qvel
    for i, (qa, va) in enumerate(zip(layout.agent_qpos, layout.agent_dof)):
        qpos = qpos.at[qa : qa + 7].set(jnp.where(active[i], row_pose[i], qpos[qa : qa + 7]))
        qvel = qvel.at[va : va + 6].set(jnp.where(active[i], row_vel, qvel[va : va + 6]))
    d = mjx.step(m, d.replace(qpos=qpos, qvel=qvel))
    touching = jnp.stack([jnp.abs(d.qfrc_constraint[va : va + 6]).max() > _CONTACT_FORCE for va in layout.agent_dof])
    early = active & touching & (k < n_drive - 1)
    return d, driven & ~(active & touching), early


def _at_rest(qvel, layout: _Layout, radius, settle_speed):
    lin = jnp.stack([qvel[d : d + 3] for d in layout.free_dofs])
    ang = jnp.stack([qvel[d + 3 : d + 6] for d in layout.free_dofs])
    return jnp.all(jnp.linalg.norm(lin, axis=-1) + jnp.linalg.norm(ang, axis=-1) * radius < settle_speed)


def _rollout(m, layout: _Layout, qpos0, pose_table, vel_table, n_drive, limit, radius, settle_speed):
    """Batched rollout; pose_table (B, S, N, 7) and vel_table (B, S, 6) are per-world drive rows."""
    global _compiles
    _compiles += 1  # runs only while tracing, i.e. once per compile
    n_worlds, n_agents = qpos0.shape[0], len(layout.agent_qpos)
    data0 = jax.vmap(lambda q: mjx.make_data(m).replace(qpos=q))(qpos0)
    last = pose_table.shape[1] - 1

    def one(d, k, driven, nd, pose_t, vel_t):
        idx = jnp.minimum(k, last)
        return _world_step(m, layout, d, k, driven, nd, pose_t[idx], vel_t[idx])

    step_all = jax.vmap(one, in_axes=(0, None, 0, 0, 0, 0))
    rest_all = jax.vmap(lambda qv: _at_rest(qv, layout, radius, settle_speed))

    def cond(carry):
        k, _, _, _, settled, _ = carry
        return (k < limit.max()) & ~jnp.all(settled | (k >= limit))

    def body(carry):
        k, d, driven, early, settled, quiet = carry
        d, driven, new_early = step_all(d, k, driven, n_drive, pose_table, vel_table)
        k = k + 1
        check = (k % layout.check_every == 0) & (k >= n_drive) & (k <= limit)
        rest = rest_all(d.qvel)
        settled = settled | (check & rest & quiet)
        quiet = jnp.where(check, rest, quiet)
        return k, d, driven, early | new_early, settled, quiet

    init = (
        jnp.int32(0),
        data0,
        jnp.ones((n_worlds, n_agents), bool),
        jnp.zeros((n_worlds, n_agents), bool),
        jnp.zeros(n_worlds, bool),
        jnp.zeros(n_worlds, bool),
    )
    _, d, _, early, settled, _ = jax.lax.while_loop(cond, body, init)
    contact = d._impl.contact
    return d.qpos, d.qvel, contact.geom, contact.dist, early, settled


_rollout_jit = jax.jit(_rollout, static_argnames=("layout",))


def bucket_scene(obj: RailObject, agents: AgentSetup, cfg: ImaginationConfig) -> Scene:
    """The box scene of obj's bucket, weighing what the hull-mesh scene weighs."""
    mesh_scene = build_scene_model(obj, None, cfg)
    m = mesh_scene.model
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "object")
    inertial = (float(m.body_mass[body]), m.body_ipos[body].copy(), m.body_inertia[body].copy(), m.body_iquat[body].copy())
    scene = build_scene_model(obj, agents, cfg, hull_boxes=hull_bucket(len(obj.hulls)), inertial=inertial)
    scene.model.opt.jacobian = mujoco.mjtJacobian.mjJAC_SPARSE  # dense deadlocked on large scenes (design.md)
    return scene


def _pad_steps(n: int) -> int:
    return max(64, 1 << int(np.ceil(np.log2(max(n, 1)))))


def run_mjx(
    obj: RailObject,
    poses: Sequence[StablePose],
    agents: AgentSetup,
    trajectories: Sequence[np.ndarray],
    n_plans: int,
    cfg: ImaginationConfig,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> Outcomes:
    """Same contract as the native backend, run as one jit-compiled JAX computation."""
    scene = bucket_scene(obj, agents, cfg)
    offsets = np.asarray(agents.offsets, dtype=np.float64)
    raw = drive_table(trajectories, cfg)
    table = drive_table(trajectories, cfg, pad_to=_pad_steps(int(raw.n_drive.max())))
    init = initial_state(scene, poses, n_plans, table, offsets)
    plan = init["row"]
    pose_table = np.concatenate(
        [
            (init["origin"][:, None, None, :] + table.pos[plan][:, :, None, :] + offsets[None, None]),
            np.broadcast_to(table.quat[plan][:, :, None, :], (len(plan), table.pos.shape[1], len(offsets), 4)),
        ],
        axis=-1,
    )
    vel_table = np.concatenate([table.linvel[plan], table.angvel[plan]], axis=-1)
    n_drive = table.n_drive[plan]
    limit = n_drive + int(np.ceil(cfg.settle_time / cfg.timestep))
    layout = _Layout(
        agent_qpos=tuple(int(a) for a in scene.agent_qpos),
        agent_dof=tuple(int(a) for a in scene.agent_dof),
        free_dofs=tuple(int(a) for a in scene.free_dofs),
        check_every=cfg.check_every,
    )
    m = mjx.put_model(scene.model, impl="jax")
    # a static copy of geom_rbound that MJX reads only to size heightfield contacts; the scene has no
    # heightfield, and left as is it would make every new object a new jit key
    m = m.replace(_impl=m._impl.replace(geom_rbound_hfield=np.zeros_like(m._impl.geom_rbound_hfield)))
    qpos, qvel, geom, dist, early, settled = _rollout_jit(
        m, layout, jnp.asarray(init["qpos"]), jnp.asarray(pose_table), jnp.asarray(vel_table),
        jnp.asarray(n_drive, dtype=jnp.int32), jnp.asarray(limit, dtype=jnp.int32),
        jnp.asarray(scene.free_radius), jnp.float32(cfg.settle_speed),
    )
    geom, dist = np.asarray(geom), np.asarray(dist)
    contacts = np.stack([count_contacts(scene.geom_owner, geom[b][dist[b] < 0], scene.n_agents) for b in range(len(plan))])
    if progress is not None:
        progress(int(limit.max()), int(limit.max()))
    return assemble_outcomes(scene, init, np.asarray(qpos, dtype=np.float64), np.asarray(qvel, dtype=np.float64),
                             contacts, np.asarray(early), np.asarray(settled))
