"""mink IK of the Panda's control site: accuracy, honest residuals, joint limits, collision avoidance."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rail_mj.core.errors import RobotError
from rail_mj.robot import RobotConfig, build_robot_scene
from rail_mj.robot.arm import HOME_QPOS, ArmIndex, quat_error
from rail_mj.robot.control import solve_ik
from rail_mj.robot.demo import make_object, plan_offline
from rail_mj.robot.ik import ArmIK


@pytest.fixture(scope="module")
def cup_scene(panda_folder):
    obj = make_object("cup", 0)
    case = plan_offline(obj, "cup")
    return build_robot_scene(RobotConfig(), obj=obj, pose=case.pose, agent_fragment=case.agent_fragment,
                             agent_scale=3.0)


@pytest.fixture(scope="module")
def table_scene(panda_folder):
    return build_robot_scene(RobotConfig())


def _home_quat(scene) -> np.ndarray:
    data = mujoco.MjData(scene.model)
    data.qpos[scene.arm.qpos] = HOME_QPOS
    mujoco.mj_kinematics(scene.model, data)
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, data.site_xmat[scene.arm.site])
    return quat


def _site_at(scene, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Forward kinematics apart from the solver: where q puts the control site."""
    data = mujoco.MjData(scene.model)
    data.qpos[scene.arm.qpos] = q
    mujoco.mj_kinematics(scene.model, data)
    return data.site_xpos[scene.arm.site].copy(), data.site_xmat[scene.arm.site].copy()


def _tilted(quat: np.ndarray, axis: list[float], angle: float) -> np.ndarray:
    turn = np.empty(4)
    mujoco.mju_axisAngle2Quat(turn, np.asarray(axis, float), angle)
    out = np.empty(4)
    mujoco.mju_mulQuat(out, turn, quat)
    return out


def test_reachable_targets_are_reached_within_a_millimetre(cup_scene):
    down = _home_quat(cup_scene)
    targets = [
        (np.array([0.45, 0.2, 0.3]), down),
        (np.array([0.6, -0.15, 0.35]), down),
        (np.array([0.55, 0.0, 0.3]), _tilted(down, [1, 0, 0], 0.4)),  # above the cup, tilted
        (np.array([0.35, 0.25, 0.5]), _tilted(down, [0, 0, 1], 1.0)),  # turned about the vertical
    ]
    for pos, quat in targets:
        sol = cup_scene.ik.solve(pos, quat, HOME_QPOS)
        reached, mat = _site_at(cup_scene, sol.q)
        assert sol.converged
        assert np.linalg.norm(reached - pos) < 1e-3 and sol.pos_residual < 1e-3
        assert np.linalg.norm(quat_error(quat, mat)) < 5e-3
        assert sol.clearance > 0  # and the hand is clear of the table and the cup


def test_unreachable_target_reports_its_residual(cup_scene):
    down = _home_quat(cup_scene)
    target = np.array([1.6, 0.0, 0.3])  # ~1.6 m from the base: the Panda reaches ~0.85 m
    sol = cup_scene.ik.solve(target, down, HOME_QPOS)
    reached, _ = _site_at(cup_scene, sol.q)
    assert not sol.converged
    assert sol.pos_residual > 0.5
    assert sol.pos_residual == pytest.approx(np.linalg.norm(reached - target), abs=1e-9)  # the pose it returns


def test_joint_limits_are_respected(cup_scene, panda_folder):
    down = _home_quat(cup_scene)
    targets = [np.array([0.5 * np.cos(az), 0.5 * np.sin(az), 0.35]) for az in (0.6, 0.9, -0.7)]
    # with its full range the base joint turns towards each target ...
    assert all(abs(cup_scene.ik.solve(p, down, HOME_QPOS).q[0]) > 0.23 for p in targets)
    # ... with the base joint limited to ±0.2 rad the other joints make up for it, within the limits
    narrow = build_robot_scene(RobotConfig())
    narrow.model.jnt_range[narrow.model.joint("joint1").id] = [-0.2, 0.2]
    arm = ArmIndex.of(narrow.model, "grip")
    ik = ArmIK(narrow.model, arm)
    for pos in targets:
        sol = ik.solve(pos, down, HOME_QPOS)
        assert sol.converged and sol.pos_residual < 1e-3
        assert np.all(sol.q >= arm.lo - 1e-9) and np.all(sol.q <= arm.hi + 1e-9) and abs(sol.q[0]) <= 0.2 + 1e-9
    # a start outside the limits (joints 4 and 6) is brought inside first
    sol = ik.solve(np.array([0.5, 0.05, 0.35]), down, HOME_QPOS + np.array([0, 0, 0, 2.0, 0, -1.0, 0]))
    assert sol.converged and np.all(sol.q >= arm.lo - 1e-9) and np.all(sol.q <= arm.hi + 1e-9)


def test_collision_avoidance_keeps_the_hand_above_the_table(table_scene):
    cfg = RobotConfig()
    down = _home_quat(table_scene)
    # the control site (the fingertips, no agent held) 1 cm into the table top
    target = np.array([0.55, 0.2, cfg.table_height - 0.01])
    free = table_scene.ik.solve(target, down, HOME_QPOS, collisions=False)
    assert free.converged and free.clearance < -0.005  # kinematically reachable: only the table is in the way
    kept = table_scene.ik.solve(target, down, HOME_QPOS)
    assert not kept.converged and kept.clearance >= cfg.ik_clearance - 2e-4
    reached, _ = _site_at(table_scene, kept.q)
    assert reached[2] > cfg.table_height and kept.pos_residual > 0.01
    # just above the table the hand keeps its clearance and stops short by no more than it
    above = table_scene.ik.solve(np.array([0.55, 0.2, cfg.table_height + 0.001]), down, HOME_QPOS)
    assert above.clearance >= cfg.ik_clearance - 2e-4 and above.pos_residual < cfg.ik_clearance + 1e-3


def test_solve_ik_keeps_its_signature_and_uses_one_solver_per_model(cup_scene):
    from rail_mj.robot.control import _IK_SOLVERS

    model, arm = cup_scene.model, cup_scene.arm
    data = mujoco.MjData(model)
    pos, quat = np.array([0.5, -0.1, 0.35]), _home_quat(cup_scene)
    q, res_p, res_r = solve_ik(model, data, arm, pos, quat, HOME_QPOS)
    assert q.shape == (7,) and res_p < 1e-3 and res_r < 5e-3
    assert np.allclose(data.qpos[arm.qpos], q) and np.linalg.norm(data.site_xpos[arm.site] - pos) < 1e-3
    first = _IK_SOLVERS[model][arm.site]
    solve_ik(model, data, arm, pos + 0.02, quat, q)
    assert _IK_SOLVERS[model][arm.site] is first


def test_bad_target_is_a_clear_error(cup_scene):
    with pytest.raises(RobotError, match=r"position \(3,\) and wxyz quaternion \(4,\)"):
        cup_scene.ik.solve(np.array([0.5, 0.0]), _home_quat(cup_scene), HOME_QPOS)
