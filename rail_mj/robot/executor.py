"""The Panda executes an imagined interaction: place the object, carry the agent, release, judge.

The object rests on a table in its stable pose; the agent (scaled to a graspable
size) is welded below the fingertips; the path through the via-poses is solved by
mink IK (``rail_mj.robot.ik``: joint limits, the hand kept off the table and the
object) every ``RobotConfig.ik_step`` and followed with Cartesian impedance
control whose null-space posture tracks those solutions; a contact force above
``RobotConfig.force_limit`` on the hand or the held agent stops the motion (hold
or retreat) and the agent is released there, as the imagination releases agents
on first collision. A via-pose that only a hand in contact reaches (the plan
presses the agent onto a surface) is kept as the impedance target, and the force
limit ends that press. The
end state is turned into a one-rollout :class:`rail_mj.core.types.Outcomes` (N = 1,
the table plays the ground) and scored with the plan's scoring function.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import mujoco
import numpy as np

from rail_mj.core.errors import FragmentError, RobotError
from rail_mj.core.geometry import quat_angle, quat_conj, quat_rotate, slerp
from rail_mj.imagination.batch import Placement, assemble_outcomes
from rail_mj.mjcf import (
    OBJECT_BODY,
    OBJECT_JOINT,
    OWNER_GROUND,
    OWNER_OBJECT,
    OWNER_OTHER,
    ScenePhysics,
    add_agent,
    add_object,
    agent_prefix,
    check_fragment,
    count_contacts,
)
from rail_mj.robot.control import (
    HOME_QPOS,
    MONITORED_BODIES,
    ArmIndex,
    RobotConfig,
    contact_force,
    impedance_torque,
    make_torque_controlled,
)
from rail_mj.robot.ik import ArmIK
from rail_mj.robot.model import load_panda_spec
from rail_mj.core.types import Outcomes, RailObject, StablePose

__all__ = [
    "ScoringFunction",
    "ForceEvent",
    "ExecutionResult",
    "RobotScene",
    "build_scene",
    "side_grasp",
    "DriveResult",
    "drive",
    "execute",
    "caption_lines",
    "VIDEO_SIZE",
    "VIDEO_FPS",
]

#: A compiled scoring function: outcomes of B rollouts -> (B,) scores, success where > 0.
ScoringFunction = Callable[[Outcomes], np.ndarray]

#: Hand z below the hand frame where the fingertips end (Menagerie finger mesh), m.
_FINGERTIP_Z = 0.1125
#: Agent frame -> hand frame: the hand points down (its z = the agent's -z).
_GRASP_QUAT = np.array([0.0, 1.0, 0.0, 0.0])
#: A plan whose path runs at least this far, and more horizontally than vertically, may be held from the side, m.
_SIDE_PUSH = 0.01
_PRIMITIVES = (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_CAPSULE,
               mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_ELLIPSOID)
#: Video frames: (width, height) in pixels and frames per simulated second.
VIDEO_SIZE = (640, 480)
VIDEO_FPS = 25


@dataclass(frozen=True)
class ForceEvent:
    """One crossing of the contact-force limit."""

    time: float  # s since the start of the execution
    force: float  # N, measured when the limit was crossed
    phase: str  # approach | trajectory | hold | lift
    waypoint: int  # index of the via-pose being approached (-1 before the trajectory)
    action: str  # hold | retreat | none (after release nothing is pushing)


@dataclass(frozen=True)
class ExecutionResult:
    """What happened when the robot executed one plan."""

    success: bool
    score: float  # nan when not scored (unreachable, or scoring=None)
    reachable: bool
    message: str
    peak_force: float  # N, peak net contact force on hand + held agent
    force_limit: float
    force_events: tuple[ForceEvent, ...]
    agent_pos: np.ndarray  # (3,) final agent centre, task frame
    agent_quat: np.ndarray  # (4,) wxyz, task frame
    object_tilt: float  # rad
    outcomes: Outcomes | None
    ik_residual: float  # worst IK position residual over the path samples (the hand allowed to touch), m
    agent_scale: float  # factor applied to the agent fragment
    timings: dict[str, float] = field(default_factory=dict)
    ik_blocked: int = 0  # path samples where IK kept the hand off an obstacle the plan would have it touch

    def to_dict(self) -> dict:
        """JSON-ready summary (no arrays of the outcomes)."""
        return {
            "success": self.success,
            "score": None if np.isnan(self.score) else float(self.score),
            "reachable": self.reachable,
            "message": self.message,
            "peak_force": self.peak_force,
            "force_limit": self.force_limit,
            "force_events": [vars(e) for e in self.force_events],
            "agent_pos": self.agent_pos.tolist(),
            "object_tilt": self.object_tilt,
            "ik_residual": self.ik_residual,
            "agent_scale": self.agent_scale,
            "ik_blocked": self.ik_blocked,
            "timings": self.timings,
        }


@dataclass(frozen=True)
class RobotScene:
    """A compiled robot + table (+ object + agent) scene and the ids used during execution."""

    model: mujoco.MjModel
    arm: ArmIndex
    agent_body: int  # -1 without agent
    weld: int  # -1 without agent
    agent_qpos: int  # qpos address of the agent's free joint
    agent_dof: int
    object_body: int  # -1 without object
    object_qpos: int
    object_dof: int
    monitored: np.ndarray  # (ngeom,) bool: hand geoms
    agent_geoms: np.ndarray  # (ngeom,) bool
    geom_owner: np.ndarray  # (ngeom,) rail_mj.mjcf owner codes: agent 0, object, ground (table, floor), other
    task_origin: np.ndarray  # (3,) world position of the task frame at placement
    half_extents: np.ndarray  # (3,)
    agent_scale: float
    agent_solref: np.ndarray  # (n_agent_geoms, 2) the composer's (the imagination's) solref, restored at release
    ik: ArmIK  # the scene's mink solver for the control site


def _agent_spec(fragment: str, scale: float) -> mujoco.MjSpec:
    """The checked fragment (``rail_mj.mjcf.check_fragment``: untrusted MJCF) scaled by ``scale``."""
    spec = check_fragment(fragment)
    for i, g in enumerate(spec.geoms):
        if g.type not in _PRIMITIVES:
            raise FragmentError(f"agent geom {i} has type {g.type.name}; the robot carries primitive agents only "
                                f"({', '.join(t.name for t in _PRIMITIVES)})")
        g.pos = np.asarray(g.pos) * scale
        g.size = np.asarray(g.size) * scale
        if not np.isnan(g.fromto[0]):
            g.fromto = np.asarray(g.fromto) * scale
        if not np.isnan(g.mass):
            g.mass = g.mass * scale**3
    top = spec.worldbody.first_body()
    nested = top.find_all(mujoco.mjtObj.mjOBJ_BODY)
    for body in nested:
        body.pos = np.asarray(body.pos) * scale
    for body in [top, *nested]:
        if body.explicitinertial:
            body.mass, body.ipos = body.mass * scale**3, np.asarray(body.ipos) * scale
            body.inertia = np.asarray(body.inertia) * scale**5
    return spec


def _agent_extent(fragment: str) -> np.ndarray:
    """Full size of the agent body's axis-aligned box in its own frame, (3,)."""
    model = check_fragment(fragment).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    body = 1  # the fragment's top body (0 is the world)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for g in range(model.ngeom):
        rot = data.geom_xmat[g].reshape(3, 3)
        centre = data.geom_xpos[g] + rot @ model.geom_aabb[g, :3] - data.xpos[body]
        half = np.abs(rot) @ model.geom_aabb[g, 3:]
        lo, hi = np.minimum(lo, centre - half), np.maximum(hi, centre + half)
    return hi - lo


