"""The Panda's arm as the controller and the IK see it: joint names, home posture, monitored bodies, MuJoCo ids.

Both the impedance controller (:mod:`rail_mj.robot.control`) and the mink IK (:mod:`rail_mj.robot.ik`) read these;
they live here so that neither imports the other for them.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

__all__ = [
    "ARM_JOINTS",
    "HOME_QPOS",
    "MONITORED_BODIES",
    "ArmIndex",
    "quat_error",
]

ARM_JOINTS: tuple[str, ...] = tuple(f"joint{i}" for i in range(1, 8))
#: The Menagerie "home" keyframe's arm joints.
HOME_QPOS = np.array([0.0, 0.0, 0.0, -1.57079, 0.0, 1.57079, -0.7853])
#: Bodies whose contact forces count as "hand contact" (plus the held agent).
MONITORED_BODIES: tuple[str, ...] = ("link6", "link7", "hand", "left_finger", "right_finger")


@dataclass(frozen=True)
class ArmIndex:
    """MuJoCo ids the controller needs, computed once per compiled model."""

    qpos: np.ndarray  # (7,) qpos addresses of the arm joints
    dof: np.ndarray  # (7,) dof addresses
    act: np.ndarray  # (7,) actuator ids
    gripper_act: int
    site: int  # the control site (held agent's centre)
    lo: np.ndarray  # (7,) joint lower limits
    hi: np.ndarray
    tau_max: np.ndarray  # (7,) torque limits from the actuator force range

    @staticmethod
    def of(model: mujoco.MjModel, site: str) -> "ArmIndex":
        jids = [model.joint(n).id for n in ARM_JOINTS]
        acts = [int(np.flatnonzero((model.actuator_trntype == mujoco.mjtTrn.mjTRN_JOINT)
                                   & (model.actuator_trnid[:, 0] == j))[0]) for j in jids]
        return ArmIndex(
            qpos=model.jnt_qposadr[jids].copy(),
            dof=model.jnt_dofadr[jids].copy(),
            act=np.array(acts),
            gripper_act=model.actuator("actuator8").id,
            site=model.site(site).id,
            lo=model.jnt_range[jids, 0].copy(),
            hi=model.jnt_range[jids, 1].copy(),
            tau_max=model.actuator_ctrlrange[acts, 1].copy(),
        )


def quat_error(target: np.ndarray, current_mat: np.ndarray) -> np.ndarray:
    """Rotation vector (world frame) that turns the current orientation into the target."""
    cur = np.empty(4)
    mujoco.mju_mat2Quat(cur, current_mat.ravel())
    inv = np.empty(4)
    mujoco.mju_negQuat(inv, cur)
    dq = np.empty(4)
    mujoco.mju_mulQuat(dq, target, inv)
    err = np.empty(3)
    mujoco.mju_quat2Vel(err, dq, 1.0)
    return err
