"""The offline profile library, stage checks and the offline Functional Pose Analyzer."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rail_mj.affordances import ANY, LIQUID_RADIUS, PAPER_AFFORDANCES, REGISTRY
from rail_mj.affordances.kinds import ContainerParams
from rail_mj.affordances.prior import NEGLIGIBLE
from rail_mj.core.errors import ConfigError, UnknownAffordanceError
from rail_mj.core.profile import AgentLayout, CandidateInteraction, PoseCandidates, ResultSummary, SegmentState
from rail_mj.core.results import BasinInfo
from rail_mj.core.types import Outcomes, StablePose
from rail_mj.imagination.inputs import agent_setup, layout_offsets, trajectory_array
from rail_mj.imagination.summary import result_summary
from rail_mj.imagination.worlds import ImaginedWorlds
from rail_mj.llm import (
    FunctionalPoseRequest,
    ImaginationProfile,
    analyze_functional_poses,
    functional_pose_request,
    generate_profile,
    get_provider,
    known_affordances,
    normalize_affordance,
)
from rail_mj.llm.checks import InvalidAnswerError, check_layout, check_trajectories
from rail_mj.scoring import compile_scoring


def _across(rng: tuple[float, float], where: float) -> float:
    """``where`` in [0, 1] across a range in log scale; an open side is a factor 2 from the other."""
    lo, hi = rng
    lo, hi = (lo or hi / 2), (hi if math.isfinite(hi) else 2 * lo)
    return lo * (hi / lo) ** where


def _dims(name: str, where: float) -> list[float]:
    """Plausible sorted dims for an affordance: ``where`` in [0, 1] across its typical ranges (log scale): the OBB's
    largest and smallest, or the envelope's height, width and length."""
    spec = REGISTRY[name]
    env = spec.envelope
    if env.ranges():
        across = env.width if env.width != ANY else env.length
        if env.length != ANY:  # a box is never wider than it is long: a width open above stops at the length's
            across = (across[0], min(across[1], env.length[1]))
        width = _across(across, where)
        length = _across(env.length, where) if env.length != ANY else width
        return sorted((_across(env.height, where), width, max(width, length)), reverse=True)
    big, small = _across(spec.largest, where), _across(spec.smallest, where)
    small = min(small, big)
    return [big, math.sqrt(big * small), small]


#: Rows whose agent keeps its kind's least size at both of the test's dims, whose middle dim (the geometric mean of
#: the others) makes a flat object a narrow strip: the saucer's food disc (2 cm radius) and the cutting board's
#: book (8 cm; it only grows on boards over 33 cm wide).
_AGENT_AT_LEAST_SIZE = ("saucer", "cutting board", "soap dish")


def test_catalogue_covers_the_paper_and_more():
    names = known_affordances()
    assert set(PAPER_AFFORDANCES) <= set(names)
    assert len(set(names) - set(PAPER_AFFORDANCES)) >= 8


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_every_affordance_makes_a_valid_profile_that_scales(name):
    small = generate_profile(name, _dims(name, 0.2))
    large = generate_profile(name, _dims(name, 0.8))
    for p in (small, large):
        assert p.analysis.fits and p.analysis.alternative is None
        assert len(p.plans.plans) >= 5
        assert [t.plan for t in p.trajectories.trajectories] == [pl.name for pl in p.plans.plans]
        assert ImaginationProfile.model_validate_json(p.model_dump_json()) == p
        setup = agent_setup(p.agent.mjcf, p.layout)
        assert setup.offsets.shape == (p.layout.n_agents, 3)
    kind = REGISTRY[name].kind
    # a drop of water has the same size in any vessel
    params = REGISTRY[name].params  # only a container's rows have droplets (the others never were liquid)
    liquid = isinstance(params, ContainerParams) and params.droplets.max_radius <= LIQUID_RADIUS
    grows = kind in ("container", "dish", "surface", "storage") and name not in _AGENT_AT_LEAST_SIZE
    if grows and not liquid:  # seat and bed agents stay human-sized
        assert small.agent.mjcf != large.agent.mjcf
    h_small = np.asarray(small.obb_dims) / 2
    start_small = trajectory_array(small.trajectories.trajectories, h_small)[0][0, :3]
    start_large = trajectory_array(small.trajectories.trajectories, 2 * h_small)[0][0, :3]
    assert not np.allclose(start_small, start_large)  # the same profile adapts to the pose's size


