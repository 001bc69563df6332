"""Seat and surface verdicts rest on where the agent came to rest, not on the object's box (issue 13).

Stage 7 is exercised on hand-made candidates (what the rollouts would report), stage 6 on hand-made
outcomes, so each test runs in well under a second.
"""

from __future__ import annotations

import numpy as np

from rail_mj.core.profile import CandidateInteraction, PoseCandidates, ResultSummary
from rail_mj.core.types import Outcomes
from rail_mj.llm import FunctionalPoseRequest, analyze_functional_poses, generate_profile
from rail_mj.scoring import compile_scoring

#: An upholstered armchair as it stands: rolled arms and a back make its box 0.91 m wide around a 0.55 m seat.
ARMCHAIR = [0.455, 0.375, 0.395]
CENTRE = ("above", "front", "back", "left", "right")
AREA = ("above_front", "above_back", "above_left", "above_right")
BESIDE = ("beside_front", "beside_back")
TOPS = ("above", "above_front", "above_back", "above_left", "above_right")


def _rests(plan: str, h: list[float], height: float, agent_half_z: float) -> CandidateInteraction:
    """A candidate whose one agent rests level on the object alone, its bottom ``height`` m above the ground."""
    mean = (height + agent_half_z - h[2]) / h[2]  # agent centre in units of h_z above the box centre
    summary = ResultSummary(frac_inside_bbox=1.0, frac_on_ground=0.0, frac_touching_object=1.0, mean_height=mean,
                            object_tilt_deg=0.5, agent_tilt_deg=1.0, agent_speed=0.0)
    return CandidateInteraction(plan=plan, description=plan, via_poses=[[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]],
                                score=0.5, summary=summary)


def _pose(index: int, probability: float, h: list[float], plans: tuple[str, ...], height: float,
          agent_half_z: float = 0.05) -> PoseCandidates:
    return PoseCandidates(pose_index=index, probability=probability, half_extents=h,
                          candidates=[_rests(p, h, height, agent_half_z) for p in plans])


def _slid(plan: str, h: list[float], *, under: bool) -> CandidateInteraction:
    """A table's feet-room probe (a failure by its score: the box ends on the floor): slid in just above the floor,
    it ends under the object's middle (``under``) or stops at its edge."""
    summary = ResultSummary(frac_inside_bbox=float(under), frac_on_ground=1.0, frac_touching_object=0.0,
                            mean_height=(0.05 - h[2]) / h[2], object_tilt_deg=0.0, agent_tilt_deg=0.0,
                            agent_speed=0.0, frac_beneath_middle=float(under))
    return CandidateInteraction(plan=plan, description=plan, via_poses=[[1.0, 0.0, 0.1], [0.0, 0.0, 0.05]],
                                score=-0.5, summary=summary)


def _verdict(affordance: str, *poses: PoseCandidates):
    return analyze_functional_poses(FunctionalPoseRequest(affordance=affordance, expected_outcome="rests",
                                                          poses=list(poses)))


def _outcome(agent_pos: list[float], h: list[float]) -> Outcomes:
    """One rollout: one level agent at ``agent_pos`` (task frame) touching the object, not the ground."""
    z = np.zeros((1, 1), dtype=np.int64)
    return Outcomes(
        pose_index=np.zeros(1, dtype=np.int64), plan_index=np.zeros(1, dtype=np.int64),
        agent_pos=np.array([[agent_pos]], dtype=float), agent_quat=np.array([[[1.0, 0.0, 0.0, 0.0]]]),
        agent_vel=np.zeros((1, 1, 3)), contacts_object=z + 1, contacts_agents=z, contacts_ground=z,
        released_early=z.astype(bool), object_pos=np.zeros((1, 3)), object_quat=np.array([[1.0, 0.0, 0.0, 0.0]]),
        object_tilt=np.zeros(1), object_half_extents=np.array([h], dtype=float), settled=np.ones(1, dtype=bool),
    )


def _score(affordance: str, h: list[float], agent_pos: list[float]) -> float:
    dims = sorted((2 * v for v in h), reverse=True)
    return float(compile_scoring(generate_profile(affordance, dims).scoring.source)(_outcome(agent_pos, h))[0])


