"""Seat and surface verdicts rest on where the agent came to rest, not on the object's box (issue 13).

Stage 7 is exercised on hand-made candidates (what the rollouts would report), stage 6 on hand-made
outcomes, so each test runs in well under a second.
"""

from __future__ import annotations

import numpy as np

from rail_mj.core.profile import CandidateInteraction, PoseCandidates, ResultSummary, SegmentState
from rail_mj.core.types import Outcomes
from rail_mj.llm import FunctionalPoseRequest, analyze_functional_poses, generate_profile
from rail_mj.mjcf.body import body_size
from rail_mj.scoring import compile_scoring

#: An upholstered armchair as it stands: rolled arms and a back make its box 0.91 m wide around a 0.55 m seat.
ARMCHAIR = [0.455, 0.375, 0.395]
SITS = ("facing_front", "facing_front_back", "facing_left", "facing_right")
BESIDE = ("facing_left_beside_front", "facing_left_beside_back", "facing_right_beside_back")
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


def _sits(plan: str, h: list[float], hips: float, *, agent: int = 0, torso_on: bool = False,
          feet: str = "ground", thighs: str = "seat", pelvis_deg: float = 0.0, knees_deg: float = 10.0,
          bones: bool = True, torso_deg: float = 16.0) -> list[SegmentState]:
    """The sitting body's segments, its hip joints ``hips`` m up on the object, thighs level, torso upright (on the
    object when ``torso_on``); its feet on the ``ground``, on the ``object`` (a rung), hanging where a ``rung`` is
    within their reach as the knees bend, or hanging in the ``air``; ``thighs`` level on the ``seat``, or with the knees
    ``knees_deg`` above the hips, ``over`` a seat pan or ``off`` the object (nothing under them); the pelvis tilted back
    ``pelvis_deg`` and the torso ``torso_deg``; the object under both sitting bones unless not ``bones``."""
    seg = [SegmentState(agent=agent, name="pelvis", height=hips, up=float(np.cos(np.radians(pelvis_deg))),
                        touching_object=True, on_ground=False, reaches_object=bones),
           SegmentState(agent=agent, name="torso", height=hips + 0.14, up=float(np.cos(np.radians(torso_deg))),
                        touching_object=torso_on, on_ground=False),
           SegmentState(agent=agent, name="head", height=hips + 0.5, up=0.96, touching_object=False, on_ground=False)]
    for side in ("l", "r"):
        seg += [SegmentState(agent=agent, name=f"thigh_{side}", height=hips,
                             up=0.0 if thighs == "seat" else -np.sin(np.radians(knees_deg)),
                             touching_object=thighs == "seat", on_ground=False, reaches_object=thighs == "over"),
                SegmentState(agent=agent, name=f"shank_{side}", height=hips, up=1.0, touching_object=False,
                             on_ground=False),
                SegmentState(agent=agent, name=f"foot_{side}", height=max(0.07, hips - 0.43), up=1.0,
                             touching_object=feet == "object", on_ground=feet == "ground",
                             reaches_object=feet == "rung")]
    return seg


def _body(plan: str, h: list[float], hips: float, **kw) -> CandidateInteraction:
    """A candidate whose body sits with its hip joints ``hips`` m up (see :func:`_sits`)."""
    mean = (hips - h[2]) / h[2]
    summary = ResultSummary(frac_inside_bbox=1.0, frac_on_ground=float(kw.get("feet", "ground") == "ground"),
                            frac_touching_object=1.0, mean_height=mean, object_tilt_deg=0.5, agent_tilt_deg=1.0,
                            agent_speed=0.0, segments=_sits(plan, h, hips, **kw))
    return CandidateInteraction(plan=plan, description=plan, via_poses=[[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]],
                                score=0.5, summary=summary)