def _hand_z(grasp: np.ndarray) -> np.ndarray:
    """The hand's z axis (where the fingers point) in the agent's frame, for the grasp ``grasp``."""
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, np.asarray(grasp, dtype=np.float64))
    return rot.reshape(3, 3)[2]


def _grasp_depth(extent: np.ndarray, grasp: np.ndarray) -> float:
    """Half the agent's box (full size ``extent``, its own frame) along the hand's z for the grasp ``grasp``."""
    return float(np.abs(_hand_z(grasp)) @ extent / 2)


def side_grasp(direction: np.ndarray, fingers_vertical: bool = False) -> np.ndarray:
    """The grasp (agent frame -> hand frame, wxyz) of a hand pointing along ``direction`` (agent frame, horizontal):
    it holds the item from behind as it pushes it, the fingers closing across it horizontally or vertically."""
    z = np.array([direction[0], direction[1], 0.0])
    z /= np.linalg.norm(z)
    y = np.array([0.0, 0.0, 1.0]) if fingers_vertical else np.array([-z[1], z[0], 0.0])
    hand_in_agent = np.column_stack([np.cross(y, z), y, z])
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, hand_in_agent.T.ravel())
    return quat


def build_scene(cfg: RobotConfig, *, obj: RailObject | None = None, pose: StablePose | None = None,
                agent_fragment: str | None = None, agent_scale: float = 1.0,
                boxes: tuple[tuple[np.ndarray, np.ndarray], ...] = (), visual: bool | None = None,
                grasp: np.ndarray = _GRASP_QUAT) -> RobotScene:
    """Compile the torque-controlled Panda on a floor, a table, the placed object and the welded agent.

    The object and the agent come from the imagination's scene composer (``rail_mj.mjcf``), with its contact
    constants at the robot's timestep; the table and floor are the ground. ``boxes`` adds fixed boxes
    ``(centre, half_size)`` in the world (used for scripted collisions). ``grasp``: how the hand holds the agent
    (agent frame -> hand frame): from above by default, or :func:`side_grasp`.
    """
    spec = load_panda_spec(visual=cfg.visual if visual is None else visual)
    make_torque_controlled(spec)
    spec.option.timestep = cfg.dt
    physics = ScenePhysics(timestep=cfg.dt)
    floor = spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.05],
                                    rgba=[0.3, 0.35, 0.4, 1])
    tx, ty = cfg.object_xy
    th = cfg.table_height
    sx, sy = cfg.table_half_size
    table = spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=[sx, sy, th / 2],
                                    pos=[tx, ty, th / 2], rgba=[0.6, 0.6, 0.55, 1])
    for ground in (floor, table):
        ground.solref, ground.friction = physics.solref, physics.friction3
    for i, (centre, half) in enumerate(boxes):
        spec.worldbody.add_geom(name=f"box{i}", type=mujoco.mjtGeom.mjGEOM_BOX, size=half, pos=centre,
                                rgba=[0.7, 0.2, 0.2, 1])
    half_extents = np.zeros(3)
    shift = np.array([tx, ty, th])
    if obj is not None:
        if pose is None:
            raise RobotError("build_scene: an object needs its stable pose")
        half_extents = np.asarray(pose.half_extents, dtype=float)
        add_object(spec, obj, pos=np.asarray(pose.pos, dtype=float) + shift, quat=np.asarray(pose.quat, dtype=float),
                   physics=physics)
    grip_z = _FINGERTIP_Z
    agent_name = ""
    agent_geoms: list[mujoco.MjsGeom] = []
    if agent_fragment is not None:
        agent = add_agent(spec, _agent_spec(agent_fragment, agent_scale), 0, pos=(0.0, 0.0, 0.0),
                          quat=(1.0, 0.0, 0.0, 0.0), physics=physics)
        agent_name = agent.name
        agent_geoms = agent.find_all(mujoco.mjtObj.mjOBJ_GEOM)
        grip_z += _grasp_depth(_agent_extent(agent_fragment) * agent_scale, grasp) + cfg.grip_gap
        for name in ("hand", "left_finger", "right_finger"):
            spec.add_exclude(bodyname1=name, bodyname2=agent_name)
        spec.add_equality(type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_BODY, name="hold",
                          name1="hand", name2=agent_name,
                          data=[0, 0, 0, 0, 0, grip_z, *grasp, 1, 0])
    spec.body("hand").add_site(name="grip", pos=[0, 0, grip_z], quat=list(grasp))
    for geom in [g for g in spec.geoms if g.parent.name in MONITORED_BODIES] + agent_geoms:
        geom.solref = [cfg.compliance, 1.0]
    try:
        model = spec.compile()
    except Exception as exc:  # MuJoCo compile errors
        raise RobotError(f"robot scene does not compile: {exc}") from exc

    has_agent = agent_fragment is not None
    agent_body = model.body(agent_name).id if has_agent else -1
    agent_joint = model.joint(agent_prefix(0) + "free").id if has_agent else -1
    objb = model.body(OBJECT_BODY).id if obj is not None else -1
    object_joint = model.joint(OBJECT_JOINT).id if obj is not None else -1
    owner = np.full(model.ngeom, OWNER_OTHER, dtype=np.int64)
    owner[[model.geom("floor").id, model.geom("table").id]] = OWNER_GROUND
    root = model.body_rootid[model.geom_bodyid]
    if obj is not None:
        owner[root == objb] = OWNER_OBJECT
    if has_agent:
        owner[root == agent_body] = 0
    arm = ArmIndex.of(model, "grip")
    return RobotScene(
        model=model,
        arm=arm,
        agent_body=agent_body,
        weld=model.equality("hold").id if has_agent else -1,
        agent_qpos=int(model.jnt_qposadr[agent_joint]) if has_agent else -1,
        agent_dof=int(model.jnt_dofadr[agent_joint]) if has_agent else -1,
        object_body=objb,
        object_qpos=int(model.jnt_qposadr[object_joint]) if obj is not None else -1,
        object_dof=int(model.jnt_dofadr[object_joint]) if obj is not None else -1,
        monitored=np.isin(model.geom_bodyid, [model.body(n).id for n in MONITORED_BODIES]),
        agent_geoms=owner == 0,
        geom_owner=owner,
        task_origin=shift + np.array([0.0, 0.0, half_extents[2]]),
        half_extents=half_extents,
        agent_scale=agent_scale,
        agent_solref=np.tile(physics.solref, (int((owner == 0).sum()), 1)),
        ik=ArmIK(model, arm, min_distance=cfg.ik_clearance),
    )


