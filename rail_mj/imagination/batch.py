"""The prepared inputs every backend takes, and the task-frame outcomes every backend returns.

``prepare`` turns (object, stable poses, agents, via-poses) into a :class:`RolloutBatch`: the typed
:class:`Placement` of every rollout (pose-major) and the :class:`DriveTable` of the agents' kinematic
targets. Every per-rollout difference lives in the initial state and the table, so one compiled scene
serves the whole batch. ``assemble_outcomes`` turns final world poses into :class:`Outcomes`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import mujoco
import numpy as np

from rail_mj.core.errors import ImaginationError
from rail_mj.core.geometry import follow_task_frame, quat_angle, quat_to_angvel, slerp, task_origin, tilt, to_task_frame
from rail_mj.core.types import AgentSetup, Outcomes, RailObject, StablePose
from rail_mj.imagination.config import ImaginationConfig
from rail_mj.imagination.perturb import Perturbation, PerturbationSet, scaled_pose, world_trajectory
from rail_mj.mjcf import Scene

__all__ = [
    "DriveTable",
    "Placement",
    "rollout_index",
    "pose_plan",
    "RolloutBatch",
    "prepare",
    "plan_rows",
    "drive_table",
    "assemble_outcomes",
    "outcomes_from_states",
    "PROBE_DIRECTIONS",
    "open_sectors",
]

#: Horizontal directions of the enclosure probe, evenly spaced (22.5 deg apart).
PROBE_DIRECTIONS = 16
#: Rays spread evenly across each probe direction's sector (world frame, (16 * 4, 3)).
_SUB_RAYS = 4
_SUB_ANGLES = (2 * np.pi * (np.arange(PROBE_DIRECTIONS * _SUB_RAYS) - (_SUB_RAYS - 1) / 2)
               / (PROBE_DIRECTIONS * _SUB_RAYS))
_SUB_VEC = np.stack([np.cos(_SUB_ANGLES), np.sin(_SUB_ANGLES), np.zeros_like(_SUB_ANGLES)], axis=1)


@dataclass(frozen=True)
class DriveTable:
    """Per-row kinematic targets of the layout centre, one entry per step, task frame at placement."""

    pos: np.ndarray  # (R, S, 3)
    quat: np.ndarray  # (R, S, 4)
    linvel: np.ndarray  # (R, S, 3) world
    angvel: np.ndarray  # (R, S, 3) body-local, as free-joint qvel
    n_drive: np.ndarray  # (R,) steps during which the agents are driven (entries used)

    @property
    def steps(self) -> int:
        return int(self.pos.shape[1])

    def padded(self, steps: int) -> DriveTable:
        """The same table with at least ``steps`` entries; added entries hold each row's last pose at rest."""
        extra = steps - self.steps
        if extra <= 0:
            return self

        def hold(a: np.ndarray) -> np.ndarray:
            return np.concatenate([a, np.repeat(a[:, -1:], extra, axis=1)], axis=1)

        def rest(a: np.ndarray) -> np.ndarray:
            return np.concatenate([a, np.zeros((a.shape[0], extra, a.shape[2]))], axis=1)

        return DriveTable(pos=hold(self.pos), quat=hold(self.quat), linvel=rest(self.linvel),
                          angvel=rest(self.angvel), n_drive=self.n_drive)


def rollout_index(pose: int, plan: int, n_plans: int) -> int:
    """The rollout of the ``pose``-th imagined pose and its plan ``plan`` in a pose-major batch of ``n_plans``
    plans per pose (:meth:`Placement.of`)."""
    return pose * n_plans + plan


def pose_plan(rollout: int, n_plans: int) -> tuple[int, int]:
    """(imagined pose, plan) of a rollout in a pose-major batch: the inverse of :func:`rollout_index`."""
    pose, plan = divmod(rollout, n_plans)
    return pose, plan