def test_profile_json_round_trip_is_exact():
    profile = generate_profile("Chair", [0.5, 0.9, 0.48])
    assert profile.obb_dims == [0.9, 0.5, 0.48]  # sorted descending
    text = profile.model_dump_json()
    assert ImaginationProfile.model_validate_json(text).model_dump_json() == text


@pytest.mark.parametrize(("given", "canonical"), [
    ("CUPS", "cup"), ("Trash_Bins", "trash bin"), ("shelves", "shelf"), ("pen-holder", "pen holder"),
    ("  Benches ", "bench"), ("mug", "cup"), ("Bowls", "bowl"),
])
def test_name_normalisation(given, canonical):
    assert normalize_affordance(given) == canonical


def test_unknown_affordance_lists_known_ones_and_the_llm_route():
    with pytest.raises(UnknownAffordanceError) as err:
        generate_profile("trampoline", [1.0, 1.0, 0.3])
    msg = str(err.value)
    assert all(name in msg for name in known_affordances())
    assert "anthropic" in msg and "ANTHROPIC_API_KEY" in msg


@pytest.mark.parametrize(("name", "dims", "alternative"), [
    ("cup", [1.6, 0.8, 0.6], "bathtub"),
    ("bathtub", [0.06, 0.05, 0.05], "cup"),
    ("table", [0.15, 0.15, 0.1], None),
    ("chair", [0.15, 0.1, 0.1], None),
    ("plate", [0.3, 0.3, 0.25], None),
])
def test_dimension_check_and_alternative(name, dims, alternative):
    profile = generate_profile(name, dims)
    assert not profile.analysis.fits and "prior" in profile.analysis.reason
    assert profile.analysis.alternative == alternative
    assert profile.affordance == name  # still imagined as asked; the chain decides by the prior


@pytest.mark.parametrize("name", ["bowl", "basket"])
def test_a_small_bowl_fits_the_bowl_and_basket_sizes(name):
    # a bowl with a 13 cm rim, 5 cm deep, upright: the smallest the dataset makes, and it is both
    assert REGISTRY[name].dims_fit([0.13, 0.13, 0.05])
    assert REGISTRY[name].pose_fits([0.065, 0.065, 0.025])[0]


def test_provider_selection(monkeypatch):
    monkeypatch.delenv("ANTHROPIC_API_KEY", raising=False)
    assert get_provider("auto").name == "offline"
    with pytest.raises(ConfigError, match="valid: auto, offline, anthropic"):
        get_provider("gpt")
    with pytest.raises(ConfigError, match="half_extents"):
        trajectory_array(generate_profile("cup", [0.1, 0.08, 0.08]).trajectories.trajectories, [0.05, -1.0, 0.04])


def test_layout_and_trajectory_checks_reject_overlap_and_bad_starts():
    layout = AgentLayout(nx=2, ny=1, nz=1, sx=0.01, sy=0.01, sz=0.01, collide_agents=True)
    with pytest.raises(InvalidAnswerError, match="overlap along x"):
        check_layout(layout, radius=0.01)
    profile = generate_profile("cup", [0.1, 0.08, 0.08])
    offsets = layout_offsets(profile.layout)
    assert np.allclose(offsets.mean(axis=0), 0) and offsets.shape == (27, 3)
    h = np.array([0.04, 0.04, 0.05])
    check_trajectories(profile.trajectories, profile.plans, 0.005, offsets, [h])
    inside = profile.trajectories.model_copy(deep=True)
    inside.trajectories[0].via_poses[0].offset_m[2] = -0.06  # start sinks into the cup
    with pytest.raises(InvalidAnswerError, match="overlaps the object's box"):
        check_trajectories(inside, profile.plans, 0.005, offsets, [h])


def _outcomes(agent_pos, h, *, quat=None, tilt=0.0, on_object=1, on_ground=0) -> Outcomes:
    """One-rollout Outcomes with agents at ``agent_pos`` (N, 3) for object half extents ``h``."""
    pos = np.asarray(agent_pos, dtype=float)[None]
    n = pos.shape[1]
    q = np.tile([1.0, 0, 0, 0] if quat is None else quat, (1, n, 1))
    z = np.zeros((1, n), dtype=np.int64)
    return Outcomes(
        pose_index=np.zeros(1, dtype=np.int64), plan_index=np.zeros(1, dtype=np.int64), agent_pos=pos,
        agent_quat=q, agent_vel=np.zeros_like(pos), contacts_object=z + on_object, contacts_agents=z,
        contacts_ground=z + on_ground, released_early=z.astype(bool), object_pos=np.zeros((1, 3)),
        object_quat=np.array([[1.0, 0, 0, 0]]), object_tilt=np.array([tilt]),
        object_half_extents=np.asarray(h, dtype=float)[None], settled=np.ones(1, dtype=bool),
    )