def test_an_armchair_seat_scores_whatever_the_arms_make_its_box():
    seated = [0.0, 0.0, -ARMCHAIR[2] + 0.45 + 0.05]  # pelvis bottom 0.45 m up, at the centre
    assert _score("chair", ARMCHAIR, seated) > 0
    assert _score("chair", ARMCHAIR, [0.0, 0.0, ARMCHAIR[2] + 0.05]) < 0  # on top of its 0.79 m back


def test_an_armchair_is_a_chair_and_a_stool_in_its_upright_pose():
    upright = _pose(0, 0.2, ARMCHAIR, CENTRE + AREA[:3], 0.45)
    for name in ("chair", "stool"):
        verdict = _verdict(name, upright)
        assert verdict.best_pose == 0, verdict.poses[0].reason


def test_a_seat_for_two_is_no_chair_and_a_seat_for_one_no_bench():
    sofa = [0.9, 0.42, 0.42]
    two = _pose(0, 0.3, sofa, CENTRE + AREA + BESIDE, 0.45)
    chair = _verdict("chair", two)
    assert chair.best_pose is None and "more than one" in chair.poses[0].reason
    assert _verdict("bench", two).best_pose == 0
    one = _pose(0, 0.3, ARMCHAIR, CENTRE + AREA + BESIDE[:1], 0.45)  # a second pelvis rests on one side only
    bench = _verdict("bench", one)
    assert bench.best_pose is None and "side by side" in bench.poses[0].reason
    assert _verdict("chair", one).best_pose == 0
    seat = _pose(0, 0.3, ARMCHAIR, CENTRE + AREA, 0.45)
    arms = [_rests(p, ARMCHAIR, 0.62, 0.05) for p in BESIDE]  # the second pelvis lands on the rolled arms
    on_arms = seat.model_copy(update={"candidates": seat.candidates + arms})
    assert _verdict("chair", on_arms).best_pose == 0 and _verdict("bench", on_arms).best_pose is None


def test_a_pouf_rolled_on_its_side_is_not_its_seat():
    """On its side a pouf bears the pelvis on its ridge where it is lowered at the centre, and tips it off when
    it is lowered a little off the centre; upright its top bears it there too. The side pose is the likelier one
    and both hold the centre plans."""
    side_box, up_box = [0.28, 0.21, 0.28], [0.28, 0.28, 0.21]
    side = _pose(0, 0.4, side_box, CENTRE, 0.55)
    upright = _pose(1, 0.2, up_box, ("above",) + AREA, 0.42)
    verdict = _verdict("chair", side, upright)
    assert [v.accept for v in verdict.poses] == [False, True]
    assert "no seat area" in verdict.poses[0].reason


def test_a_chair_lying_on_its_back_is_not_its_seat():
    """Lying on its back a chair bears the pelvis on its box's top from every approach; standing, its back rises
    behind the seat and stops the approach from behind. The lying pose is the likelier one."""
    lying, standing = [0.45, 0.25, 0.21], [0.25, 0.21, 0.45]
    verdict = _verdict("chair", _pose(0, 0.35, lying, CENTRE + AREA, 0.42),
                       _pose(5, 0.03, standing, CENTRE[:4] + AREA, 0.45))
    assert [v.accept for v in verdict.poses] == [True, True] and verdict.best_pose == 5


def test_a_console_upside_down_on_its_legs_is_not_its_table_pose():
    """Upside down, the box rests on the console's bottom among the legs that rise 9 cm above it; upright on the
    top. Both hold every placement, and the upturned pose is the likelier one."""
    upright = upturned = [0.845, 0.36, 0.34]  # 1.69 x 0.72 m, 0.68 m high on 9 cm legs
    standing = _pose(1, 0.17, upright, TOPS, 0.68, 0.015)
    standing.failed.append(_slid("under_front", upright, under=True))  # under the carcass, between the legs
    verdict = _verdict("table", _pose(0, 0.22, upturned, TOPS, 0.59, 0.015), standing)
    assert [v.accept for v in verdict.poses] == [False, True]
    assert "free space above" in verdict.poses[0].reason and verdict.best_pose == 1