@dataclass(frozen=True)
class Placement:
    """Where each rollout of a batch starts (B = poses × plans, pose-major): object pose, task frame, plan row."""

    pose_index: np.ndarray  # (B,) int
    plan_index: np.ndarray  # (B,) int
    row: np.ndarray  # (B,) int, the rollout's row of the drive table
    object_pos: np.ndarray  # (B, 3) world position of the mesh-frame origin
    object_quat: np.ndarray  # (B, 4) wxyz
    origin: np.ndarray  # (B, 3) world position of the task-frame origin
    half_extents: np.ndarray  # (B, 3)
    world: np.ndarray | None = None  # (B,) int, the rollout's world (rail_mj.imagination.perturb); None: all nominal
    scale: np.ndarray | None = None  # (B,) the world's mesh scale; None: all 1
    agent_scale: np.ndarray | None = None  # (B,) the world's agent size factor (grid spacing too); None: all 1

    @property
    def batch(self) -> int:
        return int(self.pose_index.shape[0])

    @property
    def worlds(self) -> np.ndarray:
        """(B,) the world of each rollout (0: nominal)."""
        return np.zeros(self.batch, dtype=np.int64) if self.world is None else self.world

    @property
    def scales(self) -> np.ndarray:
        """(B,) the mesh scale of each rollout's world."""
        return np.ones(self.batch) if self.scale is None else self.scale

    @staticmethod
    def concat(parts: Sequence[Placement], worlds: Sequence[Perturbation]) -> Placement:
        """One placement of ``parts[w]`` run in world ``worlds[w]``, world-major; rows are offset part by part."""
        rows, start = [], 0
        for p in parts:
            rows.append(p.row + start)
            start += int(p.row.max()) + 1
        n = [p.batch for p in parts]

        def cat(name: str) -> np.ndarray:
            return np.concatenate([getattr(p, name) for p in parts])

        return Placement(
            pose_index=cat("pose_index"), plan_index=cat("plan_index"), row=np.concatenate(rows),
            object_pos=cat("object_pos"), object_quat=cat("object_quat"), origin=cat("origin"),
            half_extents=cat("half_extents"), world=np.repeat(np.arange(len(parts)), n),
            scale=np.repeat([w.scale for w in worlds], n), agent_scale=np.repeat([w.agent_size for w in worlds], n),
        )

    @staticmethod
    def of(poses: Sequence[StablePose], n_plans: int, n_rows: int) -> Placement:
        """Pose-major placements; ``n_rows`` = ``n_plans`` (plans shared by all poses) or one row per rollout."""
        n_poses = len(poses)
        pose_index = np.repeat(np.arange(n_poses), n_plans)
        plan_index = np.tile(np.arange(n_plans), n_poses)
        half = np.stack([np.asarray(p.half_extents, dtype=np.float64) for p in poses])[pose_index]
        return Placement(
            pose_index=pose_index,
            plan_index=plan_index,
            row=plan_index if n_rows == n_plans else np.arange(len(pose_index)),
            object_pos=np.stack([np.asarray(p.pos, dtype=np.float64) for p in poses])[pose_index],
            object_quat=np.stack([np.asarray(p.quat, dtype=np.float64) for p in poses])[pose_index],
            origin=task_origin(half),
            half_extents=half,
        )


@dataclass(frozen=True)
class RolloutBatch:
    """One object's rollouts, ready for any backend."""

    obj: RailObject
    agents: AgentSetup
    placement: Placement
    table: DriveTable
    perturbations: PerturbationSet = PerturbationSet()

    @property
    def offsets(self) -> np.ndarray:
        """(N, 3) agent positions relative to the layout centre."""
        return np.asarray(self.agents.offsets, dtype=np.float64)

    @property
    def world_offsets(self) -> np.ndarray:
        """(B, N, 3) agent positions relative to the layout centre in each rollout's world (the grid scales with
        the agents' size)."""
        s = np.ones(self.placement.batch) if self.placement.agent_scale is None else self.placement.agent_scale
        return self.offsets[None] * s[:, None, None]

    def initial_qpos(self, scene: Scene) -> np.ndarray:
        """(B, nq): the object in its stable pose, the agents at their plan's first via-pose."""
        p, row = self.placement, self.placement.row
        qpos = np.tile(scene.model.qpos0, (p.batch, 1))
        qpos[:, scene.object_qpos : scene.object_qpos + 3] = p.object_pos
        qpos[:, scene.object_qpos + 3 : scene.object_qpos + 7] = p.object_quat
        start_pos = p.origin[:, None, :] + self.table.pos[row, 0][:, None, :] + self.world_offsets
        for i, adr in enumerate(scene.agent_qpos):
            qpos[:, adr : adr + 3] = start_pos[:, i]
            qpos[:, adr + 3 : adr + 7] = self.table.quat[row, 0]
        return qpos