def _score(name: str, dims: list[float], outcomes: Outcomes) -> float:
    return float(compile_scoring(generate_profile(name, dims).scoring.source)(outcomes)[0])


def test_container_scoring_fills_spills_and_tips():
    h = [0.04, 0.04, 0.05]
    inside = np.random.default_rng(0).uniform(-0.03, 0.03, (27, 3))
    assert _score("cup", [0.1, 0.08, 0.08], _outcomes(inside, h)) > 0
    spilled = inside + [0.1, 0.0, 0.0]
    assert _score("cup", [0.1, 0.08, 0.08], _outcomes(spilled, h, on_ground=1)) < 0
    assert _score("cup", [0.1, 0.08, 0.08], _outcomes(inside, h, tilt=math.radians(60))) < 0
    leaked = inside.copy()
    leaked[0] = [0.0, 0.0, -0.045]  # one droplet came through the bottom
    on_ground = np.zeros((1, 27), dtype=np.int64)
    on_ground[0, 0] = 1
    out = _outcomes(leaked, h)
    out = dataclasses.replace(out, contacts_ground=on_ground)
    assert _score("cup", [0.1, 0.08, 0.08], out) < 0


def test_seat_scoring_height_and_uprightness():
    dims, h = [0.9, 0.5, 0.48], [0.25, 0.24, 0.45]
    seated = [[0.0, 0.0, -0.45 + 0.45 + 0.05]]  # pelvis bottom 0.45 m above the ground
    assert _score("chair", dims, _outcomes(seated, h)) > 0
    high = [0.25, 0.24, 0.55]  # on top of a 1.1 m back: past where a chair's rest prior is negligible
    assert _score("chair", dims, _outcomes([[0.0, 0.0, 0.55]], high)) < 0
    tipped = [math.cos(math.radians(40)), math.sin(math.radians(40)), 0.0, 0.0]
    assert _score("chair", dims, _outcomes(seated, h, quat=tipped)) < 0


def test_plate_must_be_low():
    """Low is the plate's prior, not its scoring: a plate on its edge whose rim holds the food scores by the
    physics, and its pose is a 25 cm tall "plate", past every plate's height."""
    food_on_plate = [[0.0, 0.0, 0.02]]
    flat, edge = [0.125, 0.125, 0.015], [0.125, 0.015, 0.125]
    assert _score("plate", [0.25, 0.25, 0.03], _outcomes(food_on_plate, flat)) > 0
    assert _score("plate", [0.25, 0.25, 0.03], _outcomes([[0.0, 0.0, 0.1]], edge)) > 0
    assert REGISTRY["plate"].pose_prior(flat).value == 1.0 and REGISTRY["plate"].pose_prior(edge).value < NEGLIGIBLE


def _candidate(plan, start, score=0.4, **summary) -> CandidateInteraction:
    base = dict(frac_inside_bbox=0.9, frac_on_ground=0.0, frac_touching_object=0.8, mean_height=-0.4,
                object_tilt_deg=1.0, agent_tilt_deg=5.0, agent_speed=0.0)
    return CandidateInteraction(plan=plan, description=plan, via_poses=[start, [0.0, 0.0, 0.0]], score=score,
                                summary=ResultSummary(**{**base, **summary}))


