"""Native backend: MuJoCo C, every rollout of the batch stepped by ``mujoco.batch.Batch`` on all threads."""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import mujoco.batch
import numpy as np

from rail_mj.imagination.common import DriveTable, ImaginationConfig, Scene, assemble_outcomes, at_rest, count_contacts
from rail_mj.types import Outcomes

__all__ = ["run_native"]

#: a generalized constraint force above this on an agent's dofs means it touches something
_CONTACT_FORCE = 1e-9


def run_native(
    scene: Scene,
    init: dict[str, np.ndarray],
    table: DriveTable,
    offsets: np.ndarray,
    cfg: ImaginationConfig,
    *,
    nthread: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Outcomes:
    """Drive, release and settle every rollout; ``nthread=1`` gives the serial reference."""
    n_worlds, n_agents = len(init["qpos"]), scene.n_agents
    batch = mujoco.batch.Batch(scene.model, n_worlds, nthread=cfg.nthread if nthread is None else nthread, persistent=True)
    qpos, qvel = batch.bind("qpos"), batch.bind("qvel")
    qfrc = batch.bind("qfrc_constraint")
    batch.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)
    qpos[:] = init["qpos"]
    qvel[:] = 0.0
    batch.forward()

    plan = init["row"]
    n_drive = table.n_drive[plan]
    qcols = scene.agent_qpos[:, None] + np.arange(7)
    vcols = scene.agent_dof[:, None] + np.arange(6)
    driven = np.ones((n_worlds, n_agents), dtype=bool)
    released_early = np.zeros((n_worlds, n_agents), dtype=bool)
    limit = n_drive + int(np.ceil(cfg.settle_time / cfg.timestep))
    total = int(limit.max())
    for k in range(int(n_drive.max())):
        rows, agents = np.nonzero(driven & (k < n_drive)[:, None])
        p = plan[rows]
        qpos[rows[:, None], qcols[agents]] = np.concatenate(
            [init["origin"][rows] + table.pos[p, k] + offsets[agents], table.quat[p, k]], axis=1
        )
        qvel[rows[:, None], vcols[agents]] = np.concatenate([table.linvel[p, k], table.angvel[p, k]], axis=1)
        batch.step()
        touching = np.abs(qfrc[rows[:, None], vcols[agents]]).max(axis=1) > _CONTACT_FORCE
        released_early[rows[touching], agents[touching]] = (k < n_drive[rows] - 1)[touching]
        driven[rows[touching], agents[touching]] = False
        if progress is not None:
            progress(k + 1, total)
    steps = n_drive.copy()
    settled = np.zeros(n_worlds, dtype=bool)
    rested_once = np.zeros(n_worlds, dtype=bool)
    while True:
        rest = at_rest(qvel, scene, cfg)
        # two quiet checks in a row, so a bounce's apex does not count as rest
        settled |= rest & rested_once
        rested_once = rest
        running = np.nonzero(~settled & (steps < limit))[0]
        if len(running) == 0:
            break
        batch.step(ids=running, nstep=cfg.check_every)
        steps[running] += cfg.check_every
        if progress is not None:
            progress(int(min(steps.max(), total)), total)

    contacts = np.zeros((n_worlds, n_agents, 3), dtype=np.int64)
    data = mujoco.MjData(scene.model)
    for b in range(n_worlds):
        batch.get_data(b, data)
        contacts[b] = count_contacts(scene.geom_owner, data.contact.geom[: data.ncon], n_agents)
    return assemble_outcomes(scene, init, np.array(qpos), np.array(qvel), contacts, released_early, settled)