def _plan_samples(via: np.ndarray, cfg: ImaginationConfig) -> tuple[np.ndarray, np.ndarray]:
    """Sample one plan's via-poses at every step: positions (S, 3) and quaternions (S, 4)."""
    via = np.asarray(via, dtype=np.float64)
    if via.ndim != 2 or via.shape[1] != 7 or via.shape[0] < 1 or not np.all(np.isfinite(via)):
        raise ImaginationError(
            f"a trajectory must be a finite (K, 7) array of via-poses (pos xyz + quat wxyz), K >= 1; "
            f"got shape {via.shape}"
        )
    quats = via[:, 3:] / np.linalg.norm(via[:, 3:], axis=1, keepdims=True)
    pos_list, quat_list = [via[:1, :3]], [quats[:1]]
    for j in range(len(via) - 1):
        dist = float(np.linalg.norm(via[j + 1, :3] - via[j, :3]))
        angle = quat_angle(quats[j], quats[j + 1])
        n = int(np.ceil(max(dist / cfg.agent_speed, angle / cfg.agent_angular_speed) / cfg.timestep))
        if n == 0:
            continue
        f = np.arange(1, n + 1) / n
        pos_list.append(via[j, :3] + f[:, None] * (via[j + 1, :3] - via[j, :3]))
        quat_list.append(slerp(quats[j], quats[j + 1], f))
    return np.concatenate(pos_list), np.concatenate(quat_list)


def plan_rows(trajectories: Sequence, n_poses: int) -> tuple[list[np.ndarray], int]:
    """Drive-table rows and the plan count from trajectories shared by all poses or given per pose.

    ``trajectories`` is either ``[plan] -> (K, 7)`` (one row per plan) or ``[pose][plan] -> (K, 7)``
    (one row per rollout, pose-major), e.g. when via-poses scale with each pose's half extents.
    """
    if not trajectories:
        raise ImaginationError("imagine needs at least one trajectory (plan); got none")
    first = trajectories[0]
    if isinstance(first, np.ndarray) and first.ndim == 2:
        return list(trajectories), len(trajectories)
    if len(trajectories) != n_poses:
        raise ImaginationError(
            f"per-pose trajectories need one list of plans per stable pose: got {len(trajectories)} lists "
            f"for {n_poses} poses (or pass one list of (K, 7) arrays shared by all poses)"
        )
    n_plans = {len(plans) for plans in trajectories}
    if len(n_plans) != 1 or 0 in n_plans:
        raise ImaginationError(f"every stable pose needs the same number (>= 1) of plans; got {sorted(n_plans)}")
    return [np.asarray(t) for plans in trajectories for t in plans], n_plans.pop()


def drive_table(rows: Sequence[np.ndarray], cfg: ImaginationConfig) -> DriveTable:
    """Step-by-step targets for every row (plan); rows past a plan's end repeat its last pose at rest."""
    samples = [_plan_samples(t, cfg) for t in rows]
    if not samples:
        raise ImaginationError("imagine needs at least one trajectory (plan); got none")
    n_drive = np.array([len(p) for p, _ in samples])
    s = int(n_drive.max())
    pos = np.zeros((len(samples), s, 3))
    quat = np.zeros((len(samples), s, 4))
    linvel = np.zeros((len(samples), s, 3))
    angvel = np.zeros((len(samples), s, 3))
    for i, (p, q) in enumerate(samples):
        n = len(p)
        pos[i, :n], pos[i, n:] = p, p[-1]
        quat[i, :n], quat[i, n:] = q, q[-1]
        # the agent is at sample k when step k starts and reaches sample k+1 after it; at the end it is put down at rest
        linvel[i, : n - 1] = (p[1:] - p[:-1]) / cfg.timestep
        angvel[i, : n - 1] = quat_to_angvel(q[:-1], q[1:], cfg.timestep)
    return DriveTable(pos=pos, quat=quat, linvel=linvel, angvel=angvel, n_drive=n_drive)


def _world_rows(rows: list[np.ndarray], poses: Sequence[StablePose], n_plans: int, w: Perturbation) -> list[np.ndarray]:
    """World ``w``'s via-poses of every rollout, pose-major (:func:`~rail_mj.imagination.perturb.world_trajectory`)."""
    return [world_trajectory(rows[j if len(rows) == n_plans else k * n_plans + j], np.asarray(pose.half_extents), w)
            for k, pose in enumerate(poses) for j in range(n_plans)]