def test_functional_pose_rules_for_a_cup():
    h = [0.04, 0.04, 0.05]
    upright = PoseCandidates(pose_index=0, probability=0.4, half_extents=h,
                             basin=BasinInfo(rim=0.095, opening=[0.0, 0.0], length=0.07),
                             candidates=[_candidate("above", [0.0, 0.0, 0.1])])
    tipped = PoseCandidates(pose_index=1, probability=0.5, half_extents=h,
                            candidates=[_candidate("above", [0.0, 0.0, 0.1], score=0.5, object_tilt_deg=80.0)])
    from_side = PoseCandidates(pose_index=2, probability=0.1, half_extents=h,
                               candidates=[_candidate("front", [0.1, 0.0, 0.0], score=0.5)])
    verdict = analyze_functional_poses(FunctionalPoseRequest(affordance="Cups", expected_outcome="filled",
                                                             poses=[upright, tipped, from_side]))
    assert [v.accept for v in verdict.poses] == [True, False, False]
    assert "tipping" in verdict.poses[1].reason and "above" in verdict.poses[2].reason
    assert (verdict.best_pose, verdict.best_plan) == (0, "above")


def _sitting(hips: float) -> list[SegmentState]:
    """The seat kind's body sitting with its hip joints ``hips`` m up, feet on the floor."""
    def seg(name: str, height: float, up: float, on_object: bool, on_ground: bool = False) -> SegmentState:
        return SegmentState(agent=0, name=name, height=height, up=up, touching_object=on_object, on_ground=on_ground,
                            reaches_object=name == "pelvis")  # a seat under the sitting bones
    legs = [s for side in "lr" for s in (seg(f"thigh_{side}", hips, 0.0, True), seg(f"shank_{side}", hips, 1.0, False),
                                         seg(f"foot_{side}", 0.07, 1.0, False, True))]
    return [seg("pelvis", hips, 1.0, True), seg("torso", hips + 0.14, 1.0, False), seg("head", hips + 0.5, 1.0, False),
            *legs]


def test_functional_pose_rules_for_a_chair_and_no_valid_pose():
    h = [0.25, 0.24, 0.45]
    seat = _candidate("facing_front", [0.6, 0.0, 0.5], frac_touching_object=1.0, mean_height=0.0,
                      segments=_sitting(0.52))  # the hips 0.52 m up, the buttocks at 0.45 m
    off_centre = [_candidate(p, [0.0, 0.0, 0.8], score=0.3, frac_touching_object=1.0, mean_height=0.0,
                             segments=_sitting(0.52)) for p in ("facing_left", "facing_back")]
    too_high = _candidate("facing_right", [0.0, 0.0, 0.8], frac_touching_object=1.0, mean_height=1.1,
                          segments=_sitting(1.17))  # the buttocks 1.1 m up
    request = FunctionalPoseRequest(affordance="chair", expected_outcome="seated", poses=[
        PoseCandidates(pose_index=0, probability=0.6, half_extents=h, candidates=[too_high]),
        PoseCandidates(pose_index=1, probability=0.4, half_extents=h, candidates=[too_high, seat, *off_centre]),
    ])
    verdict = analyze_functional_poses(request)
    assert [v.accept for v in verdict.poses] == [False, True]
    assert (verdict.best_pose, verdict.best_plan) == (1, "facing_front")
    none = analyze_functional_poses(FunctionalPoseRequest(affordance="chair", expected_outcome="seated", poses=[
        PoseCandidates(pose_index=0, probability=1.0, half_extents=h, candidates=[too_high])]))
    assert none.best_pose is None and none.best_plan is None


def test_pose_size_envelope_is_a_prior_not_a_mask():
    """Droplets held are a success in the scoring and in stage 7 whatever the pose's size; the sizes are the
    pose's prior, which keeps a cup from being a bowl and a bowl from being a cup."""
    inside = np.random.default_rng(1).uniform(-0.03, 0.03, (27, 3))
    cup_pose, bowl_pose = [0.04, 0.04, 0.05], [0.1, 0.1, 0.04]  # 8 x 10 cm cup; 20 cm wide, 8 cm tall bowl
    for name in ("cup", "bowl"):
        assert _score(name, [0.1, 0.08, 0.08], _outcomes(inside, cup_pose)) > 0
        assert _score(name, [0.2, 0.2, 0.08], _outcomes(inside, bowl_pose)) > 0
    assert REGISTRY["cup"].pose_prior(bowl_pose).value < 0.5 < REGISTRY["cup"].pose_prior(cup_pose).value
    assert REGISTRY["bowl"].pose_prior(cup_pose).value < 0.5 < REGISTRY["bowl"].pose_prior(bowl_pose).value
    filled = _candidate("above", [0.0, 0.0, 0.1])
    verdict = analyze_functional_poses(FunctionalPoseRequest(affordance="bowl", expected_outcome="filled", poses=[
        PoseCandidates(pose_index=0, probability=1.0, half_extents=cup_pose, candidates=[filled],
                       basin=BasinInfo(rim=0.1, opening=[0.0, 0.0], length=0.07))]))
    assert verdict.best_pose == 0  # the physics holds; the chain weighs the pose by its prior


