"""Issue 24: a request on the user's own objects, several objects side by side, declines, and the independent judge."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from rail_mj.core.errors import ConfigError, MeshError, RailError, UnknownAffordanceError
from rail_mj.core.results import AffordanceResult, PoseProbability
from rail_mj.robot.__main__ import main
from rail_mj.robot.control import RobotConfig
from rail_mj.robot.demo import make_object
from rail_mj.robot.judge import MAX_TIP, EndState, Support, judge
from rail_mj.robot.run import decline_text, run_request, verdict_row
from rail_mj.robot.table import GAP, layout, load_user_object

# a bowl 16 cm across standing on the table top (z = 0.1), rim at 0.16
_SQUARE = np.array([[0.47, -0.08], [0.63, -0.08], [0.63, 0.08], [0.47, 0.08]])


def _state(prep: str, item, *, before=None, touches_object=True, touches_table=False, support: Support = "object",
           item_tilt=0.0, object_tilt=0.0, figure=False, water=False, n=1) -> EndState:
    items = np.tile(np.asarray(item, float), (n, 1))
    return EndState(preposition=prep, figure=figure, water=water, items=items,  # pyright: ignore[reportArgumentType]
                    items_before=items if before is None else np.tile(np.asarray(before, float), (n, 1)),
                    item_bottom=items[:, 2] - 0.02, item_tilt=np.full(n, item_tilt),
                    touches_object=np.full(n, touches_object), touches_table=np.full(n, touches_table),
                    support=(support,) * n, footprint=_SQUARE, rim_z=0.16, table_z=0.1, object_tilt=object_tilt)


def test_judge_in_accepts_an_item_resting_inside_below_the_rim():
    verdict = judge(_state("in", [0.55, 0.0, 0.12]))
    assert verdict.success and verdict.retained == 1


@pytest.mark.parametrize("kw, failed", [
    ({"item": [0.70, 0.0, 0.12], "support": "table", "touches_object": False, "touches_table": True},
     "over_footprint"),  # beside the bowl on the table
    ({"item": [0.55, 0.0, 0.18]}, "below_rim"),  # balanced on the rim
    ({"item": [0.55, 0.0, 0.12], "before": [0.55, 0.05, 0.12]}, "rests"),  # still rolling
    ({"item": [0.55, 0.0, 0.12], "touches_table": True}, "off_table"),  # through a hole to the table
])
def test_judge_in_refuses_beside_on_the_rim_rolling_or_on_the_table(kw, failed):
    item = kw.pop("item")
    verdict = judge(_state("in", item, **kw))
    assert not verdict.success and failed in verdict.reason and not all(verdict.checks[failed])


def test_judge_on_checks_support_tilt_and_the_figures_pelvis():
    assert judge(_state("on", [0.55, 0.0, 0.17])).success
    tipped = judge(_state("on", [0.55, 0.0, 0.17], item_tilt=MAX_TIP + 0.05))
    assert not tipped.success and "upright" in tipped.reason
    on_table = judge(_state("on", [0.70, 0.0, 0.12], touches_object=False, touches_table=True, support="table"))
    assert not on_table.success
    # a doll lying against the chair with its pelvis over the table: not seated
    slumped = judge(_state("on", [0.55, 0.0, 0.17], figure=True, support="table"))
    assert not slumped.success and "pelvis_on_object" in slumped.reason
    assert judge(_state("on", [0.55, 0.0, 0.17], figure=True)).success
    # a seated doll's feet stand on the table as a sitter's on the floor; an apple touching it is not on the seat
    assert judge(_state("on", [0.55, 0.0, 0.17], figure=True, touches_table=True)).success
    assert not judge(_state("on", [0.55, 0.0, 0.17], touches_table=True)).success


def test_judge_refuses_a_knocked_over_object_and_counts_droplets():
    assert not judge(_state("in", [0.55, 0.0, 0.12], object_tilt=MAX_TIP + 0.1)).success
    half = _state("in", [0.55, 0.0, 0.12], water=True, n=4)
    spilled = EndState(**{**half.__dict__, "touches_table": np.array([False, False, True, True]),
                          "support": ("object", "object", "table", "table")})
    assert judge(spilled).success and judge(spilled).retained == 2
    most = EndState(**{**spilled.__dict__, "touches_table": np.array([False, True, True, True])})
    assert not judge(most).success


def test_several_objects_stand_side_by_side_without_overlap():
    objs = [make_object("bowl", 1), make_object("cup", 1), make_object("plate", 1)]
    placed = layout(objs)
    lows = [np.array(p.xy) - p.pose.half_extents[:2] for p in placed]
    highs = [np.array(p.xy) + p.pose.half_extents[:2] for p in placed]
    for high, low in zip(highs, lows[1:]):
        assert low[1] - high[1] == pytest.approx(GAP)  # a hand's width apart, along the table
    assert all(abs(p.xy[0] - RobotConfig().object_xy[0]) < 1e-9 for p in placed)


def test_overlapping_or_unreachable_objects_are_errors_naming_them():
    bowl, cup = make_object("bowl", 1), make_object("cup", 1)
    with pytest.raises(ConfigError, match="overlap"):
        layout([bowl, cup], xys=[(0.55, 0.0), (0.56, 0.01)])
    with pytest.raises(ConfigError, match="does not fit on the table"):
        layout([bowl], xys=[(0.55, 0.44)])
    big = trimesh.creation.box([0.5, 0.5, 0.9])
    big.apply_translation([0, 0, 0.45])
    from rail_mj.mesh import object_from_mesh

    with pytest.raises(ConfigError, match="out of the arm's reach"):
        layout([object_from_mesh(big, name="wardrobe")])


def test_bad_input_is_refused_before_anything_runs(tmp_path):
    with pytest.raises(UnknownAffordanceError):
        run_request("put the apple in the glorp", [make_object("bowl", 1)], scan=False)
    broken = tmp_path / "broken.obj"
    broken.write_text("this is no mesh\n")
    with pytest.raises(MeshError):
        run_request("put the apple in the bowl", [broken], scan=False)
    huge = tmp_path / "huge.stl"
    trimesh.creation.box([2.0, 2.0, 0.1]).export(huge)
    with pytest.raises(ConfigError, match="does not fit on the table"):
        run_request("put the apple in the bowl", [huge], scan=False)
    assert main(["--request", "put the apple in the bowl", "--object", str(broken), "--no-scan"]) == 1


def test_a_user_mesh_stands_upright_as_given_turned_by_yaw(tmp_path):
    path = tmp_path / "slab.stl"
    trimesh.creation.box([0.2, 0.1, 0.04]).export(path)
    obj = load_user_object(path, units=1.0, up="z", yaw=90)
    lo, hi = obj.mesh.bounds
    assert lo[2] == pytest.approx(0.0) and (hi - lo)[:2] == pytest.approx([0.1, 0.2])
    with pytest.raises(RailError):
        load_user_object(path, yaw=float("nan"))


def test_decline_text_names_the_object_the_use_and_why():
    verdict = {"reason": "no plan scored above 0 in any stable pose", "error": None, "probability": 0.12}
    text = decline_text("plate", "cup", verdict)
    assert text == ("as it stands, 'plate' does not afford 'cup' (probability 0.12 < 0.5): no plan scored above 0 "
                    "in any stable pose")


def test_a_decline_by_size_names_the_prior_not_the_accepted_physics():
    prior = "width 0.449 (typical 0.125-0.4, width 10%): 0.35 -> prior 0.35"
    pose = PoseProbability(index=0, prior=0.35, prior_factors=prior, physics=1.0, probability=0.35, successes=5,
                           worlds=5, imagined=5)
    r = AffordanceResult(object="basin", affordance="bowl", requested="bowl", probability=0.35, prior=prior,
                         pose_verdicts=[pose], analyzer_reasons=["pose 0 works with the most plans (5)"])
    text = decline_text("basin", "bowl", verdict_row(r))
    assert "size is unusual" in text and "0.449" in text and "works with the most plans" not in text
    failed = r.model_copy(update={"pose_verdicts": [pose.model_copy(update={"physics": 0.0, "probability": 0.0})],
                                  "probability": 0.0, "analyzer_reasons": ["no plan scored above 0"]})
    assert decline_text("basin", "bowl", verdict_row(failed)).endswith("no plan scored above 0")


@pytest.mark.slow
def test_a_request_the_object_does_not_afford_is_declined_with_no_motion(tmp_path):
    # a bowl standing upside down takes no apple: the robot says so and does not move
    from rail_mj.robot.experiment import Task, task_object

    obj = task_object(Task("upside_down_bowl", "demo:bowl", 4, "put the apple in the bowl", flip=True))
    out = run_request("put the apple in the bowl", [obj], scan=False)
    assert out["declined"] and not out["executed"] and out["chosen"] is None and out["peak_force"] == 0.0
    assert out["reason"].startswith("as it stands, 'upside_down_bowl' does not afford 'bowl'")
    assert out["objects"][0]["functional"] is False


@pytest.mark.slow
def test_three_objects_the_robot_chooses_the_bowl_and_the_judge_says_it_worked(tmp_path):
    objs = [make_object("cutting_board", 2), make_object("bowl", 1), make_object("vase", 2)]
    summary = tmp_path / "out.json"
    out = run_request("put the apple in the bowl", objs, scan=False, save_profile=tmp_path / "profiles")
    assert out["chosen"] == "bowl_1" and out["executed"] and not out["declined"]
    assert (tmp_path / "profiles" / "bowl" / "agent.urdf").is_file()  # --save-profile: the chosen object's
    assert out["success"] and out["judge"]["checks"]["below_rim"] == [True]
    assert len(out["objects"]) == 3 and sum(o["functional"] for o in out["objects"]) >= 1
    summary.write_text(json.dumps(out))  # the summary is JSON as it stands
