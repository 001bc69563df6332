"""Scene composition: object hulls where they belong, agents prefixed and placed, collision bits, fragment rules."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import trimesh

from rail_mj.core.errors import FragmentError, SceneError
from rail_mj.core.types import AgentSetup, RailObject
from rail_mj.mesh import reduce_hull
from rail_mj.mjcf import (
    AGENT_BIT,
    GROUND_BIT,
    GROUND_GEOM,
    OBJECT_BIT,
    OBJECT_BODY,
    OBJECT_JOINT,
    VALID_FRAGMENT_EXAMPLE,
    agent_body_name,
    agent_prefix,
    build_scene,
    check_fragment,
    compose_scene,
    hull_geom_name,
    settled_bodies,
)

ONE = '<worldbody><body><geom size="0.01"/></body></worldbody>'  # a minimal agent body, inlined below
BALL = '<mujoco><worldbody><body name="ball"><geom type="sphere" size="0.02" mass="0.01"/></body></worldbody></mujoco>'


def _offset_box(lo, hi) -> np.ndarray:
    return np.asarray(trimesh.creation.box(bounds=[lo, hi]).vertices)


@pytest.fixture(scope="module")
def obj() -> RailObject:
    """Two off-centre hulls (a box and a wedge-ish sphere cap) far from the mesh origin."""
    hull_a = _offset_box([0.1, -0.05, 0.0], [0.3, 0.05, 0.02])
    hull_b = reduce_hull(trimesh.creation.icosphere(subdivisions=2, radius=0.03).vertices + [0.2, 0.0, 0.06], 24)
    mesh = trimesh.util.concatenate([trimesh.convex.convex_hull(hull_a), trimesh.convex.convex_hull(hull_b)])
    return RailObject(
        name="probe",
        mesh=mesh,
        hulls=(hull_a, hull_b),
        mesh_hash="0" * 64,
        obb_dims=np.array([0.2, 0.1, 0.09]),
        com=np.array([0.2, 0.0, 0.02]),
        mass=0.4,
        density=500.0,
    )


def _compile(spec: mujoco.MjSpec) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def test_scene_names_and_prefixes(obj: RailObject) -> None:
    agents = AgentSetup(fragment=BALL, offsets=np.array([[0, 0, 0.5], [0.1, 0, 0.5], [0.2, 0, 0.5]]))
    model, _ = _compile(build_scene(obj, agents=agents))
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, GROUND_GEOM) >= 0
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY) >= 0
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, OBJECT_JOINT) >= 0
    for i in range(3):
        assert agent_prefix(i) == f"agent{i}/"
        assert agent_body_name(BALL, i) == f"agent{i}/ball"
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"agent{i}/ball")
        assert body >= 0
        assert model.jnt_type[model.body_jntadr[body]] == mujoco.mjtJoint.mjJNT_FREE
    assert model.njnt == 4 and model.nq == 28
    assert model.opt.timestep == 0.005


def test_hull_geoms_sit_where_the_hull_vertices_are(obj: RailObject) -> None:
    pos, quat = np.array([0.5, -0.2, 0.3]), np.array([np.cos(0.3), 0.0, 0.0, np.sin(0.3)])
    model, data = _compile(build_scene(obj, object_pos=pos, object_quat=quat, object_free=False))
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, quat)
    rot = rot.reshape(3, 3)
    for i, hull in enumerate(obj.hulls):
        gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, hull_geom_name(i))
        mesh_id = model.geom_dataid[gid]
        start, n = model.mesh_vertadr[mesh_id], model.mesh_vertnum[mesh_id]
        verts = model.mesh_vert[start : start + n] @ data.geom_xmat[gid].reshape(3, 3).T + data.geom_xpos[gid]
        expected = hull @ rot.T + pos
        np.testing.assert_allclose(verts.min(0), expected.min(0), atol=1e-5)
        np.testing.assert_allclose(verts.max(0), expected.max(0), atol=1e-5)


def test_object_mass_and_contact_settings(obj: RailObject) -> None:
    model, _ = _compile(build_scene(obj, timestep=0.004))
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY)
    assert model.body_mass[body] == pytest.approx(obj.mass)
    np.testing.assert_allclose(model.geom_solref[:, 0], 2.5 * 0.004)
    ground = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, GROUND_GEOM)
    assert model.geom_pos[ground][2] == 0.0
    assert (model.geom_contype[ground], model.geom_conaffinity[ground]) == (GROUND_BIT, 0)


def test_fixed_versus_free_object(obj: RailObject) -> None:
    fixed, data_fixed = _compile(build_scene(obj, object_pos=(0, 0, 0.5), object_free=False))
    assert fixed.njnt == 0
    free, data_free = _compile(build_scene(obj, object_pos=(0, 0, 0.5)))
    for _ in range(40):
        mujoco.mj_step(fixed, data_fixed)
        mujoco.mj_step(free, data_free)
    body = mujoco.mj_name2id(fixed, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY)
    assert data_fixed.xpos[body][2] == pytest.approx(0.5)
    assert data_free.xpos[body][2] < 0.45  # falls under gravity


def test_agents_placed_by_layout_pose(obj: RailObject) -> None:
    quat = np.array([np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])  # 90 deg about z: x -> y
    agents = AgentSetup(fragment=BALL, offsets=np.array([[0.1, 0.0, 0.0], [0.0, 0.0, 0.2]]))
    model, data = _compile(build_scene(obj, agents=agents, agents_pos=(1.0, 2.0, 0.5), agents_quat=quat))
    b0 = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "agent0/ball")
    b1 = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "agent1/ball")
    np.testing.assert_allclose(data.xpos[b0], [1.0, 2.1, 0.5], atol=1e-9)
    np.testing.assert_allclose(data.xpos[b1], [1.0, 2.0, 0.7], atol=1e-9)
    np.testing.assert_allclose(data.xquat[b0], quat, atol=1e-9)
    unnormalised, _ = _compile(build_scene(obj, agents=agents, agents_pos=(1.0, 2.0, 0.5), agents_quat=3 * quat))
    np.testing.assert_allclose(unnormalised.body_pos[b0], [1.0, 2.1, 0.5], atol=1e-9)


@pytest.mark.parametrize("collide", [True, False])
def test_agent_collision_bits(obj: RailObject, collide: bool) -> None:
    # two balls overlapping in mid-air, away from the object and the ground
    agents = AgentSetup(fragment=BALL, offsets=np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]]), collide_agents=collide)
    model, data = _compile(build_scene(obj, agents=agents, agents_pos=(-1.0, 0.0, 1.0)))
    pairs = set()
    for _ in range(3):
        mujoco.mj_step(model, data)
        pairs |= {tuple(sorted(model.geom_bodyid[[c.geom1, c.geom2]])) for c in data.contact[: data.ncon]}
    b0 = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "agent0/ball")
    b1 = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "agent1/ball")
    assert ((b0, b1) in pairs) is collide
    geom = model.body_geomadr[b0]
    assert model.geom_contype[geom] == AGENT_BIT
    assert bool(model.geom_conaffinity[geom] & AGENT_BIT) is collide
    assert model.geom_conaffinity[geom] & (GROUND_BIT | OBJECT_BIT) == GROUND_BIT | OBJECT_BIT


def test_agents_touch_object_and_ground(obj: RailObject) -> None:
    # one ball resting on the object's box hull, one on the ground; the object rests on the ground
    agents = AgentSetup(fragment=BALL, offsets=np.array([[0.12, 0.0, 0.039], [-0.5, 0.0, 0.019]]))
    model, data = _compile(build_scene(obj, agents=agents))
    mujoco.mj_step(model, data)
    bodies = {tuple(sorted(model.geom_bodyid[[c.geom1, c.geom2]])) for c in data.contact[: data.ncon]}
    obj_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY)
    b0 = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "agent0/ball")
    b1 = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "agent1/ball")
    assert (obj_id, b0) in bodies or (b0, obj_id) in bodies
    assert (0, b1) in bodies
    assert (0, obj_id) in bodies


def _rolling(obj: RailObject, at: tuple[float, float, float], velocity: tuple[float, float]):
    """The scene with one ball at ``at`` (world), rolling without slip at ``velocity`` across the ground: (scene, qpos,
    qvel)."""
    scene = compose_scene(obj, AgentSetup(fragment=BALL, offsets=np.zeros((1, 3))))
    qpos, qvel = scene.model.qpos0.copy(), np.zeros(scene.model.nv)
    qpos[scene.agent_qpos[0] : scene.agent_qpos[0] + 3] = at
    d = scene.agent_dof[0]
    qvel[d : d + 2] = velocity
    qvel[d + 3 : d + 5] = np.array([-velocity[1], velocity[0]]) / 0.02  # rolling: w = z x v / r
    return scene, qpos, qvel


@pytest.mark.parametrize(("at", "velocity", "rests"), [
    ((1.0, 0.0, 0.019), (0.3, 0.0), True),  # on the floor, clear of the object, rolling away: decided
    ((1.0, 0.0, 0.019), (0.0, 0.3), True),  # rolling past: its distance grows, it never comes back
    ((1.0, 0.0, 0.019), (-0.3, 0.0), False),  # rolling back towards the object
    ((0.25, 0.0, 0.019), (0.3, 0.0), False),  # within the object's reach: the object may still turn it
    ((1.0, 0.0, 0.3), (0.3, 0.0), False),  # in the air
    ((1.0, 0.0, 0.019), (0.0, 0.0), True),  # still
])
def test_an_agent_that_rolled_clear_of_the_object_counts_as_settled(obj: RailObject, at, velocity, rests) -> None:
    scene, qpos, qvel = _rolling(obj, at, velocity)
    assert bool(scene.at_rest(qpos, qvel, 0.02)) is rests
    qvel[scene.object_dof] = 0.1  # the object itself moving: nothing is settled
    assert not scene.at_rest(qpos, qvel, 0.02)


def test_both_backends_judge_rest_alike(obj: RailObject) -> None:
    jnp = pytest.importorskip("jax.numpy")
    rng = np.random.default_rng(0)
    pos = rng.uniform([-1.0, -1.0, 0.0], [1.0, 1.0, 0.1], size=(64, 4, 3))
    lin, ang = rng.normal(0.0, 0.02, size=(2, 64, 4, 3))
    radius = np.array([0.3, 0.02, 0.03, 0.05])
    flags = settled_bodies(np, pos, lin, ang, radius, 0.02)
    assert 0 < flags.sum() < flags.size
    np.testing.assert_array_equal(np.asarray(settled_bodies(jnp, *map(jnp.asarray, (pos, lin, ang, radius)), 0.02)),
                                  flags)


def test_visual_only_agent_geoms_stay_visual(obj: RailObject) -> None:
    frag = (
        '<mujoco><worldbody><body name="a"><geom type="sphere" size="0.02"/>'
        '<geom type="sphere" size="0.03" contype="0" conaffinity="0" group="2"/></body></worldbody></mujoco>'
    )
    model, _ = _compile(build_scene(obj, agents=AgentSetup(fragment=frag, offsets=np.zeros((1, 3)))))
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "agent0/a")
    geoms = range(model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body])
    assert sorted((int(model.geom_contype[g]), int(model.geom_conaffinity[g])) for g in geoms) == [
        (0, 0),
        (AGENT_BIT, GROUND_BIT | OBJECT_BIT | AGENT_BIT),
    ]


def test_unnamed_agent_body_gets_a_name(obj: RailObject) -> None:
    frag = '<mujoco><worldbody><body><geom size="0.01"/></body></worldbody></mujoco>'
    model, _ = _compile(build_scene(obj, agents=AgentSetup(fragment=frag, offsets=np.zeros((2, 3)))))
    assert agent_body_name(frag, 1) == "agent1/agent"
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "agent1/agent") >= 0


def test_no_ground(obj: RailObject) -> None:
    model, _ = _compile(build_scene(obj, ground=False))
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, GROUND_GEOM) == -1


def test_scene_argument_errors(obj: RailObject) -> None:
    with pytest.raises(SceneError, match="object_quat"):
        build_scene(obj, object_quat=(1, 0, 0))
    with pytest.raises(SceneError, match="timestep"):
        build_scene(obj, timestep=0.0)
    with pytest.raises(SceneError, match=r"\(N, 3\)"):
        build_scene(obj, agents=AgentSetup(fragment=BALL, offsets=np.zeros((2, 2))))
    with pytest.raises(FragmentError):
        build_scene(obj, agents=AgentSetup(fragment="<mujoco/>", offsets=np.zeros((1, 3))))


def test_valid_fragment_passes() -> None:
    spec = check_fragment(VALID_FRAGMENT_EXAMPLE)
    assert spec.worldbody.first_body().name == "drop"
    capsule = (
        '<mujoco><worldbody><body><geom type="capsule" fromto="0 0 0 0 0 0.1" size="0.01"/></body></worldbody></mujoco>'
    )
    check_fragment(capsule)
    inline_mesh = (
        '<mujoco><asset><mesh name="tet" vertex="0 0 0 0.1 0 0 0 0.1 0 0 0 0.1"/></asset>'
        '<worldbody><body name="t"><geom type="mesh" mesh="tet"/></body></worldbody></mujoco>'
    )
    check_fragment(inline_mesh)


@pytest.mark.parametrize(
    ("xml", "pattern"),
    [
        ("<mujoco><worldbody><body>", "not well-formed"),
        ("", "empty document"),
        ("<robot/>", "expected <mujoco>"),
        (
            '<mujoco><worldbody><body><geom size="0.01"/></body><body><geom size="0.01"/></body></worldbody></mujoco>',
            "holds 2 bodies",
        ),
        ("<mujoco><worldbody/></mujoco>", "holds 0 bodies"),
        ('<mujoco><worldbody><body><joint type="hinge"/><geom size="0.01"/></body></worldbody></mujoco>',
         r"<joint> is not allowed inside <body> \(the scene adds a free joint"),
        ('<mujoco><worldbody><body><freejoint/><geom size="0.01"/></body></worldbody></mujoco>', "<freejoint>"),
        (
            '<mujoco><asset><mesh name="m" file="cup.stl"/></asset>'
            '<worldbody><body><geom type="mesh" mesh="m"/></body></worldbody></mujoco>',
            r"<mesh> attribute 'file' is not allowed; allowed <mesh> attributes: name, class, vertex",
        ),
        (
            f'<mujoco><asset><texture name="t" type="2d" file="a.png"/></asset>{ONE}</mujoco>',
            r"<texture> is not allowed inside <asset> \(it can read an image file\); allowed there: <mesh>, <material>",
        ),
        (
            f'<mujoco><include file="other.xml"/>{ONE}</mujoco>',
            "<include>",
        ),
        (
            f'<mujoco><compiler meshdir="/tmp"/>{ONE}</mujoco>',
            "meshdir",
        ),
        (
            f'<mujoco><extension><plugin plugin="mujoco.elasticity.cable"/></extension>{ONE}</mujoco>',
            "plugin",
        ),
        ('<mujoco><worldbody><body><geom type="sphere" size="0"/></body></worldbody></mujoco>', "positive size"),
        ('<mujoco><worldbody><body><geom type="box" size="0.1 0 0.1"/></body></worldbody></mujoco>', "positive size"),
        ('<mujoco><worldbody><body><geom type="mesh" mesh="nowhere"/></body></worldbody></mujoco>', "does not compile"),
        ('<mujoco><worldbody><body><geom type="plane" size="1 1 1"/></body></worldbody></mujoco>', "plane"),
        ('<mujoco><worldbody><body><geom size="0.01" mass="0"/></body></worldbody></mujoco>', "mass"),
        (
            '<mujoco><worldbody><geom size="0.01"/><body><geom size="0.01"/></body></worldbody></mujoco>',
            "<geom> is not allowed inside <worldbody>; allowed there: <body>",
        ),
        ('<mujoco><worldbody><body><geom type="sphere" size="5"/></body></worldbody></mujoco>', "reaches"),
        (
            f'<mujoco>{ONE}<keyframe><key qpos=""/></keyframe></mujoco>',
            "keyframe",
        ),
        ("<mujoco><worldbody><body><geom size='0.01' bogus='1'/></body></worldbody></mujoco>",
         "<geom> attribute 'bogus' is not allowed"),
        ('<mujoco><worldbody><body name="a"><geom size="0.01"/></body></worldbody></mujoco', "not well-formed"),
        ('<mujoco><worldbody><body><geom size="big"/></body></worldbody></mujoco>', "does not parse"),
        ('<!DOCTYPE m [<!ENTITY a "aaaa">]><mujoco/>', "ENTITY"),
        (
            f'<mujoco><asset><texture name="s" type="skybox" fileright="r.png"/></asset>{ONE}</mujoco>',
            "<texture> is not allowed",
        ),
    ],
)
def test_fragment_rejections(xml: str, pattern: str) -> None:
    with pytest.raises(FragmentError, match=pattern) as info:
        check_fragment(xml)
    assert "valid fragment" in str(info.value)  # every message shows what a valid one looks like


def _flexcomp(path) -> str:
    return (f'<mujoco><worldbody><body name="a"><flexcomp name="f" type="mesh" file="{path}" rigid="true" '
            'scale="0.05 0.05 0.05"/><geom size="0.01"/></body></worldbody></mujoco>')


def test_flexcomp_file_is_refused_whatever_the_file_holds(tmp_path) -> None:
    """A rigid mesh flexcomp read an STL from disk and passed; other targets leaked their content in the error."""
    trimesh.creation.box().export(tmp_path / "box.stl")
    (tmp_path / "notes.txt").write_text("secret text\n")
    messages = set()
    for target in (tmp_path / "box.stl", tmp_path / "notes.txt", tmp_path / "missing.stl"):
        with pytest.raises(FragmentError) as info:
            check_fragment(_flexcomp(target))
        messages.add(str(info.value).replace(str(target), "PATH"))
    (message,) = messages  # the same refusal for every file: nothing about the file is read
    assert "<flexcomp> is not allowed inside <body>" in message
    assert "allowed there: <body>, <geom>, <site>, <inertial>" in message


@pytest.mark.parametrize(
    ("xml", "pattern"),
    [
        ('<mujoco><asset><mesh name="m" content_type="model/stl" vertex="0 0 0 1 0 0 0 1 0 0 0 1"/></asset>'
         '<worldbody><body><geom type="mesh" mesh="m"/></body></worldbody></mujoco>', "'content_type' is not allowed"),
        ('<mujoco><worldbody><body><geom type="sdf" size="0.01"/></body></worldbody></mujoco>',
         "<geom> type 'sdf' is not allowed; allowed: sphere, capsule, ellipsoid, cylinder, box, mesh"),
        (f'<mujoco><default><geom type="hfield"/></default>{ONE}</mujoco>', "type 'hfield' is not allowed"),
        ('<mujoco><worldbody><body><geom size="0.01" plugin="p"/></body></worldbody></mujoco>',
         "'plugin' is not allowed"),
        ('<mujoco><worldbody><body><geom size="0.01" hfield="h"/></body></worldbody></mujoco>',
         "'hfield' is not allowed"),
        (f'<mujoco><compiler assetdir="/etc"/>{ONE}</mujoco>', "<compiler> attribute 'assetdir'.*: angle, eulerseq"),
        (f'<mujoco><asset><model name="m" file="a.xml"/></asset>{ONE}</mujoco>',
         "<model> is not allowed inside <asset>"),
        (f'<mujoco>{ONE}<actuator/></mujoco>', "<actuator> is not allowed inside <mujoco>; allowed there: <compiler>"),
        ('<mujoco><worldbody><body><composite type="cable"/><geom size="0.01"/></body></worldbody></mujoco>',
         "<composite> is not allowed"),
        ('<mujoco><worldbody><body><frame><geom size="0.01"/></frame></body></worldbody></mujoco>',
         "<frame> is not allowed"),
        (f'<mujoco model="m" version="1">{ONE}</mujoco>', "<mujoco> attribute 'version'"),
    ],
)
def test_only_allow_listed_elements_and_attributes_pass(xml: str, pattern: str) -> None:
    with pytest.raises(FragmentError, match=pattern):
        check_fragment(xml)


def _sphere_mesh(n: int) -> str:
    rng = np.random.default_rng(0)
    v = rng.normal(size=(n, 3))
    v = 0.02 * v / np.linalg.norm(v, axis=1, keepdims=True)
    return " ".join(f"{x:.4f}" for x in v.ravel())


def test_a_rich_agent_at_the_caps_is_accepted(obj: RailObject) -> None:
    """Everything the allow-list names, with geoms and inline vertices at their caps, inside the byte cap."""
    from rail_mj.mjcf import MAX_FRAGMENT_BYTES, MAX_FRAGMENT_GEOMS, MAX_FRAGMENT_VERTICES

    primitives = "".join(f'<geom type="box" size="0.005 0.005 0.005" pos="0 0 {0.01 * i:.2f}"/>'
                         for i in range(MAX_FRAGMENT_GEOMS - 2))
    xml = (
        '<mujoco model="person"><compiler angle="radian" eulerseq="xyz"/>'
        '<default><default class="skin"><geom rgba="0.9 0.7 0.6 1" density="1000"/></default></default>'
        f'<asset><material name="m" rgba="1 0 0 1"/><mesh name="head" vertex="{_sphere_mesh(MAX_FRAGMENT_VERTICES)}"/>'
        '</asset><worldbody><body name="pelvis" childclass="skin" euler="0 0 1.57">'
        '<inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/><site name="s" size="0.01"/>'
        f'<geom type="mesh" mesh="head" material="m"/>{primitives}'
        '<body name="leg" pos="0.1 0 0"><geom type="capsule" fromto="0 0 0 0 0 -0.1" size="0.01"/></body>'
        '</body></worldbody></mujoco>'
    )
    assert len(xml.encode()) <= MAX_FRAGMENT_BYTES
    assert check_fragment(xml).compile().ngeom == MAX_FRAGMENT_GEOMS
    build_scene(obj, agents=AgentSetup(fragment=xml, offsets=np.zeros((1, 3))))


@pytest.mark.parametrize(
    ("kind", "pattern"),
    [
        ("bytes", r"the document is \d+ bytes, more than 65536"),
        ("geoms", "the body has 65 geoms, more than 64"),
        ("vertices", "the meshes have 1025 vertices in all, more than 1024"),
        ("elements", "more than 256 elements"),
    ],
)
def test_fragment_caps_are_checked_before_mujoco_parses(kind: str, pattern: str, monkeypatch) -> None:
    """A 20,000-geom fragment took 19.6 s to validate; every cap is now checked on the raw XML."""
    geom = '<geom size="0.01"/>'
    body = {
        "bytes": geom * 20_000,
        "geoms": geom * 65,
        "vertices": geom,
        "elements": geom + '<site size="0.01"/>' * 260,
    }[kind]
    asset = f'<asset><mesh name="m" vertex="{_sphere_mesh(1025)}"/></asset>' if kind == "vertices" else ""
    xml = f"<mujoco>{asset}<worldbody><body>{body}</body></worldbody></mujoco>"

    def no_parse(*args, **kwargs):
        raise AssertionError("MuJoCo parsed a fragment over the caps")

    monkeypatch.setattr(mujoco.MjSpec, "from_string", no_parse)
    with pytest.raises(FragmentError, match=pattern) as info:
        check_fragment(xml)
    assert "at most 65536 bytes" in str(info.value) and "256 elements, 64 geoms and 1024 inline mesh vertices" in str(
        info.value)


def test_robot_executor_refuses_a_flexcomp_fragment(obj: RailObject, tmp_path) -> None:
    """rail_mj.robot.execute compiled agent fragments without the fragment rules."""
    from rail_mj.core.types import StablePose
    from rail_mj.robot import execute

    trimesh.creation.box().export(tmp_path / "box.stl")
    pose = StablePose(pos=np.zeros(3), quat=np.array([1.0, 0, 0, 0]), probability=1.0,
                      half_extents=np.array([0.1, 0.05, 0.045]))
    via = np.array([[0.0, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0]])
    with pytest.raises(FragmentError, match="<flexcomp> is not allowed"):
        execute(obj, pose, _flexcomp(tmp_path / "box.stl"), via, lambda outcomes: np.ones(1))


@pytest.fixture(scope="module")
def cup(tmp_path_factory: pytest.TempPathFactory) -> RailObject:
    from rail_mj.mesh import DecompositionConfig, object_from_mesh

    profile = np.array([[0, 0], [0.03, 0], [0.03, 0.08], [0.026, 0.08], [0.026, 0.005], [0, 0.005]])
    config = DecompositionConfig(threshold=0.15, max_convex_hull=16, resolution=200, mcts_nodes=4, mcts_iterations=8)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RAIL_MJ_CACHE", str(tmp_path_factory.mktemp("cache")))
        return object_from_mesh(trimesh.creation.revolve(profile, sections=12), name="cup", decomposition=config)


@pytest.mark.parametrize("upright", [True, False])
def test_droplets_stay_in_upright_cup_only(cup: RailObject, upright: bool) -> None:
    drop = (
        '<mujoco><worldbody><body name="d"><geom type="sphere" size="0.005" mass="0.0005"/></body></worldbody></mujoco>'
    )
    grid = np.array([[x, y, 0.0] for x in (-0.012, 0.0, 0.012) for y in (-0.012, 0.0, 0.012)])
    # inverted: the cup's mouth at z = 0 faces down, it rests on its rim; the drops start above its bottom
    quat, top = ((1.0, 0.0, 0.0, 0.0), 0.1) if upright else ((0.0, 1.0, 0.0, 0.0), 0.1)
    spec = build_scene(
        cup,
        object_pos=(0, 0, 0) if upright else (0, 0, 0.08),
        object_quat=quat,
        agents=AgentSetup(fragment=drop, offsets=grid),
        agents_pos=(0, 0, top),
    )
    model, data = _compile(spec)
    for _ in range(300):
        mujoco.mj_step(model, data)
    bodies = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"agent{i}/d") for i in range(len(grid))]
    pos = data.xpos[bodies]
    inside = (np.linalg.norm(pos[:, :2], axis=1) < 0.026) & (pos[:, 2] > 0.004) & (pos[:, 2] < 0.08)
    if upright:
        assert inside.all(), pos
    else:
        assert not inside.any(), pos
