"""Torque-controlled Panda, Cartesian impedance control with force limits; IK by mink (``rail_mj.robot.ik``).

The Menagerie Panda drives its joints with position servos. Here the seven arm
actuators become torque motors whose limits are the model's own ``forcerange``
(87 N·m for joints 1–4, 12 N·m for 5–7), gravity is compensated by MuJoCo
(``gravcomp`` on every robot body), and a Cartesian impedance law moves a
control site (the held agent's centre) with its spring force capped, so the
robot can never push harder than the configured contact-force limit.
"""

from __future__ import annotations

import weakref
from typing import Literal

import mujoco
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from rail_mj.core.errors import RobotError
from rail_mj.robot.arm import ARM_JOINTS, ArmIndex, quat_error
from rail_mj.robot.ik import ArmIK

__all__ = [
    "RobotConfig",
    "make_torque_controlled",
    "impedance_torque",
    "contact_force",
    "solve_ik",
]


class RobotConfig(BaseModel):
    """Execution settings (SI units)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    force_limit: float = Field(default=15.0, gt=0,
                               description="contact force on hand + held agent that stops the motion, N")
    on_force_limit: Literal["hold", "retreat"] = "hold"
    retreat_distance: float = Field(default=0.02, ge=0, description="how far to back off on a force-limit event, m")
    stiffness: float = Field(default=1000.0, gt=0, description="translational impedance, N/m")
    rot_stiffness: float = Field(default=40.0, gt=0, description="rotational impedance, N·m/rad")
    damping_ratio: float = Field(default=1.0, gt=0)
    nullspace_stiffness: float = Field(default=10.0, ge=0, description="posture spring, N·m/rad")
    speed: float = Field(default=0.2, gt=0, description="end-effector speed in free space (approach, lift), m/s")
    guarded_speed: float = Field(default=0.04, gt=0,
                                 description="speed along the via-poses, where contact is expected, m/s")
    compliance: float = Field(default=0.06, ge=0.004,
                              description="solref time constant of the hand and agent geoms, s: "
                                          "soft pads bound the impact force of a touch")
    angular_speed: float = Field(default=1.0, gt=0, description="rad/s")
    dt: float = Field(default=0.002, gt=0, le=0.005)
    hold_time: float = Field(default=0.3, ge=0, description="pause at the end of the trajectory before release, s")
    lift_after_release: float = Field(default=0.08, ge=0, description="hand moves up this far after releasing, m")
    settle_time: float = Field(default=3.0, gt=0, description="longest wait for the agent to come to rest, s")
    settle_speed: float = Field(default=0.01, gt=0, description="agent/object speed counted as at rest, m/s")
    ik_pos_tol: float = Field(default=0.005, gt=0, description="IK residual above which a pose is unreachable, m")
    ik_rot_tol: float = Field(default=0.05, gt=0, description="rad")
    ik_clearance: float = Field(default=0.002, ge=0,
                                description="distance IK keeps the hand (links 4-7, fingers) from the "
                                            "table and the object, m")
    ik_step: float = Field(default=0.02, gt=0, description="IK samples the path between via-poses this finely, m: the "
                                                "posture the controller keeps follows collision-free solutions")
    table_height: float = Field(default=0.1, gt=0, description="table top above the floor, m")
    table_half_size: tuple[float, float] = (0.3, 0.45)
    object_xy: tuple[float, float] = Field(default=(0.55, 0.0), description="where the object's task frame sits, m")
    table_xy: tuple[float, float] | None = Field(default=None,
                                                 description="the table's centre, m; None: under the object")
    clearance: float = Field(default=0.08, ge=0, description="approach height above the object top, m")
    agent_size: tuple[float, float] = Field(default=(0.03, 0.045), description="graspable agent size range, m")
    grip_gap: float = Field(default=0.015, ge=0,
                            description="how far the held agent lies below the fingertips, m: more than "
                            "its soft pads sink at the force limit (9 mm at 15 N), so the fingertips do not strike "
                            "the surface it is pressed onto")
    visual: bool = Field(default=False, description="load the render meshes (slower compile); forced on when rendering")


def make_torque_controlled(spec: mujoco.MjSpec) -> None:
    """Turn the arm's position servos into torque motors with the same force range; compensate gravity."""
    arm = set(ARM_JOINTS)
    found = 0
    for act in spec.actuators:
        if act.target in arm:
            lo, hi = act.forcerange
            act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
            act.gainprm[:] = 0
            act.gainprm[0] = 1.0
            act.biastype = mujoco.mjtBias.mjBIAS_NONE
            act.biasprm[:] = 0
            act.ctrlrange = [lo, hi]
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            found += 1
    if found != len(ARM_JOINTS):
        raise RobotError(f"expected actuators on {ARM_JOINTS}, found {found}: is this the Menagerie Panda?")
    for name in ("link0", "link1", "link2", "link3", "link4", "link5", "link6", "link7",
                 "hand", "left_finger", "right_finger"):
        spec.body(name).gravcomp = 1.0