def _seated(index: int, probability: float, h: list[float], plans: tuple[str, ...], hips: float,
            **kw) -> PoseCandidates:
    return PoseCandidates(pose_index=index, probability=probability, half_extents=h,
                          candidates=[_body(p, h, hips, **kw) for p in plans])


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
    # the body's root is its hip joints, a thigh's radius above its buttocks (the agent's half height, as the box
    # pelvis's was 0.05 m: this test's heights changed with the agent)
    up = body_size().thigh_radius
    seated = [0.0, 0.0, -ARMCHAIR[2] + 0.45 + up]  # buttocks 0.45 m up, at the centre
    assert _score("chair", ARMCHAIR, seated) > 0
    # a rest height is a prior up to where it is negligible (a chair's 0.78 m typical top, 1.0 m): on top of a 1.1 m
    # back the scoring refuses; on top of this 0.79 m one it passes, and the rules and the rest prior weigh it
    high = [*ARMCHAIR[:2], 0.55]
    assert _score("chair", high, [0.0, 0.0, high[2] + up]) < 0
    assert _score("chair", ARMCHAIR, [0.0, 0.0, ARMCHAIR[2] + up]) > 0


def test_an_armchair_is_a_chair_and_a_stool_in_its_upright_pose():
    upright = _seated(0, 0.2, ARMCHAIR, SITS, 0.52, torso_on=True)
    for name in ("chair", "stool"):
        verdict = _verdict(name, upright)
        assert verdict.best_pose == 0, verdict.poses[0].reason


def test_a_bench_seats_the_body_at_two_places_side_by_side():
    sofa = [0.9, 0.42, 0.42]
    both = _seated(0, 0.3, sofa, BESIDE, 0.52)
    assert _verdict("bench", both).best_pose == 0
    one = _seated(0, 0.3, sofa, BESIDE[:1] + BESIDE[2:3], 0.52)  # the body sits at one place facing either way
    bench = _verdict("bench", one)
    assert bench.best_pose is None and "side by side" in bench.poses[0].reason


def test_a_chair_lying_on_its_back_is_not_its_seat():
    """Lying on its back a chair seats the body on its box's top from every approach; standing, its back bears the
    sitter's torso. The lying pose is the likelier one."""
    lying, standing = [0.45, 0.25, 0.21], [0.25, 0.21, 0.45]
    verdict = _verdict("chair", _seated(0, 0.35, lying, SITS, 0.49),
                       _seated(5, 0.03, standing, SITS[:2], 0.52, torso_on=True))
    assert [v.accept for v in verdict.poses] == [True, True] and verdict.best_pose == 5


def test_an_armchair_on_its_back_is_a_perch_its_upright_seat_puts_the_feet_down():
    """An upholstered armchair lying on its back seats the body 0.78 m up on its box's top, the feet on the object (a
    ledge: a perch); standing, the feet reach the floor from a 0.45 m seat. Neither torso finds the back, as many
    plans pass, and the lying pose is the likelier: the feet put down decide. A bar chair standing perches the feet
    on its rung, and seats the body from more approaches than lying on its back, where the feet reach the floor."""
    lying, standing = [0.44, 0.41, 0.34], list(ARMCHAIR)
    up = body_size().thigh_radius
    verdict = _verdict("chair", _seated(0, 0.22, lying, SITS[:2], 0.78, feet="object"),
                       _seated(4, 0.13, standing, SITS[:2], 0.45 + up))
    assert [v.accept for v in verdict.poses] == [True, True] and verdict.best_pose == 4
    # the feet hanging within a toe's reach of the floor count as put down
    verdict = _verdict("chair", _seated(0, 0.22, lying, SITS[:2], 0.78, feet="object"),
                       _seated(4, 0.13, standing, SITS[:2], 0.45 + up, feet="air"))
    assert verdict.best_pose == 4
    bar = [0.23, 0.22, 0.53]
    verdict = _verdict("chair", _seated(1, 0.2, [0.53, 0.23, 0.22], SITS[:1], 0.49),
                       _seated(5, 0.02, bar, SITS[2:], 0.72 + up, feet="object"))
    assert [v.accept for v in verdict.poses] == [True, True] and verdict.best_pose == 5