class _Sim:
    """One execution's mutable state: data, force bookkeeping, optional frame capture."""

    def __init__(self, scene: RobotScene, cfg: RobotConfig, camera: mujoco.MjvCamera | None):
        self.scene, self.cfg = scene, cfg
        self.model = scene.model
        self.data = mujoco.MjData(self.model)
        self.posture = HOME_QPOS.copy()
        self.gripper = 0.0
        self.held = scene.agent_body >= 0
        self.peak = 0.0
        self.events: list[ForceEvent] = []
        self.over = False  # currently above the limit (an event is logged once per crossing)
        self.frames: list[np.ndarray] = []
        self.frame_info: list[tuple[float, str, float]] = []  # (time s, phase, hand force N) of each frame
        self.phase = "approach"
        self.camera = camera
        self.renderer = None
        if camera is not None:
            # software GL spends ~0.6 s a frame on the shadow map and multisampling: ~25 ms without them
            self.model.light_castshadow[:] = False
            self.model.vis.quality.offsamples = 0
            self.model.vis.global_.offwidth = max(self.model.vis.global_.offwidth, VIDEO_SIZE[0])
            self.model.vis.global_.offheight = max(self.model.vis.global_.offheight, VIDEO_SIZE[1])
            self.renderer = mujoco.Renderer(self.model, *VIDEO_SIZE[::-1])
        self.frame_every = max(1, int(round(1 / (VIDEO_FPS * cfg.dt))))
        self.steps = 0

    def site_pose(self) -> tuple[np.ndarray, np.ndarray]:
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, self.data.site_xmat[self.scene.arm.site])
        return self.data.site_xpos[self.scene.arm.site].copy(), q

    def step(self, pos: np.ndarray, quat: np.ndarray, vel: np.ndarray) -> float:
        arm = self.scene.arm
        self.data.ctrl[arm.act] = impedance_torque(self.model, self.data, arm, self.cfg, pos, quat, vel,
                                                   self.posture)
        self.data.ctrl[arm.gripper_act] = self.gripper
        mujoco.mj_step(self.model, self.data)
        self.steps += 1
        mask = self.scene.monitored | (self.scene.agent_geoms if self.held else False)
        force = contact_force(self.model, self.data, mask)
        self.peak = max(self.peak, force)
        if self.renderer is not None and self.steps % self.frame_every == 0:
            self.renderer.update_scene(self.data, camera=self.camera)
            self.frames.append(self.renderer.render().copy())
            self.frame_info.append((float(self.data.time), self.phase, force))
        return force

    def crossed(self, force: float, phase: str, waypoint: int, action: str) -> bool:
        """Log a force-limit event when the force crosses the limit (with 20 % hysteresis)."""
        limit = self.cfg.force_limit
        if force > limit and not self.over:
            self.over = True
            self.events.append(ForceEvent(self.data.time, force, phase, waypoint, action))
            return True
        if force < 0.8 * limit:
            self.over = False
        return False