def _jacobian(model: mujoco.MjModel, data: mujoco.MjData, idx: ArmIndex) -> np.ndarray:
    jp = np.zeros((3, model.nv))
    jr = np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, jp, jr, idx.site)
    return np.vstack([jp[:, idx.dof], jr[:, idx.dof]])


def _clip_norm(v: np.ndarray, limit: float) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v if n <= limit else v * (limit / n)


def impedance_torque(model: mujoco.MjModel, data: mujoco.MjData, idx: ArmIndex, cfg: RobotConfig,
                     pos: np.ndarray, quat: np.ndarray, vel: np.ndarray, posture: np.ndarray) -> np.ndarray:
    """Arm torques driving the control site to (pos, quat) at velocity ``vel``, force capped, torque clipped.

    The commanded Cartesian force is capped at 1.1 × force_limit and the moment
    at that force times 0.15 m (the grasp lever), so a blocked motion presses
    with a bounded force and trips the force-limit check instead of pushing on.
    """
    J = _jacobian(model, data, idx)
    qd = data.qvel[idx.dof]
    twist = J @ qd
    kp, kr = cfg.stiffness, cfg.rot_stiffness
    # critical damping for an effective mass of ~2 kg and inertia of ~0.05 kg·m²
    dp = 2 * cfg.damping_ratio * np.sqrt(kp * 2.0)
    dr = 2 * cfg.damping_ratio * np.sqrt(kr * 0.05)
    f_cap = 1.1 * cfg.force_limit
    force = _clip_norm(kp * (pos - data.site_xpos[idx.site]) + dp * (vel - twist[:3]), f_cap)
    moment = _clip_norm(kr * quat_error(quat, data.site_xmat[idx.site]) - dr * twist[3:], 0.15 * f_cap)
    tau = J.T @ np.concatenate([force, moment])
    # posture spring in the null space of the task Jacobian (redundancy resolution)
    pinv = J.T @ np.linalg.inv(J @ J.T + 1e-4 * np.eye(6))
    null = np.eye(7) - pinv @ J
    q = data.qpos[idx.qpos]
    kn = cfg.nullspace_stiffness
    tau += null @ (kn * (posture - q) - 2 * np.sqrt(kn * 0.5) * qd)
    return np.clip(tau, -idx.tau_max, idx.tau_max)


def contact_force(model: mujoco.MjModel, data: mujoco.MjData, geom_mask: np.ndarray) -> float:
    """Norm of the net contact force the environment exerts on the masked geoms, N."""
    total = np.zeros(3)
    if data.ncon == 0:
        return 0.0
    pairs = data.contact.geom[: data.ncon]
    in1, in2 = geom_mask[pairs[:, 0]], geom_mask[pairs[:, 1]]
    wrench = np.zeros(6)
    for i in np.flatnonzero(in1 != in2):
        mujoco.mj_contactForce(model, data, int(i), wrench)
        # contact frame rows: normal first; the force acts on geom2 along +normal
        f_world = data.contact.frame[i].reshape(3, 3).T @ wrench[:3]
        total += f_world if in2[i] else -f_world
    return float(np.linalg.norm(total))


#: One mink solver per compiled model and control site, dropped with the model.
_IK_SOLVERS: weakref.WeakKeyDictionary[mujoco.MjModel, dict] = weakref.WeakKeyDictionary()


def solve_ik(model: mujoco.MjModel, data: mujoco.MjData, idx: ArmIndex, pos: np.ndarray, quat: np.ndarray,
             q0: np.ndarray, *, iters: int = 200) -> tuple[np.ndarray, float, float]:
    """IK for the control site by mink (:class:`rail_mj.robot.ik.ArmIK`: joint limits, hand–obstacle collision
    avoidance), from ``q0`` with the rest of the scene as ``data.qpos`` has it: (q, pos residual m, rot residual
    rad). ``data`` is left at the solution (qpos and kinematics). The solver is built once per model and site."""
    solvers = _IK_SOLVERS.setdefault(model, {})
    ik = solvers.get(idx.site)
    if ik is None:
        ik = solvers[idx.site] = ArmIK(model, idx)
    sol = ik.solve(pos, quat, q0, world_qpos=data.qpos, max_iters=iters)
    data.qpos[idx.qpos] = sol.q
    mujoco.mj_kinematics(model, data)
    return sol.q, sol.pos_residual, sol.rot_residual
