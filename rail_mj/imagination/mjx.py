"""MJX backend: one world's step in JAX, ``jax.vmap`` over pose × plan, one ``lax.while_loop`` over steps.

Compiled once per shape bucket: the object's hulls become oriented boxes (MJX-JAX box contacts are exact,
its sphere-vs-general-hull contacts are not, see design.md), padded to 8/16/32/64 geoms with tiny massless
boxes hidden inside the first hull, and drive tables are padded to a power of two of steps. Every numeric
model array is a jit argument, so a new object in the same bucket reuses the compiled rollout.

MJX keeps the JAX implementation's contacts and one heightfield size table in ``_impl`` (the MJX Model and
Data have no public field for them); this backend reads them, so it checks the installed mujoco-mjx against
the versions those fields were verified on when it is built.
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
from dataclasses import dataclass, replace

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx  # pyright: ignore[reportAttributeAccessIssue]  # the generated stubs omit the subpackage

from rail_mj.core.errors import ImaginationError
from rail_mj.core.types import AgentSetup, Outcomes, RailObject
from rail_mj.imagination.backend import Backend, Progress
from rail_mj.imagination.batch import RolloutBatch, outcomes_from_states
from rail_mj.imagination.config import ImaginationConfig
from rail_mj.imagination.perturb import world_models
from rail_mj.mjcf import Scene, count_contacts, settled_bodies

__all__ = ["MjxBackend", "hull_bucket", "HULL_BUCKETS", "SUPPORTED_MJX"]

HULL_BUCKETS = (8, 16, 32, 64)
#: mujoco-mjx major.minor versions whose ``_impl`` fields (Data: contact; Model: geom_rbound_hfield) this reads
SUPPORTED_MJX = ("3.17",)
_CONTACT_FORCE = 1e-9


@dataclass(frozen=True)
class _Layout:
    """Structural, hashable facts of a bucket's scene: the jit's static argument."""

    agent_qpos: tuple[int, ...]
    agent_dof: tuple[int, ...]
    free_qpos: tuple[int, ...]
    free_dofs: tuple[int, ...]
    check_every: int


def hull_bucket(n_hulls: int) -> int:
    """The padded geom count the object's hulls compile to."""
    for b in HULL_BUCKETS:
        if n_hulls <= b:
            return b
    raise ImaginationError(f"the mjx backend takes at most {HULL_BUCKETS[-1]} hulls; the object has {n_hulls}")


def _check_mjx_version() -> None:
    installed = importlib.metadata.version("mujoco-mjx")
    if ".".join(installed.split(".")[:2]) not in SUPPORTED_MJX:
        raise ImaginationError(
            f"the mjx backend reads MJX internals (Data._impl.contact, Model._impl.geom_rbound_hfield) verified on "
            f"mujoco-mjx {', '.join(v + '.x' for v in SUPPORTED_MJX)}; installed: {installed}. Install a supported "
            f"version (pip install 'mujoco-mjx=={SUPPORTED_MJX[-1]}.*') or use backend='native'"
        )


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


def _at_rest(qpos, qvel, layout: _Layout, radius, settle_speed):
    pos = jnp.stack([qpos[a : a + 3] for a in layout.free_qpos])
    lin = jnp.stack([qvel[d : d + 3] for d in layout.free_dofs])
    ang = jnp.stack([qvel[d + 3 : d + 6] for d in layout.free_dofs])
    return jnp.all(settled_bodies(jnp, pos, lin, ang, radius, settle_speed))


