"""Backend-independent parts of the imagination: config, scene, trajectories, outcomes.

Both backends compile the same scene (object free body, agents with free
joints, ground), put every per-rollout difference in the state (object pose,
agent drive tables), and turn the final states into the same :class:`Outcomes`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from rail_mj.errors import ImaginationError, SceneError
from rail_mj.mjcf import GROUND_BIT, OBJECT_BIT, build_scene
from rail_mj.types import AgentSetup, Outcomes, RailObject, StablePose

__all__ = [
    "ImaginationConfig",
    "Scene",
    "DriveTable",
    "build_scene_model",
    "drive_table",
    "initial_state",
    "assemble_outcomes",
    "count_contacts",
    "at_rest",
    "quat_mul",
    "quat_conj",
    "quat_rotate",
]

#: geom class codes in Scene.geom_owner (agents are 0..N-1)
GROUND = -1
OBJECT = -2


class ImaginationConfig(BaseModel):
    """Physics and driving settings of the imagination rollouts."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    timestep: float = Field(0.005, gt=0, le=0.02, description="simulation step, s")
    solref_factor: float = Field(2.5, ge=2.0, description="contact time constant as a multiple of the timestep")
    friction: float = Field(1.0, gt=0, description="sliding friction of every geom")
    agent_speed: float = Field(0.5, gt=0, description="linear speed of the driven layout centre, m/s")
    agent_angular_speed: float = Field(3.0, gt=0, description="angular speed of the driven layout centre, rad/s")
    settle_time: float = Field(3.0, gt=0, description="longest simulated time after the drive, s")
    settle_speed: float = Field(0.02, gt=0, description="a body is at rest when no point of it moves faster, m/s")
    check_every: int = Field(20, ge=1, description="steps between settle checks")
    iterations: int = Field(20, ge=1, description="constraint solver iterations")
    ls_iterations: int = Field(10, ge=1, description="solver line-search iterations")
    nthread: int = Field(0, ge=0, description="native threads; 0 = all CPUs")
    max_hull_vertices: int = Field(32, ge=4, description="MuJoCo simplifies each hull to at most this many vertices")
    speculative: bool = Field(
        True, description="speculative contacts (native): fast small droplets do not tunnel through thin bottoms"
    )


@dataclass(frozen=True)
class Scene:
    """A compiled imagination scene and the ids the backends need (computed once)."""

    model: mujoco.MjModel
    n_agents: int
    object_qpos: int  # qpos address of the object's free joint
    object_dof: int
    agent_qpos: np.ndarray  # (N,) qpos address of each agent's free joint
    agent_dof: np.ndarray  # (N,)
    geom_owner: np.ndarray  # (ngeom,) agent index, GROUND or OBJECT

    @property
    def free_dofs(self) -> np.ndarray:
        """dof addresses of every free joint (object first), (1 + N,)."""
        return np.concatenate([[self.object_dof], self.agent_dof]).astype(np.int64)

    @property
    def free_radius(self) -> np.ndarray:
        """Bounding radius of each free body (object first), about its frame origin, (1 + N,)."""
        m = self.model
        bodies = m.dof_bodyid[self.free_dofs]
        reach = np.linalg.norm(m.geom_pos, axis=1) + m.geom_rbound
        return np.array([reach[m.geom_bodyid == b].max() for b in bodies])


