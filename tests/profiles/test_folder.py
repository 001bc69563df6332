"""Profile folders in the paper authors' format (rail_mj.profiles): import, the evaluation.py adapter, bad input,
the round trip through --save-profile, and the folders in a run."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from paths import FIXTURES as TEST_FIXTURES
from paths import REPO

from rail_mj.core.errors import ConfigError, ProfileFolderError
from rail_mj.imagination.inputs import layout_offsets, trajectory_array
from rail_mj.llm import generate_profile, get_provider
from rail_mj.llm.stages import task_description
from rail_mj.pipeline.chain import Pipeline, classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.profiles import (
    PROFILE_DIR_ENV,
    find_folder,
    import_profile,
    save_profile,
    urdf_to_fragment,
)
from rail_mj.profiles.folder import typical_half_extents
from rail_mj.profiles.source import folder_task
from rail_mj.scoring import compile_scoring, probe_outcomes

FIXTURES = TEST_FIXTURES / "paper_profiles"
BROKEN = FIXTURES / "broken"
DIMS = {"cup": [0.098, 0.098, 0.081], "chair": [0.895, 0.427, 0.384], "basket": [0.211, 0.211, 0.151]}


@pytest.fixture(autouse=True)
def _no_profile_dir(shared_cache: None, monkeypatch: pytest.MonkeyPatch) -> None:
    # set (empty: no folder), so that teardown restores it after the robot command sets it for its process
    monkeypatch.setenv(PROFILE_DIR_ENV, "")


@pytest.fixture(scope="module")
def offline():
    return get_provider("offline")


def _import(folder: Path, name: str, provider, **kw):
    return import_profile(folder, task_description(name, DIMS[name], provider), provider, **kw)


def test_cup_folder_becomes_the_profile(offline) -> None:
    profile = _import(FIXTURES / "cup", "cup", offline, adapt=False)
    arrangement = json.loads((FIXTURES / "cup" / "arrangement.json").read_text())
    assert np.allclose(layout_offsets(profile.layout), [arrangement[f"agent_{i}"] for i in range(1, 9)])
    assert profile.layout.n_agents == 8
    plans = json.loads((FIXTURES / "cup" / "plan.json").read_text())
    assert [p.name for p in profile.plans.plans] == list(plans)
    h = np.array([0.05, 0.05, 0.04])
    got = trajectory_array(profile.trajectories.trajectories, h)
    for traj, points in zip(got, plans.values()):  # ground origin: the task frame's ground is at z = -h_z
        assert np.allclose(traj[:, :3], np.array(points) - [0, 0, h[2]])
    centred = import_profile(FIXTURES / "cup", profile_task := task_description("cup", DIMS["cup"], offline),
                             offline, origin="center", adapt=False)
    assert profile_task.affordance == "cup"
    assert np.allclose(trajectory_array(centred.trajectories.trajectories, h)[0][:, :3], plans["plan_1"])
    # stages the folder lacks come from the provider: the cup has no evaluation.py
    assert profile.prompt_versions["scoring"] != "folder" and profile.prompt_versions["agent_model"] == "folder"
    assert profile.analysis.fits and "droplets" in profile.analysis.ibd


def test_via_points_written_for_a_typical_object_are_scaled_to_each_pose(offline) -> None:
    """A folder's metres are for one typical object of its class (a cup about 10 cm tall: the middle of the cup's
    typical heights, 6-16 cm, on a log scale). Adapted, a via-point above that cup keeps its clearance above each
    pose's top and one within it keeps its place in proportion, so the release 2 cm over a 10 cm cup's rim is 2 cm
    over a 30 cm vessel's, not 18 cm down inside it; a bowl's footprint scales too. Not adapted, metres stay."""
    typical = 2 * typical_half_extents("cup")[2]
    assert typical == pytest.approx(np.sqrt(0.06 * 0.16)) and typical_half_extents("cup")[:2] == (None, None)
    plans = json.loads((FIXTURES / "cup" / "plan.json").read_text())
    adapted = _import(FIXTURES / "cup", "cup", offline)
    plain = _import(FIXTURES / "cup", "cup", offline, adapt=False)
    assert any("typical cup (height 0.098 m" in n for n in adapted.notes)
    for hz in (0.05, 0.15):
        h = np.array([0.05, 0.05, hz])
        release = trajectory_array(adapted.trajectories.trajectories, h)[0][-1, :3]  # from the box centre
        above_top = plans["plan_1"][-1][2] - typical
        assert release[2] - hz == pytest.approx(above_top) and above_top > 0
        assert trajectory_array(plain.trajectories.trajectories, h)[0][-1, 2] == pytest.approx(0.12 - hz)
    inside = import_profile(FIXTURES / "cup", task_description("bowl", DIMS["basket"], offline), offline)
    t = typical_half_extents("bowl")
    h = np.array([2 * t[0], 2 * t[1], t[2]])  # a bowl twice as wide as a typical one
    via = trajectory_array(inside.trajectories.trajectories, h)[1][:, :3]  # plan_2: from x = 0.2 m
    assert via[0, 0] == pytest.approx(h[0] + 0.2 - t[0]) and via[-1, 0] == pytest.approx(0.0)


@pytest.mark.parametrize("name", ["cup", "bowl", "vase", "basket", "bathtub", "plate", "table", "chair"])
def test_the_benchmarks_paper_format_folders_import_without_an_error(name: str, offline) -> None:
    """benchmarks/paper_format_profiles, written as the authors wrote theirs, each import whole: the folder's agent,
    arrangement, plans and evaluation.py (where it has one) become the profile, scaled from the class's typical
    object."""
    profile = import_profile(REPO / "benchmarks" / "paper_format_profiles" / name,
                             task_description(name, DIMS.get(name, [0.3, 0.2, 0.1]), offline), offline)
    folder = REPO / "benchmarks" / "paper_format_profiles" / name
    assert profile.prompt_versions["agent_model"] == "folder" and profile.prompt_versions["trajectory"] == "folder"
    assert (profile.prompt_versions["scoring"] == "folder") == (folder / "evaluation.py").is_file()


def test_chair_links_fuse_into_one_body_and_agents_traj_gives_the_plans(offline) -> None:
    profile = _import(FIXTURES / "chair", "chair", offline)
    assert profile.agent.mjcf.count("<geom ") == 2 and 'mass="45"' in profile.agent.mjcf
    assert 'pos="0.25 0 -0.02"' in profile.agent.mjcf  # the fixed joint's origin, now a geom's position
    assert profile.layout.n_agents == 1 and len(profile.plans.plans) == 5
    assert profile.trajectories.trajectories[1].via_poses[0].offset_m == [0.6, 0.0, 1.3]


def test_evaluation_is_called_once_per_rollout(offline) -> None:
    profile = _import(FIXTURES / "basket", "basket", offline)
    assert profile.prompt_versions["scoring"] == "folder" and profile.layout.n_agents == 3
    score = compile_scoring(profile.scoring.source)
    base = probe_outcomes(3, 2, [[0.1, 0.1, 0.075]])  # B = 2 rollouts of 3 agents
    inside = np.zeros((2, 3, 3))
    inside[1, :, 2] = -0.2  # rollout 1: below the box, on the ground
    outcomes = dataclasses.replace(
        base, agent_pos=inside, agent_quat=np.tile([1.0, 0, 0, 0], (2, 3, 1)),
        contacts_object=np.array([[2, 1, 0], [0, 0, 0]]), contacts_ground=np.array([[0, 0, 0], [1, 1, 1]]),
        object_half_extents=np.tile([0.1, 0.1, 0.075], (2, 1)))
    # rollout 0: 2 of 3 balls count (score 2/3, judged a success) -> 1 + 2/3; rollout 1: none -> -1 / (1 + 0)
    assert np.allclose(score(outcomes), [1 + 2 / 3, -1.0])


@pytest.mark.parametrize("name", ["cup", "chair", "basket"])
def test_saved_profile_imports_as_the_same_profile(tmp_path: Path, offline, name: str) -> None:
    made = generate_profile(name, DIMS[name], offline)
    if name == "chair":  # the seat kind's agent is the articulated body, which one rigid URDF link cannot hold
        with pytest.raises(ProfileFolderError, match="agent 'body' is articulated .*no joint springs"):
            save_profile(made, tmp_path / name, half_extents=[0.06, 0.05, 0.04])
    else:
        folder = save_profile(made, tmp_path / name, half_extents=[0.06, 0.05, 0.04])
        assert {p.name for p in folder.iterdir()} >= {"analysis.txt", "agent.urdf", "arrangement.json", "plan.json",
                                                      "agents_traj.json", "scoring.py", "rail_mj.json"}
        assert _import(folder, name, offline) == made
    imported = _import(FIXTURES / name, name, offline)  # and a folder of the paper's kind, through rail_mj's
    again = save_profile(imported, tmp_path / f"{name}_again")
    assert _import(again, name, offline) == imported


def test_an_edited_file_wins_over_rail_mj_json(tmp_path: Path, offline) -> None:
    made = generate_profile("cup", DIMS["cup"], offline)
    folder = save_profile(made, tmp_path / "cup")
    plans = json.loads((folder / "plan.json").read_text())
    plans["plan_1"][-1][2] += 0.05
    (folder / "plan.json").write_text(json.dumps(plans))
    profile = _import(folder, "cup", offline, adapt=False)
    assert profile.trajectories != made.trajectories and profile.agent == made.agent
    assert profile.trajectories.trajectories[0].via_poses[-1].offset_m == plans["plan_1"][-1]
    assert profile.provider == "folder+offline" and profile.prompt_versions["trajectory"] == "folder"


# (the good folder, the file it replaces, the broken fixture, what the error must say)
BAD = [
    ("cup", "analysis.txt", "analysis_no_class.txt", r"analysis\.txt: no line 'Class of object: \.\.\.'"),
    ("cup", "agent.urdf", "agent_mesh.urdf", r"agent\.urdf: <mesh> inside <geometry> is not allowed \(it reads a "
                                             r"mesh file"),
    ("cup", "agent.urdf", "agent_plugin.urdf", r"agent\.urdf: <gazebo> inside <robot> is not allowed.*plugins"),
    ("cup", "agent.urdf", "agent_unknown_tag.urdf", r"agent\.urdf: <wobble> inside <link> is not allowed \(an "
                                                    r"unknown tag; allowed there: <inertial>, <visual>, <collision>"),
    ("cup", "agent.urdf", "agent_joint.urdf", r"agent\.urdf: joint 'hinge' has type 'revolute'; agents are rigid"),
    ("cup", "arrangement.json", "arrangement_wrong_shape.json", r"arrangement\.json: agent_1 must be \[x, y, z\]"),
    ("cup", "plan.json", "plan_nan.json", r"plan\.json: NaN is not a number"),
    ("cup", "plan.json", "plan_wrong_shape.json", r"plan\.json: must be a JSON object like"),
    ("chair", "agents_traj.json", "agents_traj_wrong_shape.json", r"agents_traj\.json: 1 plans; a profile has 5"),
    ("basket", "evaluation.py", "evaluation_imports.py", r"evaluation\.py: line 1: import of os is not allowed"),
    ("basket", "evaluation.py", "evaluation_loops.py", r"evaluation\.py: scoring failed \(timeout\): timed out "
                                                       r"after 2 s"),
    ("basket", "evaluation.py", "evaluation_allocates.py", r"evaluation\.py: scoring failed \(memory\) at line 5: "
                                                           r"exceeded the memory limit"),
    ("basket", "evaluation.py", "evaluation_wrong_shape.py", r"evaluation\.py: scoring failed \(exception\) in the "
                                                             r"adapter.*must return \(score, judgement, "
                                                             r"successful_agents\)"),
]


@pytest.mark.parametrize(("base", "target", "broken", "says"), BAD, ids=[b[2] for b in BAD])
def test_a_broken_file_is_an_error_naming_it(tmp_path: Path, offline, base: str, target: str, broken: str,
                                             says: str) -> None:
    folder = shutil.copytree(FIXTURES / base, tmp_path / base)
    shutil.copy(BROKEN / broken, folder / target)
    with pytest.raises(ProfileFolderError, match=says) as info:
        _import(folder, base, offline)
    assert str(folder / target) in str(info.value)


def test_a_plan_with_nan_in_a_number_is_refused(tmp_path: Path, offline) -> None:
    folder = shutil.copytree(FIXTURES / "cup", tmp_path / "cup")
    (folder / "plan.json").write_text((folder / "plan.json").read_text().replace("0.25", "1e999"))
    with pytest.raises(ProfileFolderError, match=r"plan_1 point 1 is \[0\.0, 0\.0, inf\]; positions must be finite"):
        _import(folder, "cup", offline)


def test_agents_that_start_inside_each_other_are_spread_apart_and_the_import_says_so(tmp_path: Path, offline) -> None:
    """The authors' simulator pushes bodies that start inside each other apart on its first step (their table
    folder lays 13.7 cm agents 6 cm apart): the arrangement is spread about its centre until the closest two touch,
    and the profile's notes name it; with adaptation off the folder is refused, naming the two agents."""
    folder = shutil.copytree(FIXTURES / "basket", tmp_path / "basket")
    (folder / "arrangement.json").write_text('{"agent_1": [0, 0, 0], "agent_2": [0.01, 0, 0], '
                                             '"agent_3": [0, 0.03, 0]}')
    profile = _import(folder, "basket", offline)
    offsets = np.asarray(profile.layout.offsets)
    gaps = [float(np.linalg.norm(a - b)) for k, a in enumerate(offsets) for b in offsets[k + 1:]]
    assert min(gaps) == pytest.approx(0.04)  # the agent's diameter: the closest two touch
    assert np.allclose(offsets.mean(axis=0), [0.01 / 3, 0.01, 0.0])  # about the arrangement's centre
    spread, centred, scaled = profile.notes
    assert "read as written for a typical basket" in scaled
    assert "agents 1 and 2 are 0.0100 m apart" in spread and "spread 4.00x about its centre" in spread
    assert "via-points are centred at each pose's opening" in centred
    with pytest.raises(ProfileFolderError, match=r"arrangement\.json: agents 1 and 2 are 0\.0100 m apart, closer "
                                                 r"than the agent's diameter 0\.0400 m.*adaptation is off"):
        _import(folder, "basket", offline, adapt=False)