def test_a_console_upside_down_on_its_legs_is_not_its_table_pose():
    """Upside down, the box rests on the console's bottom among the legs that rise 9 cm above it; upright on the
    top. Both hold every placement, and the upturned pose is the likelier one."""
    upright = upturned = [0.845, 0.36, 0.34]  # 1.69 x 0.72 m, 0.68 m high on 9 cm legs
    standing = _pose(1, 0.17, upright, TOPS, 0.68, 0.015)
    standing = standing.model_copy(update={"toe_room": 0.3})  # under the carcass, between the legs
    verdict = _verdict("table", _pose(0, 0.22, upturned, TOPS, 0.59, 0.015), standing)
    assert [v.accept for v in verdict.poses] == [False, True]
    assert "free space above" in verdict.poses[0].reason and verdict.best_pose == 1


def test_a_bar_chair_seat_is_a_chair_but_not_a_seat_on_a_back():
    """A bar chair seats a person 0.72 m up (feet on its rung); the body on top of its 1.06 m back is no sitter."""
    bar = [0.23, 0.22, 0.53]  # 0.46 x 0.44 m, 1.06 m to the top of its back
    up = body_size().thigh_radius
    assert _verdict("chair", _seated(0, 0.3, bar, SITS, 0.72 + up, feet="object")).best_pose == 0
    assert _score("chair", bar, [0.0, 0.0, -bar[2] + 0.72 + up]) > 0
    assert _score("chair", bar, [0.0, 0.0, bar[2] + up]) < 0


def test_a_desk_deeper_than_high_is_a_table_a_bathtub_on_its_side_is_not():
    """A desk 0.74 m high and 0.6 m deep holds items on its top, and feet get into its knee space; a bathtub on its
    side, 0.79 m high and 0.55 m deep, holds them too, but feet meet its walls at the edge from every side."""
    desk, tub = [0.7, 0.3, 0.37], [0.75, 0.275, 0.395]
    assert _score("table", desk, [0.0, 0.0, desk[2] + 0.015]) > 0
    standing = _pose(0, 0.4, desk, TOPS, 0.74, 0.015)
    standing = standing.model_copy(update={"toe_room": 0.4})
    assert _verdict("table", standing).best_pose == 0
    lying = _pose(0, 0.4, tub, TOPS, 0.79, 0.015)
    lying = lying.model_copy(update={"toe_room": 0.0})
    verdict = _verdict("table", lying)
    assert verdict.best_pose is None and "no room for feet" in verdict.poses[0].reason


def test_a_high_seat_the_feet_do_not_reach_is_no_seat():
    """A round pedestal table 0.71 m high carries the body, whose feet hang in the air; a bar chair's seat as high
    has a rung its feet rest on, or reach as the knees bend; a 0.5 m low table is as high as a chair's seat, and the
    feet reach the floor."""
    top = [0.59, 0.59, 0.357]
    up = body_size().thigh_radius
    for name in ("chair", "stool"):
        verdict = _verdict(name, _seated(0, 0.5, top, SITS, 0.714 + up, feet="air"))
        assert verdict.best_pose is None and "the feet hang" in verdict.poses[0].reason
    bar = [0.23, 0.22, 0.53]
    for feet in ("object", "rung"):
        assert _verdict("chair", _seated(0, 0.3, bar, SITS, 0.72 + up, feet=feet)).best_pose == 0
    low = [0.59, 0.59, 0.25]
    assert _verdict("chair", _seated(0, 0.5, low, SITS, 0.5 + up)).best_pose == 0