@dataclass(frozen=True)
class DriveTable:
    """Per-plan kinematic targets of the layout centre, one row per step, task frame at placement."""

    pos: np.ndarray  # (P, S, 3)
    quat: np.ndarray  # (P, S, 4)
    linvel: np.ndarray  # (P, S, 3) world
    angvel: np.ndarray  # (P, S, 3) body-local, as free-joint qvel
    n_drive: np.ndarray  # (P,) steps during which the agents are driven (rows used)


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of wxyz quaternions, broadcasting over leading axes."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def quat_conj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v by unit quaternions q (broadcasting)."""
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _quat_to_angvel(q0: np.ndarray, q1: np.ndarray, dt: float) -> np.ndarray:
    """Body-local angular velocity turning q0 into q1 in dt."""
    dq = quat_mul(quat_conj(q0), q1)
    dq = np.where(dq[..., :1] < 0, -dq, dq)
    s = np.linalg.norm(dq[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, dq[..., :1])
    axis = np.divide(dq[..., 1:], s, out=np.zeros_like(dq[..., 1:]), where=s > 1e-12)
    return axis * angle / dt


def _slerp(q0: np.ndarray, q1: np.ndarray, f: np.ndarray) -> np.ndarray:
    d = float(np.dot(q0, q1))
    if d < 0:
        q1, d = -q1, -d
    if d > 0.9995:
        q = q0[None] + f[:, None] * (q1 - q0)[None]
    else:
        th = np.arccos(d)
        q = (np.sin((1 - f) * th)[:, None] * q0 + np.sin(f * th)[:, None] * q1) / np.sin(th)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _plan_samples(via: np.ndarray, cfg: ImaginationConfig) -> tuple[np.ndarray, np.ndarray]:
    """Sample one plan's via-poses at every step: positions (S, 3) and quaternions (S, 4)."""
    via = np.asarray(via, dtype=np.float64)
    if via.ndim != 2 or via.shape[1] != 7 or via.shape[0] < 1 or not np.all(np.isfinite(via)):
        raise ImaginationError(
            f"a trajectory must be a finite (K, 7) array of via-poses (pos xyz + quat wxyz), K >= 1; got shape {via.shape}"
        )
    quats = via[:, 3:] / np.linalg.norm(via[:, 3:], axis=1, keepdims=True)
    pos_list, quat_list = [via[:1, :3]], [quats[:1]]
    for j in range(len(via) - 1):
        dist = float(np.linalg.norm(via[j + 1, :3] - via[j, :3]))
        angle = 2.0 * np.arccos(min(1.0, abs(float(np.dot(quats[j], quats[j + 1])))))
        n = int(np.ceil(max(dist / cfg.agent_speed, angle / cfg.agent_angular_speed) / cfg.timestep))
        if n == 0:
            continue
        f = np.arange(1, n + 1) / n
        pos_list.append(via[j, :3] + f[:, None] * (via[j + 1, :3] - via[j, :3]))
        quat_list.append(_slerp(quats[j], quats[j + 1], f))
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


def drive_table(trajectories: Sequence[np.ndarray], cfg: ImaginationConfig, pad_to: int = 0) -> DriveTable:
    """Step-by-step targets for every row (plan); rows past a plan's end repeat its last pose at rest."""
    samples = [_plan_samples(t, cfg) for t in trajectories]
    if not samples:
        raise ImaginationError("imagine needs at least one trajectory (plan); got none")
    n_drive = np.array([len(p) for p, _ in samples])
    s = max(int(n_drive.max()), pad_to)
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
        angvel[i, : n - 1] = _quat_to_angvel(q[:-1], q[1:], cfg.timestep)
    return DriveTable(pos=pos, quat=quat, linvel=linvel, angvel=angvel, n_drive=n_drive)


def build_scene_model(
    obj: RailObject,
    agents: AgentSetup | None,
    cfg: ImaginationConfig,
    *,
    hull_boxes: int = 0,
    inertial: tuple[float, np.ndarray, np.ndarray, np.ndarray] | None = None,
    joint_damping: float = 0.0,
    rolling_friction: float = 0.0,
) -> Scene:
    """Compile the one-world scene: ground, free object (hull meshes, or ``hull_boxes`` padded boxes), free agents.

    ``inertial`` = (mass, ipos, inertia diag, iquat) overrides the object's inertia so box and mesh scenes weigh the same.
    """
    try:
        spec = build_scene(obj, object_free=True, agents=agents, timestep=cfg.timestep, hull_boxes=hull_boxes,
                           max_hull_vertices=cfg.max_hull_vertices)
    except SceneError as exc:
        raise ImaginationError(f"the imagination scene for {obj.name!r} cannot be built: {exc}") from exc
    spec.modelname = "rail_imagination"  # MJX keeps names static: one name per bucket, not per object
    spec.option.iterations = cfg.iterations
    spec.option.ls_iterations = cfg.ls_iterations
    if cfg.speculative and not hull_boxes:  # MJX (box scenes) does not implement the flag
        spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SPECULATIVE
    for g in spec.geoms:
        if g.contype or g.conaffinity:
            g.solref = [cfg.solref_factor * cfg.timestep, 1.0]
            if g.contype & (GROUND_BIT | OBJECT_BIT):  # agents keep their fragment's friction
                g.friction = [cfg.friction, 0.005, 0.0001]
    obj_body = spec.body("object")
    if inertial is not None:
        mass, ipos, inertia, iquat = inertial
        obj_body.explicitinertial = True
        obj_body.mass, obj_body.ipos, obj_body.inertia, obj_body.iquat = mass, ipos, inertia, iquat
    if joint_damping or rolling_friction:
        spec.joint("object").damping = [joint_damping, 0.0, 0.0]
        for g in obj_body.geoms:
            g.condim = 6
            g.friction = [cfg.friction, rolling_friction, rolling_friction]
    n_agents = 0 if agents is None else len(agents.offsets)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise ImaginationError(f"the imagination scene for {obj.name!r} does not compile: {exc}") from exc
    owner = np.full(model.ngeom, OBJECT, dtype=np.int64)
    owner[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "ground")] = GROUND
    agent_qpos = np.zeros(n_agents, dtype=np.int64)
    agent_dof = np.zeros(n_agents, dtype=np.int64)
    for i in range(n_agents):
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"agent{i}/free")
        agent_qpos[i], agent_dof[i] = model.jnt_qposadr[jid], model.jnt_dofadr[jid]
        owner[model.geom_bodyid == model.jnt_bodyid[jid]] = i
    jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "object")
    return Scene(model=model, n_agents=n_agents, object_qpos=int(model.jnt_qposadr[jid]), object_dof=int(model.jnt_dofadr[jid]),
                 agent_qpos=agent_qpos, agent_dof=agent_dof, geom_owner=owner)