def prepare(
    obj: RailObject,
    poses: Sequence[StablePose],
    agents: AgentSetup,
    trajectories: Sequence[np.ndarray] | Sequence[Sequence[np.ndarray]],
    cfg: ImaginationConfig,
    perturbations: PerturbationSet | None = None,
) -> RolloutBatch:
    """Every (stable pose, plan) rollout of ``obj``, pose-major; see :func:`rail_mj.imagination.imagine`.

    With ``perturbations`` (:mod:`rail_mj.imagination.perturb`) the batch holds every world's rollouts,
    world-major: rollouts ``w * poses * plans`` on are world ``w``'s, pose-major as without.
    """
    poses = list(poses)
    if not poses:
        raise ImaginationError("imagine needs at least one stable pose; got none")
    rows, n_plans = plan_rows(trajectories, len(poses))
    if perturbations is None:
        table = drive_table(rows, cfg)
        return RolloutBatch(obj=obj, agents=agents, placement=Placement.of(poses, n_plans, len(rows)), table=table)
    parts, all_rows = [], []
    for w in perturbations.worlds:
        world_rows = list(rows) if w.nominal else _world_rows(rows, poses, n_plans, w)
        parts.append(Placement.of([scaled_pose(p, w.scale) for p in poses], n_plans, len(world_rows)))
        all_rows += world_rows
    return RolloutBatch(obj=obj, agents=agents, placement=Placement.concat(parts, perturbations.worlds),
                        table=drive_table(all_rows, cfg), perturbations=perturbations)