def _video_camera(scene: RobotScene, sols: np.ndarray, targets: list[tuple[np.ndarray, np.ndarray]]
                  ) -> mujoco.MjvCamera:
    """One fixed camera for the whole video: from the side of the base-to-object line, a little in front,
    fitted to the arm in its home posture and at every IK solution, the agent's path and the object."""
    from rail_mj.render.scene import fit_camera

    model = scene.model
    data = mujoco.MjData(model)
    robot = scene.geom_owner == OWNER_OTHER
    points = [p for p, _ in targets]
    for q in [HOME_QPOS, *sols]:
        data.qpos[scene.arm.qpos] = q
        mujoco.mj_kinematics(model, data)
        points.extend(data.geom_xpos[robot])
    signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    points.extend(scene.task_origin + signs * scene.half_extents)
    side = math.degrees(math.atan2(scene.task_origin[1], scene.task_origin[0])) + 120.0
    return fit_camera(np.array(points), side, -22.0, fovy=float(model.vis.global_.fovy),
                      aspect=VIDEO_SIZE[0] / VIDEO_SIZE[1])


def _posture_at(start: np.ndarray, samples: np.ndarray, t: float) -> np.ndarray:
    """The null-space posture at fraction ``t`` of a segment: linear between the IK solutions sampled evenly
    along it (``samples[-1]`` at the waypoint), starting from the posture held at the segment's start."""
    knots = np.vstack([start, samples])
    x = t * len(samples)
    i = min(int(x), len(samples) - 1)
    return knots[i] + (x - i) * (knots[i + 1] - knots[i])


