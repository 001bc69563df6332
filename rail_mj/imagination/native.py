"""Native backend: MuJoCo C, every rollout of the batch stepped by ``mujoco.batch.Batch`` on all threads."""

from __future__ import annotations

import mujoco
import mujoco.batch
import numpy as np

from rail_mj.core.types import AgentSetup, Outcomes, RailObject
from rail_mj.imagination.backend import Backend, Progress
from rail_mj.imagination.batch import RolloutBatch, outcomes_from_states
from rail_mj.imagination.perturb import world_models
from rail_mj.mjcf import Scene, count_contacts, segment_state

__all__ = ["NativeBackend"]

#: a generalized constraint force above this on an agent's dofs means it touches something
_CONTACT_FORCE = 1e-9
#: MuJoCo's warnings that a simulation blew up (it resets such a world to qpos0 and goes on)
_BLOW_UPS = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQPOS)


class NativeBackend(Backend):
    """The hull-mesh scene on ``config.nthread`` threads (0 = all CPUs; 1 = the serial reference)."""

    name = "native"

    def scene(self, obj: RailObject, agents: AgentSetup) -> Scene:
        return self._compose(obj, agents, self.config.physics)

    def run(self, batch: RolloutBatch, *, progress: Progress | None = None) -> Outcomes:
        """Drive, release and settle every rollout; a world that has settled is stepped no more."""
        cfg = self.config
        scene = self.scene(batch.obj, batch.agents)
        table, placement, offsets = batch.table, batch.placement, batch.world_offsets
        n_worlds, n_agents = placement.batch, scene.n_agents
        sim = mujoco.batch.Batch(scene.model, n_worlds, nthread=cfg.nthread, persistent=True)
        models = [scene.model] * n_worlds  # each rollout's model: its world's
        if any(not w.nominal for w in batch.perturbations.worlds):
            per_world = world_models(scene, batch.perturbations)
            models = [per_world[w] for w in placement.worlds]
            sim.set_models(models)
        qpos, qvel = sim.bind("qpos"), sim.bind("qvel")
        qfrc = sim.bind("qfrc_constraint")
        sim.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)  # pyright: ignore[reportArgumentType]  # it takes int(stage)
        qpos[:] = batch.initial_qpos(scene)
        qvel[:] = 0.0
        sim.forward()

        plan = placement.row
        n_drive = table.n_drive[plan]
        qcols = scene.agent_qpos[:, None] + np.arange(7)
        vcols = scene.agent_dof[:, None] + np.arange(6)
        driven = np.ones((n_worlds, n_agents), dtype=bool)
        released_early = np.zeros((n_worlds, n_agents), dtype=bool)
        free_since = n_drive.copy()  # the step from which no agent of the world is driven (released or done)
        hold = cfg.hold_steps
        n_max = int(n_drive.max())
        total = n_max + cfg.settle_steps
        settled = np.zeros(n_worlds, dtype=bool)
        quiet = np.zeros(n_worlds, dtype=bool)
        k = 0
        while True:
            if k % cfg.check_every == 0:
                # rest counts from a hold after the release, and at the latest once the batch's drive is over
                rest = scene.at_rest(qpos, qvel, cfg.settle_speed) & (k >= np.minimum(free_since + hold, n_max))
                # two quiet checks in a row, so a bounce's apex does not count as rest
                settled |= rest & quiet
                quiet = rest
            if k >= total or settled.all():
                break
            running = np.nonzero(~settled)[0]
            if k >= n_max:  # nothing is driven any more: step to the next check
                n = cfg.check_every - k % cfg.check_every
                sim.step(ids=running, nstep=n)
                k += n
            else:
                rows, agents = np.nonzero(driven & (k < n_drive)[:, None])
                p = plan[rows]
                qpos[rows[:, None], qcols[agents]] = np.concatenate(
                    [placement.origin[rows] + table.pos[p, k] + offsets[rows, agents], table.quat[p, k]], axis=1
                )
                qvel[rows[:, None], vcols[agents]] = np.concatenate([table.linvel[p, k], table.angvel[p, k]], axis=1)
                sim.step(ids=running)
                touching = np.abs(qfrc[rows[:, None], vcols[agents]]).max(axis=1) > _CONTACT_FORCE
                released_early[rows[touching], agents[touching]] = (k < n_drive[rows] - 1)[touching]
                driven[rows[touching], agents[touching]] = False
                k += 1
                free_since = np.where(~driven.any(axis=1), np.minimum(free_since, k), free_since)
            if progress is not None:
                progress(min(k, total), total)

        contacts = np.zeros((n_worlds, n_agents, 3), dtype=np.int64)
        unstable = np.zeros(n_worlds, dtype=bool)
        segments = []
        data = mujoco.MjData(scene.model)
        for b in range(n_worlds):
            sim.get_data(b, data)
            contacts[b] = count_contacts(scene.geom_owner, data.contact.geom[: data.ncon], n_agents)
            unstable[b] = any(data.warning[w].number > 0 for w in _BLOW_UPS)
            if scene.articulated:  # the segments where the rollout's own world (its agent's size) put them
                segments.append(segment_state(scene, data, data.contact.geom[: data.ncon], models[b],
                                              float(placement.scales[b])))
        stacked = tuple(np.stack(a) for a in zip(*segments, strict=True)) if segments else None
        return outcomes_from_states(scene, placement, np.array(qpos), np.array(qvel), contacts, released_early, settled,
                                    unstable, stacked)  # pyright: ignore[reportArgumentType]  # three arrays