def assemble_outcomes(
    placement: Placement,
    *,
    object_pos: np.ndarray,
    object_quat: np.ndarray,
    agent_pos: np.ndarray,
    agent_quat: np.ndarray,
    agent_vel: np.ndarray,
    contacts: np.ndarray,
    released_early: np.ndarray,
    settled: np.ndarray,
    open_sector: np.ndarray | None = None,
    unstable: np.ndarray | None = None,
    segments: tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> Outcomes:
    """Final world poses → task-frame Outcomes.

    ``object_pos/quat`` (B, 3)/(B, 4) are the object's final world pose, ``agent_pos/quat/vel`` (B, N, ·) the
    agents' (world), ``contacts`` (B, N, 3) per agent with (object, other agents, ground).
    """
    origin, quat = follow_task_frame(placement.origin, placement.object_pos, placement.object_quat,
                                     object_pos, object_quat)
    pos, orientation = to_task_frame(origin, quat, agent_pos, agent_quat)
    return Outcomes(
        pose_index=placement.pose_index.astype(np.int64),
        plan_index=placement.plan_index.astype(np.int64),
        agent_pos=pos,
        agent_quat=orientation,
        agent_vel=agent_vel,
        contacts_object=contacts[..., 0].astype(np.int64),
        contacts_agents=contacts[..., 1].astype(np.int64),
        contacts_ground=contacts[..., 2].astype(np.int64),
        released_early=released_early.astype(bool),
        object_pos=origin - placement.origin,
        object_quat=quat,
        object_tilt=tilt(quat),
        object_half_extents=placement.half_extents.copy(),
        settled=settled.astype(bool),
        agent_open_sector=None if open_sector is None else open_sector.astype(np.int64),
        world=None if placement.world is None else placement.world.astype(np.int64),
        unstable=None if unstable is None else unstable.astype(bool),
        **({} if segments is None else {"segment_names": segments[0], "segment_height": segments[1],
                                        "segment_up": segments[2], "segment_contacts": segments[3],
                                        "segment_reach": segments[4].astype(bool)}),
    )


def outcomes_from_states(
    scene: Scene,
    placement: Placement,
    qpos: np.ndarray,
    qvel: np.ndarray,
    contacts: np.ndarray,
    released_early: np.ndarray,
    settled: np.ndarray,
    unstable: np.ndarray | None = None,
    segments: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> Outcomes:
    """Final world states (B, nq)/(B, nv) of ``scene`` → task-frame Outcomes; ``segments`` stacks an articulated
    agent's :func:`rail_mj.mjcf.segment_state` over the batch.

    A rollout whose state is not finite, or that ``unstable`` (B,) marks (a MuJoCo instability warning), blew
    up: its state is replaced by its placement (agents where the plan starts) so that nothing downstream meets
    a NaN, and ``Outcomes.unstable`` names it, a failure whatever it scores.
    """
    finite = np.all(np.isfinite(qpos), axis=1) & np.all(np.isfinite(qvel), axis=1)
    bad = ~finite if unstable is None else (~finite | unstable)
    if not finite.all():
        qpos, qvel = qpos.copy(), qvel.copy()
        qpos[~finite] = np.nan_to_num(qpos[~finite], nan=0.0, posinf=0.0, neginf=0.0)
        o = scene.object_qpos
        qpos[~finite, o : o + 3] = placement.object_pos[~finite]
        qpos[~finite, o + 3 : o + 7] = placement.object_quat[~finite]
        for a in scene.agent_qpos:
            qpos[~finite, a : a + 3] = placement.origin[~finite]
            qpos[~finite, a + 3 : a + 7] = (1.0, 0.0, 0.0, 0.0)
        qvel[~finite] = 0.0
        if segments is not None:  # a blown-up body's segments: at the ground, level, touching and reaching nothing
            height, up, touching, reach = segments
            keep = finite[:, None, None]
            segments = (np.where(keep, height, 0.0), np.where(keep, up, 0.0), np.where(keep[..., None], touching, 0),
                        keep & reach.astype(bool))
    o = scene.object_qpos
    return assemble_outcomes(
        placement,
        object_pos=qpos[:, o : o + 3],
        object_quat=qpos[:, o + 3 : o + 7],
        agent_pos=np.stack([qpos[:, a : a + 3] for a in scene.agent_qpos], axis=1),
        agent_quat=np.stack([qpos[:, a + 3 : a + 7] for a in scene.agent_qpos], axis=1),
        agent_vel=np.stack([qvel[:, d : d + 3] for d in scene.agent_dof], axis=1),
        contacts=contacts,
        released_early=released_early,
        settled=settled & ~bad,
        open_sector=open_sectors(scene, qpos, placement.scales),
        unstable=bad,
        segments=None if segments is None else (scene.segment_names, *segments),
    )


def _longest_run(escaped: np.ndarray) -> np.ndarray:
    """(..., D) bool around a circle → (...) the longest run of consecutive True (D when all are)."""
    n = escaped.shape[-1]
    run = np.zeros(escaped.shape[:-1], dtype=np.int64)
    best = np.zeros_like(run)
    for k in range(2 * n):  # twice round, so a run across direction 0 counts whole
        run = np.where(escaped[..., k % n], run + 1, 0)
        best = np.maximum(best, run)
    return np.minimum(best, n)


def open_sectors(scene: Scene, qpos: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
    """The enclosure probe on final states (B, nq): for each agent, the most consecutive of
    :data:`PROBE_DIRECTIONS` horizontal directions from its centre that leave without meeting the object (B, N).

    Droplets in a cavity meet a wall every way (0); on an upturned table, between its legs, or on a seat open
    at the front, a whole sector is free. Rays meet the object's own surface (:attr:`Scene.surface`): its hulls
    fill out thin parts, and an upturned desk's hull-thickened top walls droplets in that its open front lets
    go. A direction is free only when all :data:`_SUB_RAYS` rays across its sector are, so a slot narrower
    than their spread at the wall (a basket's, between its slats) is no way out. ``scale`` (B,): the mesh scale
    of each state's world (the surface is the nominal one; rays start at the point scaled back to it).
    """
    out = np.zeros((qpos.shape[0], scene.n_agents), dtype=np.int64)
    data = scene.surface_data
    if scene.surface is None or data is None:  # a scene without agents: nothing to probe
        return out
    n_rays = PROBE_DIRECTIONS * _SUB_RAYS
    geomid = np.zeros(n_rays, dtype=np.int32)
    dist = np.zeros(n_rays)
    rot = np.zeros(9)
    o = scene.object_qpos
    for b in range(qpos.shape[0]):
        mujoco.mju_quat2Mat(rot, qpos[b, o + 3 : o + 7])
        to_object = rot.reshape(3, 3).T  # world -> object frame, where the surface model holds the mesh
        vecs = np.ascontiguousarray((_SUB_VEC @ to_object.T).ravel())
        escaped = np.zeros((scene.n_agents, n_rays), dtype=bool)
        for i, a in enumerate(scene.agent_qpos):
            p = to_object @ (qpos[b, a : a + 3] - qpos[b, o : o + 3]) / (1.0 if scale is None else scale[b])
            mujoco.mj_multiRay(scene.surface, data, p, vecs, None, True, -1, geomid, dist, None, n_rays, 100.0)
            escaped[i] = geomid < 0
        out[b] = _longest_run(
            cast(np.ndarray, escaped.reshape(scene.n_agents, PROBE_DIRECTIONS, _SUB_RAYS).all(axis=2))
        )
    return out