def _follow(sim: _Sim, waypoints: list[tuple[np.ndarray, np.ndarray]], postures: list[np.ndarray],
            phase: str, first_index: int) -> bool:
    """Move through the waypoints, the posture along each segment following its ``(M, 7)`` IK samples; on a
    force-limit crossing stop (hold/retreat). True if stopped early."""
    cfg = sim.cfg
    sim.phase = phase
    speed = cfg.guarded_speed if phase == "trajectory" else cfg.speed
    p0, q0 = sim.site_pose()
    for k, ((p1, q1), samples) in enumerate(zip(waypoints, postures)):
        start = sim.posture.copy()
        dist = float(np.linalg.norm(p1 - p0))
        duration = max(dist / speed, quat_angle(q0, q1) / cfg.angular_speed, cfg.dt)
        n = int(np.ceil(duration / cfg.dt))
        vel = (p1 - p0) / duration
        for i in range(1, n + 1):
            t = i / n
            sim.posture = _posture_at(start, samples, t)
            force = sim.step(p0 + t * (p1 - p0), slerp(q0, q1, t), vel)
            index = first_index + k if first_index >= 0 else -1
            if sim.crossed(force, phase, index, cfg.on_force_limit):
                _stop(sim, vel)
                return True
        p0, q0 = p1, q1
    return False


def _stop(sim: _Sim, vel: np.ndarray) -> None:
    """The safety rule: stop pushing — hold where the hand is, or back off along the motion."""
    cfg = sim.cfg
    pos, quat = sim.site_pose()
    if cfg.on_force_limit == "retreat":
        speed = float(np.linalg.norm(vel))
        away = -vel / speed if speed > 0 else np.array([0.0, 0.0, 1.0])
        pos = pos + cfg.retreat_distance * away
    _hold(sim, pos, quat, cfg.hold_time, "hold")


def _hold(sim: _Sim, pos: np.ndarray, quat: np.ndarray, seconds: float, phase: str) -> None:
    sim.phase = phase
    for _ in range(int(np.ceil(seconds / sim.cfg.dt))):
        sim.crossed(sim.step(pos, quat, np.zeros(3)), phase, -1, "none")


@dataclass(frozen=True)
class DriveResult:
    """Outcome of a scripted motion of the control site."""

    stopped: bool  # a force-limit event ended the motion
    peak_force: float  # N
    force_events: tuple[ForceEvent, ...]
    final_pos: np.ndarray  # (3,) world position of the control site at the end


def drive(scene: RobotScene, waypoints: np.ndarray, config: RobotConfig | None = None,
          *, hold: float = 0.3) -> DriveResult:
    """From the home posture, move the control site through world-frame ``(K, 3)`` waypoints (hand pointing
    down) under the force-limit rule, then hold ``hold`` seconds. For scripted collisions and calibration."""
    cfg = config or RobotConfig()
    sim = _Sim(scene, cfg, None)
    sim.data.qpos[scene.arm.qpos] = HOME_QPOS
    mujoco.mj_forward(scene.model, sim.data)
    _, quat = sim.site_pose()
    targets = [(np.asarray(p, float), quat) for p in np.atleast_2d(waypoints)]
    stopped = _follow(sim, targets, [HOME_QPOS[None]] * len(targets), "trajectory", 0)
    if not stopped:
        _hold(sim, *targets[-1], hold, "hold")
    return DriveResult(stopped, sim.peak, tuple(sim.events), sim.site_pose()[0])


@dataclass(frozen=True)
class _IKPlan:
    """mink solutions along the path: per target the ``(M, 7)`` samples of its segment, or why it fails."""

    postures: list[np.ndarray]
    worst: float  # m, worst position residual a reachable sample needs (with the hand allowed to touch)
    blocked: int  # samples only a hand touching an obstacle reaches
    solves: int
    message: str  # empty when every target is reachable