def test_a_pouf_on_its_side_is_a_ridge_its_seat_has_an_area_both_ways():
    """Rolled on its side a pouf nearly as tall as it is wide bears the pelvis on its ridge at the centre and off
    it along the ridge, not across it: no seat area; upright its top bears it off the centre every way. The side
    pose is the likelier one and holds as many centre plans."""
    side_box, up_box = [0.207, 0.204, 0.207], [0.207, 0.207, 0.201]
    side = _pose(0, 0.29, side_box, CENTRE + AREA[2:], 0.41)
    upright = _pose(2, 0.11, up_box, CENTRE + AREA, 0.41)
    verdict = _verdict("chair", side, upright)
    assert [v.accept for v in verdict.poses] == [False, True] and verdict.best_pose == 2
    assert "only along one axis" in verdict.poses[0].reason


def test_a_bar_chair_seat_is_a_chair_but_not_a_seat_on_a_back():
    """A bar chair seats a person 0.72 m up (feet on its rung); a pelvis on an armchair's 0.79 m back is no sitter."""
    bar = [0.23, 0.22, 0.53]  # 0.46 x 0.44 m, 1.06 m to the top of its back
    assert _verdict("chair", _pose(0, 0.3, bar, CENTRE + AREA, 0.72)).best_pose == 0
    assert _score("chair", bar, [0.0, 0.0, -bar[2] + 0.72 + 0.05]) > 0
    assert _score("chair", ARMCHAIR, [0.0, 0.0, ARMCHAIR[2] + 0.05]) < 0


def test_a_desk_deeper_than_high_is_a_table_a_bathtub_on_its_side_is_not():
    """A desk 0.74 m high and 0.6 m deep holds items on its top, and the box slid in above the floor from its front
    ends in its knee space; a bathtub on its side, 0.79 m high and 0.55 m deep, holds them too, but the slid box
    meets its walls at the edge from every side."""
    desk, tub = [0.7, 0.3, 0.37], [0.75, 0.275, 0.395]
    assert _score("table", desk, [0.0, 0.0, desk[2] + 0.015]) > 0
    standing = _pose(0, 0.4, desk, TOPS, 0.74, 0.015)
    standing.failed.extend([_slid("under_front", desk, under=True), _slid("under_left", desk, under=False)])
    assert _verdict("table", standing).best_pose == 0
    lying = _pose(0, 0.4, tub, TOPS, 0.79, 0.015)
    lying.failed.extend(_slid(f"under_{side}", tub, under=False) for side in ("front", "back", "left", "right"))
    verdict = _verdict("table", lying)
    assert verdict.best_pose is None and "no room for feet" in verdict.poses[0].reason


def test_a_pouf_on_its_feet_is_its_seat_not_upside_down_among_them():
    """Upside down, a pouf on feet bears the pelvis on its bottom, 4 cm below the tops of the feet that rise round
    it; upright, on its cushion, the top of the object. Both hold every plan, and upside down is the likelier."""
    box = [0.29, 0.29, 0.22]
    verdict = _verdict("chair", _pose(1, 0.23, box, CENTRE + AREA, 0.40), _pose(2, 0.22, box, CENTRE + AREA, 0.44))
    assert [v.accept for v in verdict.poses] == [True, True] and verdict.best_pose == 2


def test_a_high_seat_with_nothing_behind_it_is_no_chair():
    """A round pedestal table 0.71 m high bears the pelvis at its centre and off it, and a second pelvis 0.35 m from
    its centre slides off its rocking top; a bar chair's seat as high has a back rising 0.3 m behind the sitter."""
    top = [0.59, 0.59, 0.357]
    verdict = _verdict("chair", _pose(0, 0.5, top, CENTRE + AREA, 0.714))
    assert verdict.best_pose is None and "has a back" in verdict.poses[0].reason
    assert _verdict("stool", _pose(0, 0.5, top, CENTRE + AREA, 0.714)).best_pose == 0  # a stool needs none
    bar = [0.23, 0.22, 0.53]
    assert _verdict("chair", _pose(0, 0.3, bar, CENTRE + AREA, 0.72)).best_pose == 0
    low = [0.59, 0.59, 0.25]  # a 0.5 m low table is as high as a chair's seat: the second sitter tells
    assert _verdict("chair", _pose(0, 0.5, low, CENTRE + AREA, 0.5)).best_pose == 0