def initial_state(scene: Scene, poses: Sequence[StablePose], n_plans: int, table: DriveTable, offsets: np.ndarray) -> dict[str, np.ndarray]:
    """Per-rollout placement (pose-major): qpos (B, nq), task-frame origins (B, 3), half extents, indices.

    ``row`` maps each rollout to its row of the drive table.
    """
    n_poses = len(poses)
    pose_index = np.repeat(np.arange(n_poses), n_plans)
    plan_index = np.tile(np.arange(n_plans), n_poses)
    half = np.stack([np.asarray(p.half_extents, dtype=np.float64) for p in poses])[pose_index]
    origin = np.zeros((len(pose_index), 3))
    origin[:, 2] = half[:, 2]
    qpos = np.tile(scene.model.qpos0, (len(pose_index), 1))
    obj_pos = np.stack([np.asarray(p.pos, dtype=np.float64) for p in poses])[pose_index]
    obj_quat = np.stack([np.asarray(p.quat, dtype=np.float64) for p in poses])[pose_index]
    qpos[:, scene.object_qpos : scene.object_qpos + 3] = obj_pos
    qpos[:, scene.object_qpos + 3 : scene.object_qpos + 7] = obj_quat
    # the drive table holds one row per plan (shared by all poses) or one per rollout (pose-major)
    row = plan_index if len(table.n_drive) == n_plans else np.arange(len(pose_index))
    start_pos = origin[:, None, :] + table.pos[row, 0][:, None, :] + offsets[None]
    for i, adr in enumerate(scene.agent_qpos):
        qpos[:, adr : adr + 3] = start_pos[:, i]
        qpos[:, adr + 3 : adr + 7] = table.quat[row, 0]
    return dict(
        qpos=qpos, origin=origin, half=half, obj_pos=obj_pos, obj_quat=obj_quat,
        pose_index=pose_index, plan_index=plan_index, row=row,
    )