def test_table_needs_a_wide_top_and_plate_a_solid_centre():
    h = [0.5, 0.5, 0.375]  # 1 m across, 0.75 m high: the box centre rests 0.765 m up
    placed = {p: _candidate(p, [0.0, 0.0, 1.0], frac_touching_object=1.0, mean_height=1.04)
              for p in ("above", "above_front", "above_back", "above_left", "above_right")}
    top = PoseCandidates(pose_index=0, probability=0.2, half_extents=h, candidates=list(placed.values()),
                         toe_room=0.4)  # feet get in between its legs
    foot = PoseCandidates(pose_index=1, probability=0.8, half_extents=h, candidates=[placed["above"]])
    verdict = analyze_functional_poses(FunctionalPoseRequest(affordance="table", expected_outcome="held",
                                                             poses=[foot, top]))
    assert [v.accept for v in verdict.poses] == [False, True] and verdict.best_pose == 0
    ring = [_candidate(p, [0.0, 0.0, 0.1], frac_touching_object=1.0, mean_height=0.5)
            for p in ("above_front", "above_left")]
    dish = analyze_functional_poses(FunctionalPoseRequest(affordance="plate", expected_outcome="held", poses=[
        PoseCandidates(pose_index=0, probability=1.0, half_extents=[0.1, 0.1, 0.01], candidates=ring)]))
    assert dish.best_pose is None and "centre" in dish.poses[0].reason


def test_result_summary_of_outcomes():
    h = [0.04, 0.04, 0.05]
    pos = [[0.0, 0.0, -0.02], [0.2, 0.0, -0.04]]
    s = result_summary(_outcomes(pos, h, on_ground=0), 0)
    assert s.frac_inside_bbox == 0.5 and s.frac_touching_object == 1.0
    assert s.mean_height == pytest.approx(-0.6) and s.object_tilt_deg == 0.0
    assert s.frac_through_object == 0.0
    # on the ground: the one beneath the middle came through the object, the one beside it did not
    s = result_summary(_outcomes([[0.005, 0.0, -0.045], [0.2, 0.0, -0.045]], h, on_ground=1), 0)
    assert s.frac_through_object == 0.5


def test_a_container_that_leaks_under_the_centre_pour_is_rejected():
    """A bowl with a hole in its base: droplets poured off centre stay, those poured at the centre fall through."""
    h = [0.08, 0.08, 0.028]
    held = _candidate("above_right", [0.024, 0.0, 0.1], score=0.43)
    leaked = _candidate("above", [0.0, 0.0, 0.1], score=-1.0, frac_through_object=0.04)
    missed = _candidate("above", [0.0, 0.0, 0.1], score=-1.0, frac_on_ground=0.3)
    verdicts = [analyze_functional_poses(FunctionalPoseRequest(affordance="basket", expected_outcome="held", poses=[
        PoseCandidates(pose_index=0, probability=1.0, half_extents=h, candidates=[held], failed=[failed])]))
        for failed in (leaked, missed)]
    assert verdicts[0].best_pose is None and "beneath" in verdicts[0].poses[0].reason
    assert verdicts[1].best_pose == 0  # droplets that missed the opening are no evidence of a leak
    # droplets spilt past a cup's handle end on the ground beneath its box, touching nothing: no evidence either
    spilt = _candidate("above_front", [0.024, 0.0, 0.1], score=-1.0, frac_through_object=0.1,
                       frac_touching_object=0.0, frac_on_ground=0.3)
    cup = analyze_functional_poses(FunctionalPoseRequest(affordance="cup", expected_outcome="held", poses=[
        PoseCandidates(pose_index=0, probability=1.0, half_extents=[0.06, 0.042, 0.05],
                       basin=BasinInfo(rim=0.095, opening=[0.0, 0.0], length=0.075),
                       candidates=[held], failed=[spilt])]))
    assert cup.best_pose == 0


def _leak_verdict(affordance, h, held, failed):
    return analyze_functional_poses(FunctionalPoseRequest(affordance=affordance, expected_outcome="held", poses=[
        PoseCandidates(pose_index=0, probability=1.0, half_extents=h, candidates=held, failed=failed)]))