def test_urdf_that_is_no_xml_or_has_no_collision_shape() -> None:
    with pytest.raises(ProfileFolderError, match="a.urdf: not well-formed XML"):
        urdf_to_fragment("<robot>", "a.urdf")
    with pytest.raises(ProfileFolderError, match="no link has a <collision> shape"):
        urdf_to_fragment('<robot name="r"><link name="l"><visual><geometry><sphere radius="0.1"/></geometry>'
                         "</visual></link></robot>", "a.urdf")


def test_folders_are_found_by_affordance(tmp_path: Path) -> None:
    assert find_folder(FIXTURES, {"cup"}) == FIXTURES / "cup"
    assert find_folder(FIXTURES, {"mug", "cup"}) == FIXTURES / "cup"
    assert find_folder(FIXTURES, {"bowl"}) is None
    assert find_folder(FIXTURES / "basket", {"basket"}) == FIXTURES / "basket"
    assert find_folder(FIXTURES / "basket", {"cup"}) is None  # its analysis names another affordance
    planter = shutil.copytree(FIXTURES / "basket", tmp_path / "any name")
    (planter / "analysis.txt").write_text((planter / "analysis.txt").read_text().replace("basket", "planter"))
    assert find_folder(tmp_path, {"planter"}) == planter


def test_a_folder_imagines_a_name_the_offline_provider_does_not_know(tmp_path: Path) -> None:
    folder = shutil.copytree(FIXTURES / "basket", tmp_path / "planter")
    pipe = Pipeline(RunConfig(provider="offline", profile_dir=tmp_path))
    pipe.check_affordances(["planter"])  # no UnknownAffordanceError: the folder knows it
    profile = pipe.profile("planter", DIMS["basket"])
    assert profile.affordance == "planter" and set(profile.prompt_versions.values()) == {"folder"}
    assert folder.is_dir()


