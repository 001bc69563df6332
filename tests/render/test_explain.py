"""``python -m rail_mj MESH -a NAME --explain``: every stable pose, each plan's score, the rules, the verdict."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import trimesh

from rail_mj.__main__ import main as rail_main
from rail_mj.core.results import AffordanceResult, BasinInfo, PoseInfo
from rail_mj.render.explain import explain, format_explanation, up_axis

pytestmark = pytest.mark.usefixtures("shared_cache")


@pytest.fixture
def block(tmp_path: Path) -> Path:
    """A 20 x 16 x 3 cm block (a closed flat box of a plate's size): one convex hull, several stable faces."""
    path = tmp_path / "block.stl"
    trimesh.creation.box(extents=(0.2, 0.16, 0.03)).export(path)
    return path


def _pose(i: int, up: list[float], half: list[float], p: float, rim: float | None = None,
          length: float = 0.1) -> PoseInfo:
    basin = None if rim is None else BasinInfo(rim=rim, opening=[0.0, 0.0], length=length)
    return PoseInfo(index=i, pos=[0, 0, 0], quat=[1, 0, 0, 0], probability=p, half_extents=half,
                    up_in_mesh_frame=up, basin=basin)


def test_explain_splits_the_reasons_by_pose_and_names_the_envelope() -> None:
    r = AffordanceResult(
        object="o", affordance="cup", requested="mug", dims_fit=True,
        stable_poses=[_pose(0, [0, 0, 1], [0.04, 0.04, 0.05], 0.7), _pose(1, [0, -1, 0], [0.08, 0.05, 0.02], 0.3)],
        plans=["above", "above_front"], scores=[[0.4, -1.0], [-1.0, -1.0]],
        analyzer_reasons=["pose 0: above: 90% of droplets rest inside", "no other pose"],
    )
    e = explain(r)
    assert [p.up for p in e.poses] == ["+z", "-y"]
    assert e.poses[0].box_size_m == [0.08, 0.08, 0.1] and e.poses[0].envelope.endswith("-> prior 1.00")
    assert e.poses[1].envelope.startswith("height 0.04 (typical 0.06-0.16, width 10%): 0.0")
    assert e.poses[0].scores == {"above": 0.4, "above_front": -1.0}
    assert e.poses[0].analyzer == "above: 90% of droplets rest inside" and e.poses[1].analyzer == ""
    assert e.reasons == ["no other pose"] and e.verdict == "not functional"
    text = format_explanation(e)
    assert "pose 1: p=0.30, up -y" in text and "rule: no other pose" in text


def test_explain_judges_a_vessels_aspect_at_its_rim_as_the_analyser_does() -> None:
    # a saucepan: 18 cm wide, a handle rising to 14 cm over a 7 cm rim; the box alone is too tall for a bowl
    half = [0.09, 0.09, 0.07]
    r = AffordanceResult(object="pan", affordance="bowl", requested="bowl", dims_fit=True,
                         stable_poses=[_pose(0, [0, 0, 1], half, 1.0, rim=0.07), _pose(1, [0, 0, 1], half, 0.0)],
                         plans=["above"], scores=[[0.5], [0.5]])
    e = explain(r)
    assert e.poses[0].envelope.endswith("-> prior 1.00")
    assert "height/width 0.778 (typical 0-0.55" in e.poses[1].envelope
    assert AffordanceResult.model_validate_json(r.model_dump_json()).stable_poses[0].basin.rim == 0.07


def test_explain_shows_where_poured_water_stands_in_each_pose() -> None:
    """The liquid rules read the pose's basin: its spill level and length are shown, 'none' without one."""
    pose = _pose(0, [0, 0, 1], [0.8, 0.35, 0.28], 1.0, rim=0.52, length=0.58)
    r = AffordanceResult(object="console", affordance="bathtub", requested="bathtub", dims_fit=True,
                         stable_poses=[pose, _pose(1, [0, 0, -1], [0.8, 0.35, 0.28], 0.0)],
                         plans=["above"], scores=[[0.5], [-1.0]])
    e = explain(r)
    assert e.poses[0].basin == "water stands up to 0.520 m, 0.58 m long" and e.poses[1].basin == "none"
    assert "    basin: water stands up to 0.520 m, 0.58 m long" in format_explanation(e)


def test_up_axis_names_an_axis_or_prints_the_vector() -> None:
    assert up_axis([0.0, 0.0, -1.0]) == "-z"
    assert up_axis([0.6, 0.0, 0.8]) == "[0.60, 0.00, 0.80]"


def test_cli_explain_prints_every_pose_scores_rules_and_verdict(block: Path, capsys) -> None:
    assert rail_main([str(block), "-a", "plate", "--explain", "--provider", "offline"]) == 0
    out = capsys.readouterr().out
    assert "'plate'" in out and "verdict: " in out
    assert out.count("  pose ") >= 2 and "envelope prior: " in out and "scores: above " in out
    assert "probability " in out
    assert "analyser: " in out or "rule: " in out


def test_cli_explain_json_carries_the_same_as_structured_data(block: Path, capsys) -> None:
    assert rail_main([str(block), "-a", "plate", "--explain", "--json", "--provider", "offline"]) == 0
    line = json.loads(capsys.readouterr().out)
    e = line["explain"]
    assert e["verdict"] in ("functional", "not functional") and e["verdict"] == (
        "functional" if line["functional"] else "not functional")
    assert len(e["poses"]) == len(line["stable_poses"]) >= 2
    for pose, info in zip(e["poses"], line["stable_poses"], strict=True):
        assert pose["index"] == info["index"] and pose["probability"] == info["probability"]
        assert set(pose["scores"]) == set(line["plans"])
        assert pose["up"] in ("+x", "-x", "+y", "-y", "+z", "-z")
