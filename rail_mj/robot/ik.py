"""Inverse kinematics of the Panda's control site by mink: joint limits and collision avoidance as QP constraints.

mink (a maintained differential-IK library on MuJoCo) solves one small quadratic program per iteration:
a frame task on the control site, a posture task towards the home posture (redundancy resolution), the
joint limits and a collision-avoidance limit between the hand end of the arm (links 4–7, hand, fingers)
and the obstacles (the static world geoms: floor, table, fixed boxes; and the placed object). Everything
that is not an arm joint (fingers, the object's and the agent's free joints) is frozen by an equality
constraint, so the QP can neither move the object out of the hand's way nor open the gripper.

:class:`ArmIK` is built once per compiled scene (ids resolved there, none in the loop) and solves
target after target, each warm-started from the previous solution. A target it cannot reach, because
it is out of reach or because reaching it would put the hand into an obstacle, comes back with its
residual and ``converged=False``; the caller decides what that means.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Sequence

import mink
import mujoco
import numpy as np

from rail_mj.core.errors import RobotError
from rail_mj.mjcf import OBJECT_BODY
from rail_mj.robot.arm import HOME_QPOS, ArmIndex, quat_error

__all__ = [
    "HAND_BODIES",
    "QP_SOLVER",
    "IKSolution",
    "ArmIK",
]

#: Robot bodies whose geoms are kept out of the obstacles: the hand end of the arm, which comes near the
#: table and the object (links 0–3 stay at the base, far above and behind the table top).
HAND_BODIES: tuple[str, ...] = ("link4", "link5", "link6", "link7", "hand", "left_finger", "right_finger")
#: qpsolvers backend: DAQP is a dense active-set solver, exact and fast for mink's ~20-variable QPs.
QP_SOLVER = "daqp"

#: Iterations without a better pose after which a target counts as out of reach (or blocked).
_STALL_ITERS = 8
#: Position residual under which the posture task is dropped, m: from there the frame task alone converges.
_POSTURE_OFF = 0.01

# mink logs every limit violation of the (frozen) non-arm joints at debug level; nothing to act on
logging.getLogger("mink").setLevel(logging.WARNING)


@dataclass(frozen=True)
class IKSolution:
    """One solved target."""

    q: np.ndarray  # (7,) arm joint angles, within the joint limits
    pos_residual: float  # m, |target - reached| of the control site
    rot_residual: float  # rad
    converged: bool  # both residuals under the solver's tolerance
    iterations: int
    clearance: float  # m, smallest distance hand–obstacle at q (negative: penetration; inf: none near)
    seconds: float


class ArmIK:
    """mink IK for one compiled scene's control site (``ArmIndex.site``)."""

    def __init__(self, model: mujoco.MjModel, arm: ArmIndex, *, obstacles: Sequence[int] | np.ndarray | None = None,
                 min_distance: float = 0.002, detection_distance: float = 0.1, pos_tol: float = 1e-4,
                 rot_tol: float = 1e-3, max_iters: int = 300, max_step: float = 0.2) -> None:
        """``obstacles``: geom ids the hand must keep ``min_distance`` from; default: every geom on a static
        body (floor, table, boxes) and the placed object's geoms, when the scene has one. ``detection_distance``
        exceeds one iteration's hand travel (``max_step`` rad at a ~0.5 m lever), so no step jumps past an
        obstacle before its constraint row is active."""
        self.model, self.arm = model, arm
        self.pos_tol, self.rot_tol, self.max_iters = pos_tol, rot_tol, max_iters
        self.min_distance = min_distance
        self.configuration = mink.Configuration(model)
        hand_bodies = [model.body(n).id for n in HAND_BODIES]
        collides = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
        self.hand_geoms = np.flatnonzero(np.isin(model.geom_bodyid, hand_bodies) & collides)
        if obstacles is None:
            robot = model.body_rootid[model.geom_bodyid] == model.body("link0").id
            static = (model.body_weldid[model.geom_bodyid] == 0) & ~robot  # link0 is welded to the world too
            obj = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY)
            on_object = model.geom_bodyid == obj if obj >= 0 else np.zeros(model.ngeom, bool)
            obstacles = np.flatnonzero((static | on_object) & collides)
        self.obstacles = np.asarray(obstacles, dtype=int)
        self.frame = mink.FrameTask(arm.site, "site", position_cost=1.0, orientation_cost=1.0, lm_damping=1e-3)
        # weak: the posture only picks among the solutions along the arm's one redundant degree of freedom,
        # and it is dropped near the target so it cannot bias the pose (see _descend)
        self.posture = mink.PostureTask(model, cost=np.where(np.isin(np.arange(model.nv), arm.dof), 1e-2, 0.0))
        # a trust region: a full Gauss-Newton step from far away overshoots into a joint limit and stalls there
        step = {model.joint(int(j)).name: max_step for j in model.dof_jntid[arm.dof]}
        self.kinematic_limits: list[mink.Limit] = [mink.ConfigurationLimit(model), mink.VelocityLimit(model, step)]
        self.limits = list(self.kinematic_limits)
        if self.hand_geoms.size and self.obstacles.size:
            self.limits.append(mink.CollisionAvoidanceLimit(
                model, [(self.hand_geoms.tolist(), self.obstacles.tolist())], gain=0.85,
                minimum_distance_from_collisions=min_distance, collision_detection_distance=detection_distance))
        frozen = np.setdiff1d(np.arange(model.nv), arm.dof)
        self.constraints = [mink.DofFreezingTask(model, dof_indices=frozen.tolist())] if frozen.size else []
        home = model.qpos0.copy()
        home[arm.qpos] = HOME_QPOS
        self.posture.set_target(home)
        self._fromto = np.empty(6)
        g1, g2 = (a.ravel() for a in np.meshgrid(self.hand_geoms, self.obstacles, indexing="ij"))
        self._pairs = (g1, g2)
        self._rsum = model.geom_rbound[g1] + model.geom_rbound[g2]
        self._bounded = (model.geom_rbound[g1] > 0) & (model.geom_rbound[g2] > 0)

    def solve(self, pos: np.ndarray, quat: np.ndarray, q0: np.ndarray, *, world_qpos: np.ndarray | None = None,
              collisions: bool = True, max_iters: int | None = None) -> IKSolution:
        """Arm joints putting the control site at ``pos`` (world, m) with orientation ``quat`` (wxyz), from ``q0``.

        ``world_qpos`` is the full qpos the non-arm joints are taken from (the object where it stands now);
        default: the model's ``qpos0``. ``collisions=False`` drops the collision-avoidance limit (to tell a
        target out of reach from one the obstacles block). A start that ends in a local minimum (e.g. a
        straight elbow against its limit) is retried once from the home posture; the better pose is kept."""
        t0 = time.perf_counter()
        pos, quat = np.asarray(pos, float), np.asarray(quat, float)
        if pos.shape != (3,) or quat.shape != (4,) or not (np.all(np.isfinite(pos)) and np.all(np.isfinite(quat))):
            raise RobotError(f"IK target must be a finite position (3,) and wxyz quaternion (4,), got "
                             f"{pos.shape} and {quat.shape}")
        quat = quat / np.linalg.norm(quat)
        qpos = (self.model.qpos0 if world_qpos is None else np.asarray(world_qpos, float)).copy()
        self.frame.set_target(mink.SE3.from_rotation_and_translation(mink.SO3(quat), pos))
        limits = self.limits if collisions else self.kinematic_limits
        iters = self.max_iters if max_iters is None else max_iters
        q, res_p, res_r, n = self._descend(qpos, np.asarray(q0, float), pos, quat, limits, iters)
        clearance = self._clearance_at(qpos, q)
        # an obstacle in the way stops any start alike: only a stall in free space is worth a second start
        if (not self._within(res_p, res_r) and not np.allclose(q0, HOME_QPOS)
                and not (collisions and clearance < self.min_distance + 1e-3)):
            q2, p2, r2, n2 = self._descend(qpos, HOME_QPOS, pos, quat, limits, iters)
            n += n2
            if p2 + 0.1 * r2 < res_p + 0.1 * res_r:
                q, res_p, res_r = q2, p2, r2
                clearance = self._clearance_at(qpos, q)
        return IKSolution(q=q, pos_residual=res_p, rot_residual=res_r, converged=self._within(res_p, res_r),
                          iterations=n, clearance=clearance, seconds=time.perf_counter() - t0)

    def _clearance_at(self, qpos: np.ndarray, q: np.ndarray) -> float:
        qpos = qpos.copy()
        qpos[self.arm.qpos] = q
        self.configuration.update(qpos)
        return self.clearance()

    def _within(self, res_p: float, res_r: float) -> bool:
        return res_p < self.pos_tol and res_r < self.rot_tol

    def _descend(self, qpos: np.ndarray, q0: np.ndarray, pos: np.ndarray, quat: np.ndarray,
                 limits: list[mink.Limit], iters: int) -> tuple[np.ndarray, float, float, int]:
        """mink iterations from ``q0`` until converged or stalled: the best arm pose, its residuals, iterations."""
        arm, cfg = self.arm, self.configuration
        qpos = qpos.copy()
        # start inside the limits: the QP's limit rows assume a feasible start
        qpos[arm.qpos] = np.clip(q0, arm.lo, arm.hi)
        cfg.update(qpos)
        best, stalled, it = (np.inf, qpos[arm.qpos].copy(), np.inf, np.inf), 0, 0
        for it in range(iters + 1):
            res_p, res_r = self._residuals(pos, quat)
            score = res_p + 0.1 * res_r  # 1 mm weighs as 0.01 rad
            if score < best[0] - 1e-6:
                best, stalled = (score, cfg.data.qpos[arm.qpos].copy(), res_p, res_r), 0
            else:
                stalled += 1
            # against a limit or an obstacle there is no further progress to pay for
            if self._within(res_p, res_r) or stalled >= _STALL_ITERS or it == iters:
                break
            # the posture pulls the pose off the target by ~its cost: it steers the approach, not the last cm
            tasks = [self.frame, self.posture] if res_p > _POSTURE_OFF else [self.frame]
            try:
                v = mink.solve_ik(cfg, tasks, 1.0, QP_SOLVER, damping=1e-6, limits=limits,
                                  constraints=self.constraints)
            except mink.NoSolutionFound:
                break  # infeasible QP (the start is already inside an obstacle): keep the best pose so far
            cfg.integrate_inplace(v, 1.0)
        # no clip: ConfigurationLimit keeps every iterate inside the limits, and a clip would hide it if not
        return best[1], best[2], best[3], it

    def _residuals(self, pos: np.ndarray, quat: np.ndarray) -> tuple[float, float]:
        data, site = self.configuration.data, self.arm.site
        return (float(np.linalg.norm(pos - data.site_xpos[site])),
                float(np.linalg.norm(quat_error(quat, data.site_xmat[site]))))

    def clearance(self, distmax: float = 0.05) -> float:
        """Smallest hand–obstacle distance at the current configuration, m (inf beyond ``distmax``)."""
        model, data = self.model, self.configuration.data
        g1, g2 = self._pairs
        # bounding spheres first (a plane's is 0: never culled), as mink's own broadphase does
        gap = np.linalg.norm(data.geom_xpos[g1] - data.geom_xpos[g2], axis=1) - self._rsum
        near = ~(self._bounded & (gap > distmax))
        best = np.inf
        for a, b in zip(g1[near], g2[near]):
            d = mujoco.mj_geomDistance(model, data, int(a), int(b), distmax, self._fromto)
            if d < distmax:
                best = min(best, d)
        return float(best)