def test_a_side_pour_that_leaks_through_slats_is_rejected():
    """A slatted crate: the centre pours land on a board, the side pours land on slats and leak between them."""
    h = [0.149, 0.082, 0.041]
    held = [_candidate(p, [0.0, 0.0, 0.08], score=0.5, frac_inside_bbox=1.0, frac_touching_object=0.33)
            for p in ("above", "above_front", "above_back")]
    leaked = _candidate("above_left", [0.0, 0.045, 0.08], score=-1.0, frac_inside_bbox=0.89, frac_on_ground=0.3,
                        frac_touching_object=0.81, frac_through_object=0.15)
    verdict = _leak_verdict("bowl", h, held, [leaked])
    assert verdict.best_pose is None and "above_left" in verdict.poses[0].reason


def test_a_centre_pour_over_a_long_handle_is_no_leak():
    """A saucepan's box centre lies over its handle: droplets poured there fall past the pan to the ground beneath
    the box; the pour offset over the pan holds them all."""
    h = [0.17, 0.078, 0.054]
    held = [_candidate("above_front", [0.05, 0.0, 0.1], score=0.5, frac_inside_bbox=1.0, frac_touching_object=1.0)]
    past = _candidate("above", [0.0, 0.0, 0.1], score=-1.0, frac_inside_bbox=0.81, frac_on_ground=0.85,
                      frac_touching_object=0.15, frac_through_object=0.41)
    piled = _candidate("above_back", [-0.05, 0.0, 0.1], score=-1.0, frac_inside_bbox=1.0, frac_on_ground=0.33,
                       frac_touching_object=0.0, frac_through_object=0.33)
    # poured at the pan's edge by the handle: droplets rest on the rim, spill beside the body, one by the handle
    rim = _candidate("above_left", [0.0, 0.03, 0.1], score=-1.0, frac_inside_bbox=0.7, frac_on_ground=0.41,
                     frac_touching_object=0.59, frac_through_object=0.04)
    assert _leak_verdict("basket", h, held, [past, piled, rim]).best_pose == 0


def test_plate_pose_with_the_rim_around_the_food_wins():
    """An upturned plate's flat bottom also holds the disc, on top of it: rejected; the upright plate keeps it
    inside its rim."""
    h = [0.11, 0.11, 0.012]
    plans = ["above", "above_front", "above_back", "above_left", "above_right"]

    def pose(i, prob, mean_height):
        cands = [_candidate(p, [0.0, 0.0, 0.05], score=0.5, frac_touching_object=1.0, mean_height=mean_height)
                 for p in plans]
        return PoseCandidates(pose_index=i, probability=prob, half_extents=h, candidates=cands)

    upturned, upright = pose(0, 0.55, 1.6), pose(1, 0.45, -0.2)
    verdict = analyze_functional_poses(FunctionalPoseRequest(affordance="plate", expected_outcome="food stays",
                                                             poses=[upturned, upright]))
    assert [v.accept for v in verdict.poses] == [False, True]
    assert "not below a rim" in verdict.poses[0].reason
    assert verdict.best_pose == 1


def test_the_leak_test_is_defined_once_for_the_scoring_and_the_analyser(monkeypatch):
    """result_summary and the container scoring source each wrote their own 0.25 ellipse."""
    from rail_mj.core import profile

    h, dims = [0.04, 0.04, 0.05], [0.1, 0.08, 0.08]
    pos = np.random.default_rng(0).uniform(-0.03, 0.03, (27, 3))
    pos[0] = [0.7 * h[0], 0.0, -0.045]  # on the ground, 0.7 of the half size off the middle
    out = dataclasses.replace(_outcomes(pos, h), contacts_ground=np.eye(1, 27, dtype=np.int64))
    assert result_summary(out, 0).frac_through_object == 0.0 and _score("cup", dims, out) > 0
    monkeypatch.setattr(profile, "BENEATH_MIDDLE", 0.9**2)  # a wider middle: that droplet came through
    assert result_summary(out, 0).frac_through_object == pytest.approx(1 / 27)
    assert _score("cup", dims, out) == -1.0


