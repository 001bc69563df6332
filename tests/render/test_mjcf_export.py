"""``--save-scene DIR`` and :func:`rail_mj.render.mjcf_export.save_scene`: the imagined scene as MJCF files."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from rail_mj import llm
from rail_mj.__main__ import main as rail_main
from rail_mj.core.errors import ConfigError, RailError
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.dataset.shapes.parts import _revolve
from rail_mj.imagination.inputs import trajectory_array
from rail_mj.mesh import load_object
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.render.mjcf_export import save_scene

R_TOP, HEIGHT, WALL, BASE = 0.04, 0.07, 0.004, 0.006


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RAIL_MJ_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))
        yield


@pytest.fixture(scope="module")
def cup(tmp_path_factory: pytest.TempPathFactory, cache) -> tuple[RailObject, AffordanceResult]:
    """A 8 cm wide, 7 cm tall cup, classified as a cup (functional)."""
    path = tmp_path_factory.mktemp("cup") / "cup.obj"
    _revolve([(0.0, 0.0), (R_TOP, 0.0), (R_TOP, HEIGHT), (R_TOP - WALL, HEIGHT), (R_TOP - WALL, BASE),
              (0.0, BASE)], sections=24).export(path)
    obj = load_object(path)
    (result,) = classify([obj], ["cup"], config=RunConfig(provider="offline", backend="native"), progress=False)
    assert result.functional and result.best_plan is not None
    return obj, result


@pytest.fixture(scope="module")
def block(tmp_path_factory: pytest.TempPathFactory, cache) -> Path:
    """A 20 x 16 x 3 cm closed block: one hull, quick to classify; not a functional plate."""
    path = tmp_path_factory.mktemp("block") / "block.stl"
    trimesh.creation.box(extents=(0.2, 0.16, 0.03)).export(path)
    return path


def _id(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> int:
    i = mujoco.mj_name2id(model, kind, name)
    assert i >= 0, name
    return i


def test_saved_scene_loads_with_the_object_in_its_functional_pose(cup, tmp_path: Path) -> None:
    obj, result = cup
    assert result.functional_pose is not None and result.best_plan is not None
    saved = save_scene(obj, result, tmp_path / "scene")
    assert saved.path == tmp_path / "scene" / "scene.xml" and saved.functional and not saved.overwrote
    assert saved.pose == result.functional_pose.index and saved.plan == result.best_plan.index
    model = mujoco.MjModel.from_xml_path(str(saved.path))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)

    # the object: its hulls as collision geoms (group 3), the original mesh as a visual-only geom, meshes as files
    body = _id(model, mujoco.mjtObj.mjOBJ_BODY, "object")
    hulls = [_id(model, mujoco.mjtObj.mjOBJ_GEOM, f"object/hull{i}") for i in range(len(obj.hulls))]
    assert all(model.geom_bodyid[g] == body and model.geom_contype[g] and model.geom_group[g] == 3 for g in hulls)
    visual = _id(model, mujoco.mjtObj.mjOBJ_GEOM, "rail_render_mesh")
    assert model.geom_bodyid[visual] == body and model.geom_contype[visual] == model.geom_conaffinity[visual] == 0
    assert model.nmesh == len(obj.hulls) + 1 and len(saved.meshes) == model.nmesh
    assert all(p.is_file() and p.parent == tmp_path / "scene" / "meshes" for p in saved.meshes)
    xml = saved.path.read_text()
    assert 'meshdir="meshes"' in xml and str(tmp_path) not in xml and 'file="object_hull0.obj"' in xml
    _id(model, mujoco.mjtObj.mjOBJ_GEOM, "ground")

    # in the functional pose
    pose = result.functional_pose
    assert np.allclose(data.xpos[body], pose.pos, atol=1e-9)
    assert np.allclose(data.xquat[body], pose.quat, atol=1e-9)

    # the agents at the start of the best plan, the via-poses as sites and keyframes
    offsets = np.asarray(result.agent_offsets)
    via = np.asarray(result.best_plan.via_poses)
    origin = np.array([0.0, 0.0, pose.half_extents[2]])
    agents = [_id(model, mujoco.mjtObj.mjOBJ_JOINT, f"agent{i}/free") for i in range(len(offsets))]
    assert saved.n_agents == len(offsets) and model.njnt == 1 + len(offsets)
    starts = np.array([data.xpos[model.jnt_bodyid[j]] for j in agents])
    assert np.allclose(starts, origin + via[0, :3] + offsets, atol=1e-9)
    assert model.nsite == len(via) and saved.via_sites == tuple(f"via{k}" for k in range(len(via)))
    for k, v in enumerate(via):
        assert np.allclose(data.site_xpos[_id(model, mujoco.mjtObj.mjOBJ_SITE, f"via{k}")], origin + v[:3])
    assert saved.keyframes == (*saved.via_sites, "imagined_end") and model.nkey == len(via) + 1
    assert np.allclose(model.key_qpos[_id(model, mujoco.mjtObj.mjOBJ_KEY, "via0")], model.qpos0)
    last = model.key_qpos[_id(model, mujoco.mjtObj.mjOBJ_KEY, f"via{len(via) - 1}")]
    a = model.jnt_qposadr[agents[0]]
    assert np.allclose(last[a:a + 3], origin + via[-1, :3] + offsets[0])

    # what is what, written beside it and in the XML
    readme = saved.readme.read_text()
    assert f"stable pose #{pose.index}" in readme and f"{result.best_plan.name!r}" in readme
    assert "python -m mujoco.viewer --mjcf scene.xml" in readme and "the functional pose" in xml

    for _ in range(100):
        mujoco.mj_step(model, data)
    assert np.all(np.isfinite(data.qpos)) and np.linalg.norm(data.xpos[body] - pose.pos) < 0.01


def test_without_a_functional_pose_the_best_scoring_rollout_is_saved(block: Path, tmp_path: Path) -> None:
    (result,) = classify([block], ["plate"], config=RunConfig(provider="offline", backend="native"), progress=False)
    assert not result.functional and result.evidence_pose is not None
    saved = save_scene(block, result, tmp_path / "s")
    plan = int(np.argmax(result.scores[result.evidence_pose]))
    assert (saved.pose, saved.plan, saved.functional) == (result.evidence_pose, plan, False)
    profile = llm.generate_profile("plate", [float(d) for d in load_object(block).obb_dims], "offline")
    p = result.stable_poses[saved.pose].to_pose()
    via = trajectory_array(profile.trajectories.trajectories, p.half_extents, p.basin)[plan]
    model = mujoco.MjModel.from_xml_path(str(saved.path))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert np.allclose(data.xpos[model.body("object").id], p.pos)
    assert np.allclose(data.site_xpos[model.site("via0").id], [0, 0, p.half_extents[2]] + via[0, :3])
    assert "best-scoring rollout" in saved.readme.read_text()


def test_a_non_empty_directory_is_refused_unless_it_holds_a_previous_scene(block: Path, tmp_path: Path) -> None:
    (result,) = classify([block], ["plate"], config=RunConfig(provider="offline", backend="native"), progress=False)
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="not empty and holds no previous scene.xml"):
        save_scene(block, result, other)
    assert sorted(p.name for p in other.iterdir()) == ["notes.txt"]
    first = save_scene(block, result, tmp_path / "s")
    stale = tmp_path / "s" / "meshes" / "stale.obj"
    stale.write_text("")
    again = save_scene(block, result, tmp_path / "s")
    assert not first.overwrote and again.overwrote and not stale.exists() and again.path.is_file()


def test_a_result_with_nothing_to_draw_is_a_clear_error(cup, tmp_path: Path) -> None:
    obj, result = cup
    failed = result.model_copy(update={"dims_fit": False, "scores": [],  # an absurd size: nothing was imagined
                                       "analyzer_reasons": ["too small for a bathtub"]})
    with pytest.raises(RailError, match="nothing to draw: the dimension check failed.*too small for a bathtub"):
        save_scene(obj, failed, tmp_path / "x")
    with pytest.raises(RailError, match="nothing to draw: the case failed"):
        save_scene(obj, result.model_copy(update={"error": "boom"}), tmp_path / "x")
    with pytest.raises(RailError, match="holds no imagined rollout"):
        save_scene(obj, result.model_copy(update={"stable_poses": []}), tmp_path / "x")
    assert not (tmp_path / "x").exists()


def test_cli_save_scene(block: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "scene"
    argv = [str(block), "-a", "plate", "--provider", "offline", "--backend", "native", "--save-scene", str(out)]
    assert rail_main(argv) == 0
    assert f"wrote {out / 'scene.xml'}: pose #" in capsys.readouterr().err
    mujoco.MjModel.from_xml_path(str(out / "scene.xml"))
    assert rail_main(argv) == 0
    assert "(overwrote the previous scene there)" in capsys.readouterr().err

    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "keep.txt").write_text("")
    assert rail_main([*argv[:-1], str(busy)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: cannot save the scene in") and "no previous scene.xml" in err

    nothing = tmp_path / "nothing"
    assert rail_main([*argv[:2], "chair", *argv[3:-1], str(nothing)]) == 0
    assert "no scene written: " in capsys.readouterr().err and not nothing.exists()
