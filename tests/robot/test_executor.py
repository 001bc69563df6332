"""The Panda executor: model cache, force-limit safety rule, one short execution."""

from __future__ import annotations

import shutil

import mujoco
import numpy as np
import pytest

from rail_mj.core.errors import FragmentError, RobotError
from rail_mj.core.types import RailObject
from rail_mj.imagination import ImaginationConfig
from rail_mj.mjcf import OBJECT_BODY, compose_scene
from rail_mj.mjcf.body import body_fragment
from rail_mj.robot import RobotConfig, build_robot_scene, drive, execute
from rail_mj.robot.arm import ARM_JOINTS
from rail_mj.robot.control import make_torque_controlled
from rail_mj.robot.demo import make_object, plan_offline, upright_pose
from rail_mj.robot.model import MENAGERIE_ENV, PANDA_FILES, fetch_panda, load_panda_spec, panda_dir, verify_panda
from rail_mj.robot.scene import graspable_scale


def test_cached_model_verifies_and_loads(panda_folder):
    verify_panda(panda_folder)  # hashes + compile
    model = load_panda_spec(visual=False).compile()
    assert model.nu == 8 and model.nq == 9


def test_tampered_model_is_rejected(panda_folder, tmp_path):
    copy = tmp_path / "franka_emika_panda"
    shutil.copytree(panda_folder, copy)
    (copy / "panda.xml").write_text((copy / "panda.xml").read_text().replace('gainprm="4500"', 'gainprm="1"', 1))
    with pytest.raises(RobotError, match="SHA-256"):
        verify_panda(copy)
    (copy / "assets" / "hand.stl").unlink()
    with pytest.raises(RobotError, match="missing"):
        verify_panda(copy)


def test_menagerie_env_must_point_to_a_panda(panda_folder, tmp_path, monkeypatch):
    monkeypatch.setenv(MENAGERIE_ENV, str(tmp_path))
    with pytest.raises(RobotError, match=MENAGERIE_ENV):
        panda_dir()
    monkeypatch.setenv(MENAGERIE_ENV, str(panda_folder.parent))
    assert panda_dir() == panda_folder


def test_torque_variant_keeps_the_model_force_limits(panda_folder):
    spec = load_panda_spec(visual=False)
    make_torque_controlled(spec)
    model = spec.compile()
    arm = [model.actuator(f"actuator{i}").id for i in range(1, 8)]
    assert np.allclose(model.actuator_ctrlrange[arm, 1], [87, 87, 87, 87, 12, 12, 12])
    assert np.all(model.actuator_biastype[arm] == mujoco.mjtBias.mjBIAS_NONE)
    assert len(ARM_JOINTS) == 7


def test_force_limit_pauses_on_a_scripted_collision(panda_folder):
    cfg = RobotConfig(force_limit=12.0)
    scene = build_robot_scene(cfg, boxes=((np.array([0.5, 0.0, 0.15]), np.array([0.05, 0.05, 0.05])),))
    # drive the fingertips 10 cm into the top of a fixed box (top at z = 0.2)
    res = drive(scene, np.array([[0.5, 0.0, 0.3], [0.5, 0.0, 0.1]]), cfg)
    assert res.stopped and res.force_events
    assert res.force_events[0].action == "hold" and res.force_events[0].force > cfg.force_limit
    assert res.peak_force <= 1.2 * cfg.force_limit
    assert abs(res.final_pos[2] - 0.2) < 0.01  # stopped on the surface, not through it


def test_free_motion_has_no_force_events(panda_folder):
    cfg = RobotConfig()
    scene = build_robot_scene(cfg)
    res = drive(scene, np.array([[0.45, 0.1, 0.4], [0.5, -0.1, 0.35]]), cfg)
    assert not res.stopped and not res.force_events and res.peak_force == 0.0
    assert np.linalg.norm(res.final_pos - [0.5, -0.1, 0.35]) < 0.01


@pytest.fixture(scope="module")
def cup_case():
    obj = make_object("cup", 0)
    return obj, plan_offline(obj, "cup")


def test_ball_into_cup_succeeds(panda_folder, cup_case):
    obj, case = cup_case
    res = execute(obj, case.pose, case.agent_fragment, case.via_poses, case.scoring)
    assert res.reachable and res.success and res.score > 0
    h = case.pose.half_extents
    assert np.all(np.abs(res.agent_pos[:2]) < h[:2]) and -h[2] < res.agent_pos[2] < h[2]
    assert res.outcomes.contacts_object[0, 0] > 0 and res.outcomes.contacts_ground[0, 0] == 0
    assert res.object_tilt < 0.1 and 0.03 <= res.agent_scale * 0.012 <= 0.045


def test_ball_dropped_beside_the_cup_fails(panda_folder, cup_case):
    obj, case = cup_case
    beside = case.via_poses.copy()
    beside[:, 0] += 0.12  # same plan, 12 cm to the side: the ball lands on the table
    res = execute(obj, case.pose, case.agent_fragment, beside, case.scoring)
    assert res.reachable and not res.success
    assert res.outcomes.contacts_ground[0, 0] > 0


def test_unreachable_plan_is_reported(panda_folder, cup_case):
    obj, case = cup_case
    far = case.via_poses.copy()
    far[:, 0] += 1.5
    res = execute(obj, case.pose, case.agent_fragment, far, case.scoring)
    assert not res.reachable and not res.success and "unreachable" in res.message