def at_rest(qvel, scene: Scene, cfg: ImaginationConfig, xp=np):
    """Whether every free body of each world is slower than ``settle_speed``; qvel (..., nv) → (...).

    A body's speed bound is |v| + |w| r (r = its bounding radius), so a rolling droplet and a spinning cup count alike.
    """
    lin = xp.stack([qvel[..., d : d + 3] for d in scene.free_dofs], axis=-2)
    ang = xp.stack([qvel[..., d + 3 : d + 6] for d in scene.free_dofs], axis=-2)
    speed = xp.linalg.norm(lin, axis=-1) + xp.linalg.norm(ang, axis=-1) * scene.free_radius
    return xp.all(speed < cfg.settle_speed, axis=-1)


def count_contacts(geom_owner: np.ndarray, geom_pairs: np.ndarray, n_agents: int) -> np.ndarray:
    """Contact points per agent, split (object, other agents, ground): (N, 3) from (ncon, 2) geom ids."""
    out = np.zeros((n_agents, 3), dtype=np.int64)
    if len(geom_pairs) == 0:
        return out
    a, b = geom_owner[geom_pairs[:, 0]], geom_owner[geom_pairs[:, 1]]
    for x, y in ((a, b), (b, a)):
        is_agent = x >= 0
        kind = np.where(y == OBJECT, 0, np.where(y == GROUND, 2, 1))
        np.add.at(out, (x[is_agent], kind[is_agent]), 1)
    return out


def assemble_outcomes(
    scene: Scene,
    init: dict[str, np.ndarray],
    qpos: np.ndarray,
    qvel: np.ndarray,
    contacts: np.ndarray,
    released_early: np.ndarray,
    settled: np.ndarray,
) -> Outcomes:
    """Final world states (B, nq)/(B, nv) → task-frame Outcomes."""
    o = scene.object_qpos
    p1, q1 = qpos[:, o : o + 3], qpos[:, o + 3 : o + 7]
    p0, q0 = init["obj_pos"], init["obj_quat"]
    # the task frame rides on the object: its offset from the object origin, in object coordinates, is fixed
    rel = quat_rotate(quat_conj(q0), init["origin"] - p0)
    task_quat = quat_mul(q1, quat_conj(q0))
    task_quat /= np.linalg.norm(task_quat, axis=-1, keepdims=True)
    task_origin = p1 + quat_rotate(q1, rel)
    agent_world = np.stack([qpos[:, a : a + 3] for a in scene.agent_qpos], axis=1)
    agent_wquat = np.stack([qpos[:, a + 3 : a + 7] for a in scene.agent_qpos], axis=1)
    inv = quat_conj(task_quat)[:, None, :]
    agent_pos = quat_rotate(inv, agent_world - task_origin[:, None, :])
    agent_quat = quat_mul(np.broadcast_to(inv, agent_wquat.shape), agent_wquat)
    agent_vel = np.stack([qvel[:, d : d + 3] for d in scene.agent_dof], axis=1)
    up = quat_rotate(task_quat, np.array([0.0, 0.0, 1.0]))
    tilt = np.arccos(np.clip(up[:, 2], -1.0, 1.0))
    return Outcomes(
        pose_index=init["pose_index"].astype(np.int64),
        plan_index=init["plan_index"].astype(np.int64),
        agent_pos=agent_pos,
        agent_quat=agent_quat,
        agent_vel=agent_vel,
        contacts_object=contacts[..., 0].astype(np.int64),
        contacts_agents=contacts[..., 1].astype(np.int64),
        contacts_ground=contacts[..., 2].astype(np.int64),
        released_early=released_early.astype(bool),
        object_pos=task_origin - init["origin"],
        object_quat=task_quat,
        object_tilt=tilt,
        object_half_extents=init["half"].copy(),
        settled=settled.astype(bool),
    )
