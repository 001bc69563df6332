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

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Literal

import mujoco
import numpy as np

from rail_mj.core.errors import RobotError
from rail_mj.core.geometry import quat_angle, quat_rotate, slerp
from rail_mj.core.types import Outcomes, RailObject, StablePose
from rail_mj.imagination.batch import Placement, assemble_outcomes
from rail_mj.mjcf import count_contacts
from rail_mj.robot.arm import HOME_QPOS
from rail_mj.robot.control import RobotConfig, contact_force, impedance_torque
from rail_mj.robot.judge import WINDOW, Judgement, judge, observe
from rail_mj.robot.scene import (
    TOP_GRASPS,
    Neighbour,
    RobotScene,
    build_robot_scene,
    graspable_scale,
    hand_z,
    home_grip,
    side_grasps,
)
from rail_mj.robot.video import VIDEO_FPS, video_camera, video_renderer, write_video
from rail_mj.scoring import compile_scoring

__all__ = [
    "ScoringFunction",
    "ForceEvent",
    "ExecutionResult",
    "DriveResult",
    "drive",
    "execute",
    "caption_lines",
]

#: A compiled scoring function: outcomes of B rollouts -> (B,) scores, success where > 0.
ScoringFunction = Callable[[Outcomes], np.ndarray]


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
    judgement: Judgement | None = None  # the independent judge's (rail_mj.robot.judge), when a preposition was given

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
            "judge": self.judgement.to_dict() if self.judgement is not None else None,
        }


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
            self.renderer = video_renderer(self.model)
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
            assert self.camera is not None  # the renderer exists only with a camera
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
    return compile_scoring(scoring)


def execute(obj: RailObject, pose: StablePose, agent_fragment: str, trajectory: np.ndarray,
            scoring: ScoringFunction | str | None, *, config: RobotConfig | None = None,
            render: Path | None = None, affordance: str | None = None, others: tuple[Neighbour, ...] = (),
            preposition: Literal["in", "on"] | None = None, figure: bool = False, water: bool = False
            ) -> ExecutionResult:
    """Carry the agent along ``trajectory`` ((K, 7) via-poses of its centre, task frame), release, judge.

    ``render`` records the execution: an mp4 when it ends in .mp4, else a folder of PNG frames
    (:func:`rail_mj.render.files.write_frames`), seen by one fixed camera that keeps the arm and the agent in view,
    each frame captioned (:func:`caption_lines`: the object, ``affordance``, the verdict, the peak force
    against the limit, and the phase and hand force at that frame).

    ``others`` stand fixed on the table beside the object. With ``preposition`` the end state is also judged by
    :func:`rail_mj.robot.judge.judge` (``figure``: the agent has a pelvis; ``water``: its droplets are counted),
    after the item has rested :data:`rail_mj.robot.judge.WINDOW` more seconds.
    """
    cfg = config or RobotConfig()
    traj = np.asarray(trajectory, dtype=float)
    if traj.ndim != 2 or traj.shape[1] != 7 or traj.shape[0] < 1 or not np.all(np.isfinite(traj)):
        raise RobotError(f"trajectory must be a finite (K, 7) array of via-poses (pos, wxyz quat), got {traj.shape}")
    score_fn = _resolve_scoring(scoring)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    half = np.asarray(pose.half_extents, dtype=float)
    scale = graspable_scale(agent_fragment, half, cfg)
    quats = traj[:, 3:] / np.linalg.norm(traj[:, 3:], axis=1, keepdims=True)
    timings["build"] = timings["ik"] = 0.0
    solves = 0
    chosen = None
    # the hand holds the agent from above; where that hand would have to pass through the object (a cupboard's
    # top board over the shelf the item is pushed onto), a hand holding it from behind may not
    for grasp in [*TOP_GRASPS, *side_grasps(traj[:, :3], quats[-1])]:
        t0 = time.perf_counter()
        scene = build_robot_scene(cfg, obj=obj, pose=pose, agent_fragment=agent_fragment, agent_scale=scale,
                            visual=True if render is not None else None, grasp=grasp, others=others)
        timings["build"] += time.perf_counter() - t0
        t0 = time.perf_counter()
        path = [(scene.task_origin + p, q) for p, q in zip(traj[:, :3], quats)]
        top = scene.task_origin[2] + half[2]
        above = path[0][0].copy()
        above[2] = max(above[2], top + cfg.clearance)
        home = home_grip(scene)
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
    assert chosen is not None  # the grasp list is never empty
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
            outcomes=outcomes, ik_residual=plan.worst, agent_scale=scale, timings=timings, ik_blocked=plan.blocked,
            judgement=verdict)

    verdict: Judgement | None = None

    if plan.message:
        return result(False, float("nan"), False, plan.message, None, None)

    t0 = time.perf_counter()
    camera = video_camera(scene, np.vstack(plan.postures), targets) if render is not None else None
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
    item_quat0 = data.xquat[scene.agent_body].copy()
    sim.held = False
    # the free agent gets back the imagination's contact softness; soft pads were for the grasp
    scene.model.geom_solref[scene.agent_geoms] = scene.agent_solref
    sim.gripper = 255.0
    pos, quat = sim.site_pose()
    away = np.array([0.0, 0.0, 1.0])
    if not any(grasp is g for g in TOP_GRASPS):
        away = -quat_rotate(path[-1][1], hand_z(grasp))  # agent frame -> task frame
    _follow(sim, [(pos + cfg.lift_after_release * away, quat)], [sim.posture[None]], "lift", -1)

    pos, quat = sim.site_pose()
    sim.phase = "settle"
    for _ in range(int(np.ceil(cfg.settle_time / cfg.dt))):
        sim.crossed(sim.step(pos, quat, np.zeros(3)), "settle", -1, "none")
        speed = max(np.linalg.norm(data.qvel[scene.agent_dof:scene.agent_dof + 3]),
                    np.linalg.norm(data.qvel[scene.object_dof:scene.object_dof + 3]))
        if speed < cfg.settle_speed and data.time > 0.5:
            break
    if preposition is not None:
        # the judge's window: the item must rest where it ended for WINDOW more seconds
        before = data.xpos[scene.agent_body].copy()
        for _ in range(int(np.ceil(WINDOW / cfg.dt))):
            sim.crossed(sim.step(pos, quat, np.zeros(3)), "settle", -1, "none")
        verdict = judge(observe(scene.model, data, item_body=scene.agent_body, object_body=scene.object_body,
                                object_hulls=obj.hulls, object_quat0=obj_quat0, item_quat0=item_quat0,
                                item_before=before, geom_owner=scene.geom_owner, table_z=cfg.table_height,
                                preposition=preposition, figure=figure, water=water))
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
        write_video(sim.frames, sim.frame_info, cfg.force_limit, Path(render), caption_lines(obj.name, affordance, res),
                    res.success)
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