def test_bad_inputs_raise_clear_errors(panda_folder, cup_case):
    obj, case = cup_case
    with pytest.raises(RobotError, match=r"\(K, 7\)"):
        execute(obj, case.pose, case.agent_fragment, np.zeros((3, 3)), case.scoring)
    with pytest.raises(FragmentError, match="invalid agent fragment"):
        execute(obj, case.pose, "<mujoco><worldbody><body>", case.via_poses, case.scoring)
    assert upright_pose(obj).half_extents[2] == pytest.approx(obj.extents[2] / 2)


def test_robot_object_weighs_what_the_imagined_object_weighs(panda_folder, cup_case):
    """One scene composer: the object's mass is split over its hulls by volume, not set by density."""
    obj, case = cup_case
    # overlapping hulls: density × hull volumes would count the overlap twice
    heavy = RailObject(name="overlap", mesh=obj.mesh, hulls=obj.hulls + obj.hulls[:1], mesh_hash="overlap",
                       obb_dims=obj.obb_dims, com=obj.com, mass=0.3, density=obj.density)
    robot = build_robot_scene(RobotConfig(), obj=heavy, pose=case.pose).model
    imagined = compose_scene(heavy, None, ImaginationConfig().physics).model
    assert robot.body(OBJECT_BODY).mass[0] == pytest.approx(0.3)
    assert robot.body(OBJECT_BODY).mass[0] == pytest.approx(imagined.body(OBJECT_BODY).mass[0])


def test_robot_refuses_unsafe_fragments(panda_folder, cup_case):
    """The robot runs untrusted agent MJCF through the same fragment check as the imagination."""
    obj, case = cup_case
    unsafe = '<mujoco><include file="/etc/passwd"/><worldbody><body><geom size="0.01"/></body></worldbody></mujoco>'
    with pytest.raises(FragmentError, match="invalid agent fragment: <include>"):
        execute(obj, case.pose, unsafe, case.via_poses, case.scoring)


@pytest.mark.slow
def test_fetch_from_the_registry(tmp_path):
    folder = fetch_panda(tmp_path / "franka_emika_panda")
    assert sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()) == sorted(PANDA_FILES)


def test_a_side_grasp_points_the_hand_along_the_push():
    from rail_mj.robot.scene import side_grasp

    for fingers_vertical in (False, True):
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, side_grasp(np.array([0.0, 0.3, 0.0]), fingers_vertical))
        hand_in_agent = rot.reshape(3, 3).T  # columns: the hand's x, y, z in the agent's frame
        assert np.allclose(hand_in_agent[:, 2], [0, 1, 0]) and np.isclose(np.linalg.det(hand_in_agent), 1.0)
        assert np.isclose(abs(hand_in_agent[2, 1]), 1.0 if fingers_vertical else 0.0)


def test_an_item_pushed_in_under_a_board_is_held_from_the_side(panda_folder):
    # a doll's cupboard: held from above, the hand over the item catches the top board while pushing it onto the
    # middle board and tips the cupboard over (issue 15); held from behind, the hand stays out in front
    from rail_mj.robot.demo import _BLOCK, _inside

    obj = make_object("cupboard", 1)
    pose = upright_pose(obj)
    h = pose.half_extents
    ident = [1.0, 0, 0, 0]
    z = 0.15 * h[2]  # the storage plans' height: above the middle board, well under the top
    via = np.array([[0.0, -h[1] - 0.05, z, *ident], [0.0, 0.0, z, *ident]])  # the front is open (-y)
    res = execute(obj, pose, _BLOCK.format(a=0.02, b=0.02, rho=500), via, _inside(0.0))
    assert res.reachable and res.success, res.message
    assert res.object_tilt < 0.1 and res.peak_force <= 1.2 * res.force_limit


def test_an_item_pressed_onto_a_bed_does_not_bring_the_fingertips_down_on_it(panda_folder):
    # pressed till the force limit, the held item's soft pads sink and its weld gives: with the fingertips 2 mm
    # above it they struck the mattress, a one-step spike over the limit (a doll's bed: 18.3 N against 15 N)
    from rail_mj.robot.demo import _on_object

    obj = make_object("bed", 1)
    pose = upright_pose(obj)
    top = float(max(hull[:, 2].max() for hull in obj.hulls[:5])) + pose.pos[2] - pose.half_extents[2]  # mattress
    doll = ('<mujoco><worldbody><body name="doll"><geom type="box" size="0.04 0.028 0.013" mass="0.12"/></body>'
            '</worldbody></mujoco>')
    ident = [1.0, 0, 0, 0]
    via = np.array([[0.0, 0.0, top + 0.06, *ident], [0.0, 0.0, top - 0.04, *ident]])  # pressed in till the limit
    res = execute(obj, pose, doll, via, _on_object)
    assert res.reachable and res.success and res.force_events
    assert res.peak_force < 1.05 * res.force_limit


def test_the_hand_carries_a_seated_figure_rigid_and_at_its_own_size():
    doll = body_fragment("sit", 0.18, name="pelvis")
    chair = make_object("chair", 0)
    pose = upright_pose(chair)
    # a box agent is scaled to the hand; the doll the request names keeps its size
    assert graspable_scale(doll, np.asarray(pose.half_extents), RobotConfig()) == 1.0
    scene = build_robot_scene(RobotConfig(), obj=chair, pose=pose, agent_fragment=doll)
    agent = scene.agent_body
    hinges = [j for j in range(scene.model.njnt) if scene.model.body_rootid[scene.model.jnt_bodyid[j]] == agent
              and scene.model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    assert not hinges  # its posture held as it was imagined: no hinge to swing out of the hand's weld