def _rollout(m, fields, world, layout: _Layout, qpos0, pose_table, vel_table, n_drive, limit, hold, radius,
             settle_speed):
    """Batched rollout; pose_table (B, S, N, 7) and vel_table (B, S, 6) are per-world drive rows; ``fields`` the
    model fields that differ between perturbed worlds, (W, ...) each, and ``world`` (B,) each rollout's world. Rest
    counts ``hold`` steps after a world's agents are all released, at the latest once the batch's drive is over (as
    the native backend counts it)."""
    n_worlds, n_agents = qpos0.shape[0], len(layout.agent_qpos)
    data0 = jax.vmap(lambda q: mjx.make_data(m).replace(qpos=q))(qpos0)
    last = pose_table.shape[1] - 1

    def one(d, k, driven, nd, pose_t, vel_t, w):
        idx = jnp.minimum(k, last)
        mw = m.replace(**{name: jax.tree.map(lambda x: x[w], v) for name, v in fields.items()})
        return _world_step(mw, layout, d, k, driven, nd, pose_t[idx], vel_t[idx])

    step_all = jax.vmap(one, in_axes=(0, None, 0, 0, 0, 0, 0))
    rest_all = jax.vmap(lambda qp, qv: _at_rest(qp, qv, layout, radius, settle_speed))
    n_max = n_drive.max()

    def cond(carry):
        k, _, _, _, settled, _, _ = carry
        return (k < limit.max()) & ~jnp.all(settled | (k >= limit))

    def body(carry):
        k, d, driven, early, settled, quiet, free_since = carry
        d, driven, new_early = step_all(d, k, driven, n_drive, pose_table, vel_table, world)
        k = k + 1
        free_since = jnp.where(~driven.any(axis=1), jnp.minimum(free_since, k), free_since)
        check = (k % layout.check_every == 0) & (k >= jnp.minimum(free_since + hold, n_max)) & (k <= limit)
        rest = rest_all(d.qpos, d.qvel)
        settled = settled | (check & rest & quiet)
        quiet = jnp.where(check, rest, quiet)
        return k, d, driven, early | new_early, settled, quiet, free_since

    init = (
        jnp.int32(0),
        data0,
        jnp.ones((n_worlds, n_agents), bool),
        jnp.zeros((n_worlds, n_agents), bool),
        jnp.zeros(n_worlds, bool),
        jnp.zeros(n_worlds, bool),
        n_drive,
    )
    _, d, _, early, settled, _, _ = jax.lax.while_loop(cond, body, init)
    contact = d._impl.contact
    return d.qpos, d.qvel, contact.geom, contact.dist, early, settled


def _pad_steps(n: int) -> int:
    return max(64, 1 << int(np.ceil(np.log2(max(n, 1)))))