def test_on_a_seat_lower_than_the_knees_the_thighs_rise_off_the_seat_still_under_them():
    """On a 0.36 m seat the feet on the floor hold the knees above the hips and the thighs rise off the seat's front,
    the seat still under them: a low seat. Thighs with nothing under them (an edge or a rail) are carried by nothing
    the object offers."""
    low = [0.25, 0.25, 0.25]
    up = body_size().thigh_radius
    assert _verdict("chair", _seated(0, 0.5, low, SITS, 0.36 + up, thighs="over")).best_pose == 0
    verdict = _verdict("chair", _seated(0, 0.5, low, SITS, 0.36 + up, thighs="off"))
    assert verdict.best_pose is None and "does not carry the thighs" in verdict.poses[0].reason


def test_a_pelvis_tilted_back_past_a_work_seats_tilt_sits_only_against_a_back():
    """An easy chair's seat tilts back 14-24° and its back bears the reclined trunk: the pelvis rests 20° back, or 30°
    (rolled back on the seat by the hips' give), with the torso on the object. Without a back, or 36° back, the sitter
    slides."""
    seat = [0.25, 0.25, 0.25]
    up = body_size().thigh_radius
    for deg in (20, 30):
        verdict = _verdict("chair", _seated(0, 0.5, seat, SITS, 0.42 + up, pelvis_deg=deg, torso_on=True))
        assert verdict.best_pose == 0, deg
    for deg, back in ((20, False), (36, True)):
        verdict = _verdict("chair", _seated(0, 0.5, seat, SITS, 0.42 + up, pelvis_deg=deg, torso_on=back))
        assert verdict.best_pose is None and "the pelvis leans" in verdict.poses[0].reason


def test_a_pelvis_leans_back_with_the_thighs_a_low_reclined_seat_raises():
    """On a lounge chair's low reclined seat the feet hold the knees 26° above the hips: the pelvis sits 35° back
    against the back, within the hips' give of the thighs; 37° back on the same thighs, it has rolled past that give.
    On thighs risen 10°, 35° is past an easy chair's seat and the give."""
    seat = [0.25, 0.25, 0.25]
    up = body_size().thigh_radius
    assert _verdict("chair", _seated(0, 0.5, seat, SITS, 0.36 + up, pelvis_deg=35, torso_on=True, thighs="over",
                                     knees_deg=26)).best_pose == 0
    for deg, knees in ((37, 26), (35, 10)):
        verdict = _verdict("chair", _seated(0, 0.5, seat, SITS, 0.36 + up, pelvis_deg=deg, torso_on=True,
                                            thighs="over", knees_deg=knees))
        assert verdict.best_pose is None and "the pelvis leans" in verdict.poses[0].reason, (deg, knees)


def test_the_seat_kind_needs_its_body():
    """The box pelvis's candidates (no segments) are no evidence of sitting."""
    verdict = _verdict("chair", _pose(0, 0.2, ARMCHAIR, ("facing_front",), 0.45))
    assert verdict.best_pose is None and "articulated body" in verdict.poses[0].reason


def test_a_pelvis_rolls_back_with_the_trunk_on_a_lounge_chairs_far_reclined_back():
    """On a lounge chair whose back leans 55-65° the trunk on it rolls the pelvis 41° back, past the thighs' 30° rise
    and the hips' give: the lumbar spine flattens, so the pelvis may lean as far as the trunk it carries. Rolled back
    past a trunk leaning 30°, the spine would arch; a trunk at 76° on thighs risen 30° opens the hips past Keegan's
    135°: lying."""
    seat = [0.25, 0.25, 0.25]
    up = body_size().thigh_radius
    assert _verdict("chair", _seated(0, 0.5, seat, SITS, 0.36 + up, pelvis_deg=41, torso_on=True, thighs="over",
                                     knees_deg=30, torso_deg=64)).best_pose == 0
    for torso, why in ((30, "the pelvis leans"), (76, "the torso leans")):
        verdict = _verdict("chair", _seated(0, 0.5, seat, SITS, 0.36 + up, pelvis_deg=41, torso_on=True,
                                            thighs="over", knees_deg=30, torso_deg=torso))
        assert verdict.best_pose is None and why in verdict.poses[0].reason, torso
