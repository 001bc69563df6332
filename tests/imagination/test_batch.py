"""Batched imagination: physics checks, outcome contract, backend agreement and MJX compile buckets."""

import numpy as np
import pytest
from scenes import BLOCK, DROPLET, FAST, _box, _cup, _grid, _inside, _object, _pour_plans, _table

from rail_mj.core.errors import FragmentError, ImaginationError
from rail_mj.core.types import AgentSetup
from rail_mj.imagination import ImaginationConfig, get_backend, imagine, prepare
from rail_mj.stable_poses import pose_from_up


@pytest.fixture(scope="module")
def cup():
    return _cup()


@pytest.fixture(scope="module")
def cup_poses(cup):
    return [pose_from_up(cup, np.array([0.0, 0.0, 1.0]), 0.5), pose_from_up(cup, np.array([0.0, 0.0, -1.0]), 0.5)]


def _pour(cup, cup_poses, backend, n=3, collide=True):
    drops = AgentSetup(fragment=DROPLET, offsets=_grid(n, 0.015), collide_agents=collide)
    return imagine(cup, cup_poses, drops, _pour_plans(cup_poses), backend=backend, config=FAST)


@pytest.fixture(scope="module")
def poured(cup, cup_poses):
    return _pour(cup, cup_poses, "native")


def test_droplets_stay_in_an_upright_cup_and_not_in_an_inverted_one(poured):
    inside = _inside(poured)
    upright = poured.pose_index == 0
    assert inside[upright].mean() >= 0.9
    assert poured.contacts_ground[upright].sum() == 0
    assert inside[~upright].sum() == 0
    assert poured.settled.all()


def test_outcomes_are_pose_major_with_documented_shapes(poured):
    b, n = 4, 27
    np.testing.assert_array_equal(poured.pose_index, [0, 0, 1, 1])
    np.testing.assert_array_equal(poured.plan_index, [0, 1, 0, 1])
    shapes = {"agent_pos": (b, n, 3), "agent_quat": (b, n, 4), "agent_vel": (b, n, 3), "contacts_object": (b, n),
              "contacts_agents": (b, n), "contacts_ground": (b, n), "released_early": (b, n), "object_pos": (b, 3),
              "object_quat": (b, 4), "object_tilt": (b,), "object_half_extents": (b, 3), "settled": (b,)}
    for name, shape in shapes.items():
        assert getattr(poured, name).shape == shape, name
    assert poured.contacts_object.dtype.kind == "i" and poured.released_early.dtype == bool
    np.testing.assert_allclose(np.linalg.norm(poured.agent_quat, axis=-1), 1.0, atol=1e-6)
    # droplets in an upright cup touch its inside and each other
    assert poured.contacts_object[0].sum() > 0 and poured.contacts_agents[0].sum() > 0


def test_box_dropped_on_a_table_rests_on_its_top():
    table = _table()
    pose = pose_from_up(table, np.array([0.0, 0.0, 1.0]), 1.0)
    block = AgentSetup(fragment=BLOCK.format(s=0.02, m=0.1), offsets=np.zeros((1, 3)))
    out = imagine(table, [pose], block, [np.array([[0.0, 0.0, 0.15, 1, 0, 0, 0]])], backend="native", config=FAST)
    top = pose.half_extents[2]
    assert out.agent_pos[0, 0, 2] == pytest.approx(top + 0.02, abs=2e-3)
    assert out.contacts_object[0, 0] > 0 and out.contacts_ground[0, 0] == 0


def _steps_to_rest(config: ImaginationConfig) -> tuple[int, float, float]:
    """A block lowered from 0.6 m towards 3 m below the ground onto the table's top (released there, a fifth of the
    way down): (the last step simulated, the drive's steps, the block's rest height above the top)."""
    table = _table()
    pose = pose_from_up(table, np.array([0.0, 0.0, 1.0]), 1.0)
    block = AgentSetup(fragment=BLOCK.format(s=0.02, m=0.1), offsets=np.zeros((1, 3)))
    plan = np.array([[0.0, 0.0, 0.6, 1, 0, 0, 0], [0.0, 0.0, -3.0, 1, 0, 0, 0]])
    seen: list[int] = []
    out = imagine(table, [pose], block, [plan], backend="native", config=config,
                  progress=lambda done, total: seen.append(done))
    return seen[-1], 3.6 / config.agent_speed / config.timestep, out.agent_pos[0, 0, 2] - pose.half_extents[2]