class MjxBackend(Backend):
    """The hull-box bucket scene, vmapped and jit-compiled; ``compiles`` counts this backend's compiles."""

    name = "mjx"

    def __init__(self, config: ImaginationConfig | None = None):
        _check_mjx_version()
        super().__init__(config)
        self._compiles = 0
        self._rollout = jax.jit(self._traced_rollout, static_argnames=("layout",))

    @property
    def compiles(self) -> int:
        """Traces (= compiles) of the rollout by this backend so far."""
        return self._compiles

    def _traced_rollout(self, m, fields, world, layout: _Layout, qpos0, pose_table, vel_table, n_drive, limit, hold,
                        radius, settle_speed):
        self._compiles += 1  # runs only while tracing, i.e. once per compile
        return _rollout(m, fields, world, layout, qpos0, pose_table, vel_table, n_drive, limit, hold, radius,
                        settle_speed)

    def scene(self, obj: RailObject, agents: AgentSetup) -> Scene:
        """The box scene of obj's bucket, weighing what the hull-mesh scene weighs."""
        # MJX does not implement speculative contacts
        scene = self._compose(obj, agents, replace(self.config.physics, speculative=False), hull_bucket(len(obj.hulls)))
        scene.model.opt.jacobian = mujoco.mjtJacobian.mjJAC_SPARSE  # dense deadlocked on large scenes (design.md)
        return scene

    @staticmethod
    def put_model(scene: Scene) -> mjx.Model:
        """The scene on the device, with nothing object-specific left in its static fields."""
        m = mjx.put_model(scene.model, impl="jax")
        # a static copy of geom_rbound that MJX reads only to size heightfield contacts; the scene has no
        # heightfield, and left as is it would make every new object a new jit key
        return m.replace(_impl=m._impl.replace(geom_rbound_hfield=np.zeros_like(m._impl.geom_rbound_hfield)))

    def world_fields(self, scene: Scene, m: mjx.Model, batch: RolloutBatch) -> dict:
        """The model fields that differ between the batch's worlds, stacked (W, ...): the jit's per-world inputs
        (:func:`~rail_mj.imagination.perturb.world_models`; the rest of the model is shared)."""
        if all(w.nominal for w in batch.perturbations.worlds):
            return {}
        models = [m if w is scene.model else self.put_model(replace(scene, model=w))
                  for w in world_models(scene, batch.perturbations)]
        fields = {}
        for f in dataclasses.fields(m):
            if f.name == "_impl":  # implementation details; a perturbation changes none the rollout reads
                continue
            values = [getattr(w, f.name) for w in models]
            leaves = [jax.tree.leaves(v) for v in values]
            if all(isinstance(x, jax.Array) for x in leaves[0]) and any(
                    not all(np.array_equal(np.asarray(a), np.asarray(b)) for a, b in zip(leaves[0], other))
                    for other in leaves[1:]):
                fields[f.name] = jax.tree.map(lambda *xs: jnp.stack(xs), *values)
        return fields

    def run(self, batch: RolloutBatch, *, progress: Progress | None = None) -> Outcomes:
        """Same contract as the native backend, run as one jit-compiled JAX computation."""
        cfg = self.config
        scene = self.scene(batch.obj, batch.agents)
        if scene.articulated:
            raise ImaginationError("the mjx backend drives one-body agents only; an articulated agent (the body of "
                                   "the seat and lie kinds) is imagined with backend='native'")
        placement, offsets = batch.placement, batch.world_offsets
        table = batch.table.padded(_pad_steps(int(batch.table.n_drive.max())))
        plan = placement.row
        pose_table = np.concatenate(
            [
                (placement.origin[:, None, None, :] + table.pos[plan][:, :, None, :] + offsets[:, None]),
                np.broadcast_to(table.quat[plan][:, :, None, :], (len(plan), table.steps, offsets.shape[1], 4)),
            ],
            axis=-1,
        )
        vel_table = np.concatenate([table.linvel[plan], table.angvel[plan]], axis=-1)
        n_drive = table.n_drive[plan]
        limit = n_drive + cfg.settle_steps
        layout = _Layout(
            agent_qpos=tuple(int(a) for a in scene.agent_qpos),
            agent_dof=tuple(int(a) for a in scene.agent_dof),
            free_qpos=tuple(int(a) for a in scene.free_qpos),
            free_dofs=tuple(int(a) for a in scene.free_dofs),
            check_every=cfg.check_every,
        )
        m = self.put_model(scene)
        qpos, qvel, geom, dist, early, settled = self._rollout(
            m, self.world_fields(scene, m, batch), jnp.asarray(placement.worlds, dtype=jnp.int32), layout,
            jnp.asarray(batch.initial_qpos(scene)), jnp.asarray(pose_table),
            jnp.asarray(vel_table), jnp.asarray(n_drive, dtype=jnp.int32), jnp.asarray(limit, dtype=jnp.int32),
            jnp.int32(cfg.hold_steps), jnp.asarray(scene.free_radius),
            jnp.float32(cfg.settle_speed),
        )
        geom, dist = np.asarray(geom), np.asarray(dist)
        contacts = np.stack([count_contacts(scene.geom_owner, geom[b][dist[b] < 0], scene.n_agents)
                             for b in range(len(plan))])
        if progress is not None:
            progress(int(limit.max()), int(limit.max()))
        return outcomes_from_states(scene, placement, np.asarray(qpos, dtype=np.float64),
                                    np.asarray(qvel, dtype=np.float64), contacts, np.asarray(early),
                                    np.asarray(settled))