def _ik_plan(scene: RobotScene, cfg: RobotConfig, start: tuple[np.ndarray, np.ndarray],
             targets: list[tuple[np.ndarray, np.ndarray]]) -> _IKPlan:
    """Solve the straight path from ``start`` through every target every ``cfg.ik_step`` (and 0.1 rad), each
    solve warm-started from the last. A sample the hand can reach only by touching the table or the object
    keeps the collision-free solution (the posture) and counts as blocked: the impedance target stays the
    plan's, so the hand presses there until the force limit holds it. Out of reach even so: unreachable."""
    q = HOME_QPOS.copy()
    postures, worst, blocked, solves = [], 0.0, 0, 0
    p0, r0 = start
    for k, (p1, r1) in enumerate(targets):
        n = max(1, int(np.ceil(np.linalg.norm(p1 - p0) / cfg.ik_step)), int(np.ceil(quat_angle(r0, r1) / 0.1)))
        samples = []
        for j in range(1, n + 1):
            t = j / n
            p, r = p0 + t * (p1 - p0), slerp(r0, r1, t)
            sol = scene.ik.solve(p, r, q)
            solves += 1
            res_p, res_r = sol.pos_residual, sol.rot_residual
            if res_p > cfg.ik_pos_tol or res_r > cfg.ik_rot_tol:
                free = scene.ik.solve(p, r, q, collisions=False)
                solves += 1
                res_p, res_r = free.pos_residual, free.rot_residual
                if res_p > cfg.ik_pos_tol or res_r > cfg.ik_rot_tol:
                    where = f"waypoint {k}" if j == n else f"the path to waypoint {k}"
                    return _IKPlan(postures, max(worst, res_p), blocked, solves,
                                   f"{where} at world {np.round(p, 3).tolist()} is unreachable: IK residual "
                                   f"{res_p * 1000:.1f} mm / {res_r:.3f} rad (tolerance {cfg.ik_pos_tol * 1000:.1f}"
                                   f" mm / {cfg.ik_rot_tol} rad)")
                blocked += 1
            worst = max(worst, res_p)
            q = sol.q
            samples.append(q)
        postures.append(np.array(samples))
        p0, r0 = p1, r1
    return _IKPlan(postures, worst, blocked, solves, "")


def _side_grasps(positions: np.ndarray, final_quat: np.ndarray) -> list[np.ndarray]:
    """The side grasps worth trying for a path ``(K, 3)`` (task frame) ending with the agent at ``final_quat``:
    a hand pointing along the push, fingers across it horizontally, then vertically; none for a path that
    does not push mostly horizontally (a drop from above, a set-down)."""
    push = positions[-1] - positions[0]
    if np.linalg.norm(push[:2]) < max(_SIDE_PUSH, abs(push[2])):
        return []
    direction = quat_rotate(quat_conj(final_quat), push)  # task frame -> the agent's frame
    return [side_grasp(direction), side_grasp(direction, fingers_vertical=True)]


def _home_grip(scene: RobotScene) -> tuple[np.ndarray, np.ndarray]:
    data = mujoco.MjData(scene.model)
    data.qpos[scene.arm.qpos] = HOME_QPOS
    mujoco.mj_kinematics(scene.model, data)
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, data.site_xmat[scene.arm.site])
    return data.site_xpos[scene.arm.site].copy(), q


def _agent_scale(fragment: str, half_extents: np.ndarray, cfg: RobotConfig) -> float:
    """Scale that makes the agent graspable (cfg.agent_size) but smaller than the object's footprint."""
    size = float(np.max(_agent_extent(fragment)))
    lo, hi = cfg.agent_size
    target = min(max(size, lo), hi, 0.5 * 2 * float(np.min(half_extents[:2])))
    return target / size


def _outcomes(sim: _Sim, obj_pos0: np.ndarray, obj_quat0: np.ndarray) -> Outcomes:
    """The end state as a one-rollout Outcomes (N = 1, the table plays the ground), as the imagination reports it."""
    scene, data = sim.scene, sim.data
    zero = np.zeros(1, dtype=np.int64)
    placement = Placement(pose_index=zero, plan_index=zero, row=zero, object_pos=obj_pos0[None],
                          object_quat=obj_quat0[None], origin=scene.task_origin[None],
                          half_extents=scene.half_extents[None])
    agent_vel = data.qvel[scene.agent_dof:scene.agent_dof + 3].copy()
    speed = max(np.linalg.norm(agent_vel), np.linalg.norm(data.qvel[scene.object_dof:scene.object_dof + 3]))
    return assemble_outcomes(
        placement,
        object_pos=data.xpos[scene.object_body][None].copy(),
        object_quat=data.xquat[scene.object_body][None].copy(),
        agent_pos=data.xpos[scene.agent_body][None, None].copy(),
        agent_quat=data.xquat[scene.agent_body][None, None].copy(),
        agent_vel=agent_vel[None, None],
        contacts=count_contacts(scene.geom_owner, data.contact.geom[: data.ncon], 1)[None],
        released_early=np.array([[bool(sim.events)]]),
        settled=np.array([speed < sim.cfg.settle_speed]),
    )


def _resolve_scoring(scoring: ScoringFunction | str | None) -> ScoringFunction | None:
    if scoring is None or callable(scoring):
        return scoring
    try:
        from rail_mj.scoring import compile_scoring
    except ImportError as exc:
        raise RobotError("scoring source given but rail_mj.scoring.compile_scoring is not available; "
                         "pass a callable(outcomes) -> (B,) scores instead") from exc
    return compile_scoring(scoring)