def test_a_settled_world_is_stepped_no_more_though_its_drive_goes_on():
    last, drive, rest = _steps_to_rest(FAST)
    assert rest == pytest.approx(0.02, abs=2e-3)  # on the top
    # released at the top after 0.9 s, at rest 1 s (min_settle_time) later: the drive's last 5 s are not simulated
    assert last < 0.5 * drive


def test_rest_counts_only_a_hold_after_the_release():
    held, _, _ = _steps_to_rest(FAST)
    quick, _, rest = _steps_to_rest(FAST.model_copy(update={"min_settle_time": 0.0}))
    assert rest == pytest.approx(0.02, abs=2e-3)
    assert held - quick >= FAST.min_settle_time / FAST.timestep - 2 * FAST.check_every


def test_agent_released_on_collision_knocks_a_light_object_over():
    post = _object("post", [_box([-0.01, -0.01, 0], [0.01, 0.01, 0.2])], density=50.0)
    pose = pose_from_up(post, np.array([0.0, 0.0, 1.0]), 1.0)
    ram = AgentSetup(fragment=BLOCK.format(s=0.02, m=2.0), offsets=np.zeros((1, 3)))
    through = np.array([[-0.2, 0.0, 0.07, 1, 0, 0, 0], [0.2, 0.0, 0.07, 1, 0, 0, 0]])
    beside = through + np.array([0, 0.2, 0, 0, 0, 0, 0])
    out = imagine(post, [pose], ram, [through, beside], backend="native", config=FAST)
    assert out.released_early[:, 0].tolist() == [True, False]
    assert out.object_tilt[0] > np.pi / 4 and out.object_tilt[1] < 1e-3
    # the task frame follows the fallen post, so the post still spans its box while the world frame would not
    assert out.object_pos[0, 2] < -0.05


def test_trajectory_is_followed_to_its_end():
    cup = _cup()
    pose = pose_from_up(cup, np.array([0.0, 0.0, 1.0]), 1.0)
    drop = AgentSetup(fragment=DROPLET, offsets=np.zeros((1, 3)))
    plan = np.array([[0.2, 0.0, 0.0, 1, 0, 0, 0], [0.2, 0.1, 0.0, 1, 0, 0, 0]])
    out = imagine(cup, [pose], drop, [plan], backend="native", config=FAST)
    # put down at rest at (0.2, 0.1) in the task frame, then fallen onto the ground (task z = -h)
    np.testing.assert_allclose(out.agent_pos[0, 0, :2], [0.2, 0.1], atol=2e-3)
    assert out.agent_pos[0, 0, 2] == pytest.approx(-pose.half_extents[2] + 0.006, abs=2e-3)
    assert out.contacts_ground[0, 0] >= 1 and not out.released_early[0, 0]


def test_bad_inputs_raise_imagination_errors(cup, cup_poses):
    drops = AgentSetup(fragment=DROPLET, offsets=np.zeros((1, 3)))
    with pytest.raises(ImaginationError, match="valid: auto, native, mjx"):
        imagine(cup, cup_poses, drops, [np.zeros((1, 7))], backend="bullet")
    with pytest.raises(ImaginationError, match=r"\(K, 7\)"):
        imagine(cup, cup_poses, drops, [np.zeros((2, 3))], backend="native")
    # the scene module's fragment check names the problem and shows a valid fragment
    with pytest.raises(FragmentError, match="expected exactly one"):
        imagine(cup, cup_poses, AgentSetup(fragment="<mujoco><worldbody/></mujoco>", offsets=np.zeros((1, 3))),
                [np.array([[0, 0, 0.1, 1, 0, 0, 0]])], backend="native")


@pytest.mark.slow
def test_mjx_agrees_with_native_and_compiles_once_per_bucket(cup, cup_poses):
    native = _pour(cup, cup_poses, "native", n=2, collide=False)
    mjx = get_backend("mjx", FAST)
    before = mjx.compiles
    fast = _pour(cup, cup_poses, mjx, n=2, collide=False)
    assert mjx.compiles == before + 1
    np.testing.assert_array_equal(_inside(fast), _inside(native))
    np.testing.assert_allclose(fast.agent_pos, native.agent_pos, atol=5e-3)
    # upright-vs-inverted check on this backend too
    assert _inside(fast)[fast.pose_index == 0].mean() >= 0.9 and _inside(fast)[fast.pose_index == 1].sum() == 0
    other = _cup(r=0.035, h=0.07)  # 13 hulls again: same 16-geom bucket
    other_poses = [pose_from_up(other, np.array([0.0, 0.0, s]), 0.5) for s in (1.0, -1.0)]
    second = _pour(other, other_poses, "mjx", n=2, collide=False)
    assert mjx.compiles == before + 1
    assert _inside(second)[second.pose_index == 0].mean() >= 0.9