def test_stage_7_request_from_one_batch():
    profile = generate_profile("cup", [0.1, 0.08, 0.08])
    n_plans = len(profile.plans.plans)
    h = np.array([0.04, 0.04, 0.05])
    poses = [StablePose(pos=np.zeros(3), quat=np.array([1.0, 0, 0, 0]), probability=p, half_extents=h * (1 + p))
             for p in (0.5, 0.3, 0.2)]
    kept = [0, 2]  # pose 1 was too rare to imagine
    one = _outcomes(np.random.default_rng(2).uniform(-0.03, 0.03, (27, 3)), h)
    batch = Outcomes(**{f.name: np.repeat(getattr(one, f.name), 2 * n_plans, axis=0)  # pyright: ignore[reportArgumentType]  # no segment names here
                        for f in dataclasses.fields(one) if getattr(one, f.name) is not None})
    trajectories = [trajectory_array(profile.trajectories.trajectories, poses[i].half_extents) for i in kept]
    scores = np.full(2 * n_plans, -1.0)
    evidence = ImaginedWorlds(profile.affordance, 1.0, profile.plans.plans, poses, kept, trajectories)
    assert functional_pose_request(profile, evidence.candidates(evidence.add_nominal(batch, scores))) is None
    scores[n_plans + 1] = 0.3  # one success, in pose 2
    request = functional_pose_request(profile, evidence.candidates(evidence.add_nominal(batch, scores)))
    assert request is not None and request.affordance == "cup"
    assert request.expected_outcome == profile.analysis.expected_outcome
    (pose,) = request.poses  # pose 0 had no candidate: not put to the analyser
    assert (pose.pose_index, pose.probability, pose.half_extents) == (2, 0.2, (h * 1.2).tolist())
    assert [c.plan for c in pose.candidates] == [profile.plans.plans[1].name]
    assert len(pose.failed) == n_plans - 1 and all(c.score == -1.0 for c in pose.failed)
    (c,) = pose.candidates
    assert c.summary == result_summary(batch, n_plans + 1) and c.via_poses == trajectories[1][1][:, :3].tolist()


def test_a_liquid_holder_needs_a_basin_in_its_pose():
    """An upturned desk's knee hole keeps droplets (spheres on a flat board) walled on three sides, but seen from
    above it has no basin: water runs out of its open front. A cup needs one; a basket, which holds items, not."""
    h = [0.7, 0.36, 0.38]
    pour = _candidate("above", [0.0, 0.0, 0.45])
    no_basin = PoseCandidates(pose_index=0, probability=1.0, half_extents=[0.05, 0.04, 0.05], candidates=[pour])
    cup = analyze_functional_poses(FunctionalPoseRequest(affordance="cup", expected_outcome="held", poses=[no_basin]))
    assert cup.best_pose is None and "no basin" in cup.poses[0].reason
    basket = analyze_functional_poses(FunctionalPoseRequest(affordance="basket", expected_outcome="held", poses=[
        PoseCandidates(pose_index=0, probability=1.0, half_extents=[0.15, 0.1, 0.08], candidates=[pour])]))
    assert basket.best_pose == 0
    desk = PoseCandidates(pose_index=0, probability=1.0, half_extents=h, candidates=[pour])
    tub = analyze_functional_poses(FunctionalPoseRequest(affordance="bathtub", expected_outcome="held", poses=[desk]))
    assert tub.best_pose is None and "no basin" in tub.poses[0].reason


def test_a_bowl_on_its_side_holds_a_puddle_not_a_cup_of_water():
    """A 12 cm bowl tipped on its side keeps droplets in the curve of its wall, a basin 2 cm deep at the bottom of
    a 12 cm pose; upright a cup's water stands up to its rim."""
    pour = _candidate("above", [0.0, 0.0, 0.2])
    side = PoseCandidates(pose_index=0, probability=0.6, half_extents=[0.062, 0.06, 0.06],
                          basin=BasinInfo(rim=0.02, opening=[0.0, 0.0], length=0.05), candidates=[pour])
    upright = PoseCandidates(pose_index=1, probability=0.4, half_extents=[0.045, 0.045, 0.05],
                             basin=BasinInfo(rim=0.1, opening=[0.0, 0.0], length=0.08), candidates=[pour])
    verdict = analyze_functional_poses(FunctionalPoseRequest(affordance="cup", expected_outcome="held",
                                                             poses=[side, upright]))
    assert [v.accept for v in verdict.poses] == [False, True] and "puddle" in verdict.poses[0].reason