def execute(obj: RailObject, pose: StablePose, agent_fragment: str, trajectory: np.ndarray,
            scoring: ScoringFunction | str | None, *, config: RobotConfig | None = None,
            render: Path | None = None, affordance: str | None = None) -> ExecutionResult:
    """Carry the agent along ``trajectory`` ((K, 7) via-poses of its centre, task frame), release, judge.

    ``render`` records the execution: an mp4 when it ends in .mp4, else a folder of PNG frames
    (:func:`rail_mj.render.files.write_frames`), seen by one fixed camera that keeps the arm and the agent in view,
    each frame captioned (:func:`caption_lines`: the object, ``affordance``, the verdict, the peak force
    against the limit, and the phase and hand force at that frame).
    """
    cfg = config or RobotConfig()
    traj = np.asarray(trajectory, dtype=float)
    if traj.ndim != 2 or traj.shape[1] != 7 or traj.shape[0] < 1 or not np.all(np.isfinite(traj)):
        raise RobotError(f"trajectory must be a finite (K, 7) array of via-poses (pos, wxyz quat), got {traj.shape}")
    score_fn = _resolve_scoring(scoring)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    half = np.asarray(pose.half_extents, dtype=float)
    scale = _agent_scale(agent_fragment, half, cfg)
    quats = traj[:, 3:] / np.linalg.norm(traj[:, 3:], axis=1, keepdims=True)
    timings["build"] = timings["ik"] = 0.0
    solves = 0
    chosen = None
    # the hand holds the agent from above; where that hand would have to pass through the object (a cupboard's
    # top board over the shelf the item is pushed onto), a hand holding it from behind may not
    for grasp in [_GRASP_QUAT, *_side_grasps(traj[:, :3], quats[-1])]:
        t0 = time.perf_counter()
        scene = build_scene(cfg, obj=obj, pose=pose, agent_fragment=agent_fragment, agent_scale=scale,
                            visual=True if render is not None else None, grasp=grasp)
        timings["build"] += time.perf_counter() - t0
        t0 = time.perf_counter()
        path = [(scene.task_origin + p, q) for p, q in zip(traj[:, :3], quats)]
        top = scene.task_origin[2] + half[2]
        above = path[0][0].copy()
        above[2] = max(above[2], top + cfg.clearance)
        home = _home_grip(scene)
        # rise (or stay) to the approach height first so the straight approach clears the object
        rise = np.array([home[0][0], home[0][1], max(home[0][2], above[2])])
        targets = [(rise, path[0][1]), (above, path[0][1])] + path
        plan = _ik_plan(scene, cfg, home, targets)
        timings["ik"] += time.perf_counter() - t0
        solves += plan.solves
        # reachable first, then the fewest path samples where the hand would touch the table or the object
        if chosen is None or (bool(plan.message), plan.blocked) < (bool(chosen[1].message), chosen[1].blocked):
            chosen = (scene, plan, path, targets, grasp)
        if not plan.message and not plan.blocked:
            break
    scene, plan, path, targets, grasp = chosen
    timings["ik_per_solve"] = timings["ik"] / max(1, solves)

    def result(success: bool, score: float, reachable: bool, message: str, sim: _Sim | None,
               outcomes: Outcomes | None) -> ExecutionResult:
        nan3 = np.full(3, np.nan)
        return ExecutionResult(
            success=success, score=score, reachable=reachable, message=message,
            peak_force=sim.peak if sim else 0.0, force_limit=cfg.force_limit,
            force_events=tuple(sim.events) if sim else (),
            agent_pos=outcomes.agent_pos[0, 0] if outcomes else nan3,
            agent_quat=outcomes.agent_quat[0, 0] if outcomes else np.full(4, np.nan),
            object_tilt=float(outcomes.object_tilt[0]) if outcomes else float("nan"),
            outcomes=outcomes, ik_residual=plan.worst, agent_scale=scale, timings=timings, ik_blocked=plan.blocked)

    if plan.message:
        return result(False, float("nan"), False, plan.message, None, None)

    t0 = time.perf_counter()
    camera = _video_camera(scene, np.vstack(plan.postures), targets) if render is not None else None
    sim = _Sim(scene, cfg, camera)
    data = sim.data
    data.qpos[scene.arm.qpos] = HOME_QPOS
    mujoco.mj_kinematics(scene.model, data)
    grip_pos, grip_quat = sim.site_pose()
    data.qpos[scene.agent_qpos:scene.agent_qpos + 3] = grip_pos
    data.qpos[scene.agent_qpos + 3:scene.agent_qpos + 7] = grip_quat
    mujoco.mj_forward(scene.model, data)
    obj_pos0 = data.xpos[scene.object_body].copy()
    obj_quat0 = data.xquat[scene.object_body].copy()

    _hold(sim, grip_pos, grip_quat, 0.1, "approach")
    n_app = len(targets) - len(path)
    stopped = _follow(sim, targets[:n_app], plan.postures[:n_app], "approach", -1)
    if not stopped:
        stopped = _follow(sim, targets[n_app:], plan.postures[n_app:], "trajectory", 0)
    if not stopped:
        _hold(sim, *path[-1], cfg.hold_time, "hold")

    # release: the weld lets go, the fingers open, the hand withdraws: straight up from above, and back the way
    # it pushed from the side (lifting there would catch what hangs over the item)
    data.eq_active[scene.weld] = 0
    sim.held = False
    # the free agent gets back the imagination's contact softness; soft pads were for the grasp
    scene.model.geom_solref[scene.agent_geoms] = scene.agent_solref
    sim.gripper = 255.0
    pos, quat = sim.site_pose()
    away = np.array([0.0, 0.0, 1.0])
    if grasp is not _GRASP_QUAT:
        away = -quat_rotate(path[-1][1], _hand_z(grasp))  # agent frame -> task frame
    _follow(sim, [(pos + cfg.lift_after_release * away, quat)], [sim.posture[None]], "lift", -1)

    pos, quat = sim.site_pose()
    sim.phase = "settle"
    for _ in range(int(np.ceil(cfg.settle_time / cfg.dt))):
        sim.crossed(sim.step(pos, quat, np.zeros(3)), "settle", -1, "none")
        speed = max(np.linalg.norm(data.qvel[scene.agent_dof:scene.agent_dof + 3]),
                    np.linalg.norm(data.qvel[scene.object_dof:scene.object_dof + 3]))
        if speed < cfg.settle_speed and data.time > 0.5:
            break
    timings["simulate"] = time.perf_counter() - t0
    timings["sim_time"] = float(data.time)

    outcomes = _outcomes(sim, obj_pos0, obj_quat0)
    if score_fn is None:
        res = result(False, float("nan"), True, "executed, not scored", sim, outcomes)
    else:
        t0 = time.perf_counter()
        scores = np.asarray(score_fn(outcomes), dtype=float).reshape(-1)
        timings["score"] = time.perf_counter() - t0
        if scores.shape != (1,):
            raise RobotError(f"scoring function returned shape {scores.shape}, expected (1,) for one rollout")
        score = float(scores[0])
        res = result(bool(score > 0), score, True, "executed", sim, outcomes)
    if render is not None:
        _write_video(sim, Path(render), caption_lines(obj.name, affordance, res), res.success)
    return res