def test_per_pose_trajectories_follow_each_pose(cup, cup_poses):
    """[pose][plan] trajectories: each pose's rollouts start where that pose's own plan says."""
    block = AgentSetup(fragment=BLOCK.format(s=0.01, m=0.01), offsets=np.zeros((1, 3)), collide_agents=False)
    starts = (0.3, 0.5)
    plans = [[np.array([[0.2, 0, z, 1, 0, 0, 0]]), np.array([[-0.2, 0, z, 1, 0, 0, 0]])] for z in starts]
    out = imagine(cup, cup_poses, block, plans, backend="native", config=ImaginationConfig(settle_time=0.05))
    assert out.pose_index.tolist() == [0, 0, 1, 1] and out.plan_index.tolist() == [0, 1, 0, 1]
    # the block falls freely for about 0.1 s (settle checks run every 20 steps): ~6 cm, far less than 0.2 m
    assert np.all(np.abs(out.agent_pos[out.pose_index == 0, 0, 2] - starts[0]) < 0.08)
    assert np.all(np.abs(out.agent_pos[out.pose_index == 1, 0, 2] - starts[1]) < 0.08)
    assert np.allclose(np.sign(out.agent_pos[:, 0, 0]), [1, -1, 1, -1])


def test_per_pose_trajectories_must_match_the_poses(cup, cup_poses):
    block = AgentSetup(fragment=BLOCK.format(s=0.01, m=0.01), offsets=np.zeros((1, 3)))
    one = np.array([[0, 0, 0.3, 1, 0, 0, 0]])
    with pytest.raises(ImaginationError, match="one list of plans per stable pose"):
        imagine(cup, cup_poses, block, [[one]], backend="native")
    with pytest.raises(ImaginationError, match="same number"):
        imagine(cup, cup_poses, block, [[one], [one, one]], backend="native")


def test_backends_share_one_interface_and_keep_their_config(cup, cup_poses):
    """One prepared batch runs on any backend; a backend is built once per config and keeps it."""
    drops = AgentSetup(fragment=DROPLET, offsets=_grid(2, 0.015), collide_agents=False)
    native = get_backend("native", FAST)
    assert get_backend("native", FAST) is native and native.config == FAST
    batch = prepare(cup, cup_poses, drops, _pour_plans(cup_poses), native.config)
    assert batch.placement.pose_index.tolist() == [0, 0, 1, 1] and batch.placement.row.tolist() == [0, 1, 0, 1]
    np.testing.assert_allclose(batch.placement.origin[:, 2], [p.half_extents[2] for p in cup_poses for _ in (0, 1)])
    direct = native.run(batch)
    via_imagine = imagine(cup, cup_poses, drops, _pour_plans(cup_poses), backend=native)
    np.testing.assert_array_equal(direct.agent_pos, via_imagine.agent_pos)
    with pytest.raises(ImaginationError, match="its own config"):
        imagine(cup, cup_poses, drops, _pour_plans(cup_poses), backend=native, config=ImaginationConfig())


def test_mjx_box_scene_weighs_what_the_hull_scene_weighs(cup):
    """The bucket scene's hull boxes carry the inertia MuJoCo computes for the hull meshes."""
    drops = AgentSetup(fragment=DROPLET, offsets=_grid(2, 0.015))
    boxes = get_backend("mjx", FAST).scene(cup, drops).model
    meshes = get_backend("native", FAST).scene(cup, drops).model
    body = boxes.body("object").id
    assert boxes.body_geomnum[body] == 16 and meshes.body_geomnum[body] == len(cup.hulls)
    for field in ("body_mass", "body_ipos", "body_inertia", "body_iquat"):
        np.testing.assert_array_equal(getattr(boxes, field)[body], getattr(meshes, field)[body])


def test_mjx_refuses_an_unverified_mujoco_mjx_version(monkeypatch):
    from rail_mj.imagination import mjx

    monkeypatch.setattr(mjx.importlib.metadata, "version", lambda name: "9.1.0")
    with pytest.raises(ImaginationError, match=r"mujoco-mjx 3\.17\.x; installed: 9\.1\.0.*backend='native'"):
        mjx.MjxBackend(FAST)