def test_profile_dir_is_checked_and_reaches_workers(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(ConfigError, match="is not a folder"):
        Pipeline(RunConfig(provider="offline", profile_dir=tmp_path / "missing"))
    with pytest.raises(ConfigError, match="holds no profile folder"):
        Pipeline(RunConfig(provider="offline", profile_dir=tmp_path))
    monkeypatch.setenv(PROFILE_DIR_ENV, str(FIXTURES))
    cfg = RunConfig()
    assert cfg.profile_dir == FIXTURES.resolve()
    sent = RunConfig.model_validate_json(cfg.model_copy(update={"profile_dir": cfg.profile_dir}).model_dump_json(
        exclude_unset=True))
    monkeypatch.delenv(PROFILE_DIR_ENV)
    assert sent.profile_dir == FIXTURES.resolve()  # as a worker without the variable reads its task's config


@pytest.fixture(scope="module")
def cup_mesh(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from rail_mj.dataset.shapes import core

    path = tmp_path_factory.mktemp("mesh") / "cup.stl"
    core.cup(np.random.default_rng(0)).mesh.export(path)
    return path


def test_a_run_imagines_the_folder_and_keeps_the_other_results(tmp_path: Path, cup_mesh: Path) -> None:
    profiles = tmp_path / "profiles"
    shutil.copytree(FIXTURES / "cup", profiles / "cup")
    broken = shutil.copytree(FIXTURES / "basket", profiles / "bowl")
    shutil.copy(BROKEN / "evaluation_wrong_shape.py", broken / "evaluation.py")
    (broken / "analysis.txt").write_text((broken / "analysis.txt").read_text().replace("basket", "bowl"))
    planter = shutil.copytree(FIXTURES / "basket", profiles / "planter")  # a name the offline library lacks
    (planter / "analysis.txt").write_text((planter / "analysis.txt").read_text().replace("basket", "planter"))
    results = classify([cup_mesh, cup_mesh], ["cup", "bowl", "plate", "planter"],
                       config=RunConfig(provider="offline", backend="native", pose="as_placed", profile_dir=profiles),
                       progress=False, workers=1)
    assert len(results) == 8
    cups = [r for r in results if r.requested == "cup"]
    bowls = [r for r in results if r.requested == "bowl"]
    plates = [r for r in results if r.requested == "plate"]
    assert all(r.error is None and r.functional and r.best_plan and r.best_plan.name.startswith("plan_")
               for r in cups)
    assert all(len(r.agent_offsets) == 8 for r in cups)
    assert all(r.error and "evaluation.py" in r.error and "ProfileFolderError" in r.error for r in bowls)
    assert all(r.error is None and r.plans != cups[0].plans for r in plates)  # the provider's own profile
    planters = [r for r in results if r.requested == "planter"]
    assert all(r.error is None and r.affordance == "planter" and len(r.agent_offsets) == 3 for r in planters)
    assert all(r.analyzer_reasons for r in planters)  # stage 7 judged it (the offline rules for a novel use)


def test_a_folders_via_points_are_centred_at_the_opening_where_a_handle_moves_the_box(offline) -> None:
    """A mug's handle moves its box's centre off its cavity (the published cup profile's droplets then land beside
    a real mug): adapted, the folder's via-points follow each pose's opening; not adapted, the box's centre."""
    from rail_mj.core.types import Basin

    h = [0.06, 0.05, 0.04]
    basin = Basin(rim=0.07, opening=np.array([-0.015, 0.0]), length=0.08)  # the cavity 1.5 cm behind the centre
    adapted = _import(FIXTURES / "cup", "cup", offline)
    plain = _import(FIXTURES / "cup", "cup", offline, adapt=False)
    moved = trajectory_array(adapted.trajectories.trajectories, h, basin)
    kept = trajectory_array(plain.trajectories.trajectories, h, basin)
    alone = trajectory_array(adapted.trajectories.trajectories, h)
    for a, b, c in zip(moved, kept, alone, strict=True):
        assert np.allclose(a[:, 0] - b[:, 0], -0.015) and np.allclose(a[:, 1:3], c[:, 1:3])
    assert any("centred at each pose's opening" in n for n in adapted.notes) and plain.notes == []


def test_a_run_names_what_it_adapted_in_the_result_and_its_explanation(tmp_path: Path, cup_mesh: Path) -> None:
    from rail_mj.render.explain import explain, format_explanation

    folder = shutil.copytree(FIXTURES / "cup", tmp_path / "cup")
    offsets = json.loads((folder / "arrangement.json").read_text())
    first = next(iter(offsets))
    offsets[first] = offsets[next(k for k in offsets if k != first)]  # two droplets in one place: no spread helps
    (folder / "arrangement.json").write_text(json.dumps(offsets))
    config = RunConfig(provider="offline", backend="native", pose="as_placed", profile_dir=folder)
    (same,) = classify([cup_mesh], ["cup"], config=config, progress=False, workers=1)
    assert same.error is not None and "start inside each other" in same.error
    offsets[first] = [v + 0.001 for v in offsets[first]]  # 1.7 mm apart: spread to touching
    (folder / "arrangement.json").write_text(json.dumps(offsets))
    (cup,) = classify([cup_mesh], ["cup"], config=config, progress=False, workers=1)
    assert cup.error is None and len(cup.profile_notes) == 3 and "spread" in cup.profile_notes[0]
    assert "profile folder adapted: " in format_explanation(explain(cup))
    (off,) = classify([cup_mesh], ["cup"], config=config.model_copy(update={"profile_adapt": False}), progress=False,
                      workers=1)
    assert off.error is not None and "adaptation is off" in off.error


def test_every_command_line_takes_profile_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    from rail_mj.eval import cli as eval_cli
    from rail_mj.robot import __main__ as robot_cli

    args = eval_cli._parser().parse_args(["--out", str(tmp_path / "out"), "--profile-dir", str(FIXTURES),
                                          "--profile-origin", "center"])
    cfg = eval_cli._config(args)
    assert cfg.run.profile_dir == FIXTURES.resolve() and cfg.run.profile_origin == "center"
    monkeypatch.setenv(PROFILE_DIR_ENV, str(FIXTURES / "cup"))
    assert eval_cli._config(eval_cli._parser().parse_args(["--out", "o"])).run.profile_dir == (
        FIXTURES / "cup").resolve()
    monkeypatch.setenv(PROFILE_DIR_ENV, "")
    seen: list[str | None] = []
    monkeypatch.setattr(robot_cli, "run_demo", lambda *a, **k: seen.append(os.environ.get(PROFILE_DIR_ENV)) or {
        "success_rate": 1.0, "n_trials": 0, "n_affordances": 0, "max_peak_force": 0.0, "force_limit": 1.0,
        "n_force_events": 0})
    assert robot_cli.main(["--demo", "--profile-dir", str(FIXTURES)]) == 0
    assert seen == [str(FIXTURES.resolve())]  # every classification of the demo, in any worker, reads it
    assert robot_cli.main(["--demo", "--profile-dir", str(tmp_path / "none")]) == 2
    assert "is not a folder" in capsys.readouterr().err


def test_classify_cli_saves_and_reads_back_profile_folders(tmp_path: Path, cup_mesh: Path, capsys) -> None:
    from rail_mj.__main__ import main as rail_main

    common = [str(cup_mesh), "-a", "cup", "--provider", "offline", "--backend", "native", "--json"]
    assert rail_main([*common, "--profile-dir", str(FIXTURES), "--save-profile", str(tmp_path / "saved")]) == 0
    out, err = capsys.readouterr()
    first = json.loads(out)
    assert f"wrote {tmp_path / 'saved' / 'cup'}" in err and first["plans"][0] == "plan_1"
    assert rail_main([*common, "--profile-dir", str(tmp_path / "saved")]) == 0
    again = json.loads(capsys.readouterr()[0])
    assert again["scores"] == first["scores"] and again["best_plan"] == first["best_plan"]
    assert rail_main([*common, "--profile-dir", str(tmp_path / "missing")]) == 2
    assert "is not a folder" in json.loads(capsys.readouterr()[0])["error"]


def test_eval_saves_each_affordances_profile(tmp_path: Path) -> None:
    from rail_mj.dataset.procedural import generate
    from rail_mj.eval import cli as eval_cli

    generate(tmp_path / "ds", classes=["cup"], per_class=1, seed=3, affordances=["cup"])
    rc = eval_cli.main(["--dataset", str(tmp_path / "ds"), "--out", str(tmp_path / "out"), "--provider", "offline",
                        "--backend", "native", "--no-render", "--no-progress", "--workers", "1",
                        "--save-profile", str(tmp_path / "saved")])
    assert rc == 0
    profile = import_profile(tmp_path / "saved" / "cup", folder_task("cup", DIMS["cup"], get_provider("offline")),
                             get_provider("offline"))
    assert profile.affordance == "cup" and profile.layout.n_agents > 1


def test_urdf_written_and_read_back_keeps_the_body() -> None:
    import mujoco

    from rail_mj.mjcf import check_fragment
    from rail_mj.profiles import fragment_to_urdf

    mjcf = ('<mujoco><worldbody><body name="toy"><geom type="box" size="0.05 0.02 0.01" mass="0.2" '
            'euler="0.3 -0.4 1.1"/><body pos="0.06 0.01 -0.02" euler="0 0.5 0"><geom type="cylinder" '
            'size="0.01 0.03" pos="0 0.01 0" mass="0.1"/><geom type="sphere" size="0.015" mass="0.05"/></body>'
            '</body></worldbody></mujoco>')

    def world(xml: str):
        model = check_fragment(xml).compile()
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mass = model.body_mass[1:].sum()
        com = (model.body_mass[1:, None] * data.xipos[1:]).sum(axis=0) / mass
        inertia = sum(data.ximat[b].reshape(3, 3) @ np.diag(model.body_inertia[b]) @ data.ximat[b].reshape(3, 3).T
                      + model.body_mass[b] * ((d := data.xipos[b] - com) @ d * np.eye(3) - np.outer(d, d))
                      for b in range(1, model.nbody))
        return (model.geom_type.tolist(), model.geom_size.copy(), data.geom_xpos.copy(), data.geom_xmat.copy(),
                mass, com, inertia)

    before, after = world(mjcf), world(urdf_to_fragment(fragment_to_urdf(mjcf, "toy")))
    assert before[0] == after[0]
    for a, b in zip(before[1:], after[1:]):
        assert np.allclose(a, b, atol=1e-7)