def caption_lines(object_name: str, affordance: str | None, res: ExecutionResult) -> list[str]:
    """The video caption's fixed lines: object, affordance and verdict; peak force against the limit, force-limit
    events and what IK did."""
    asked = f"affordance {affordance!r}" if affordance else "affordance not given"
    if not res.reachable:
        verdict = "UNREACHABLE"
    elif np.isnan(res.score):
        verdict = "EXECUTED, NOT SCORED"
    else:
        verdict = f"{'SUCCESS' if res.success else 'FAILURE'} (score {res.score:+.2f})"
    held = f"; {res.ik_blocked} path samples kept off an obstacle" if res.ik_blocked else ""
    return [f"{object_name} - {asked} - {verdict}",
            f"peak hand force {res.peak_force:.1f} N (limit {res.force_limit:.1f} N, "
            f"{res.peak_force / res.force_limit:.2f}x) - {len(res.force_events)} force-limit events - "
            f"IK by mink, worst residual {res.ik_residual * 1000:.2f} mm{held}"]


def _write_video(sim: _Sim, path: Path, lines: list[str], success: bool) -> None:
    """Every frame with the caption under it: the fixed lines, then the frame's time, phase and hand force."""
    from rail_mj.render.captions import with_caption
    from rail_mj.render.files import write_frames

    limit = sim.cfg.force_limit
    ok = (30, 150, 60) if success else (190, 40, 30)
    size = max(10, VIDEO_SIZE[0] // 40)
    frames = []
    for pixels, (t, phase, force) in zip(sim.frames, sim.frame_info):
        live = f"t = {t:5.2f} s - {phase} - hand force {force:5.1f} N" + (" - FORCE LIMIT" if force > limit else "")
        frames.append(with_caption(pixels, [(lines[0], ok), (lines[1], (20, 20, 20)),
                                            (live, (190, 40, 30) if force > limit else (20, 20, 20))], size))
    # a live line that wraps on a narrow frame makes its band taller: an mp4 needs one frame size
    height = max(f.shape[0] for f in frames)
    frames = [np.pad(f, ((0, height - f.shape[0]), (0, 0), (0, 0)), mode="edge") for f in frames]
    write_frames(frames, path, fps=VIDEO_FPS)
