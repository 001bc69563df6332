"""The articulated body the seat and lie kinds imagine with (issue 22, part 4).

The fast tests check the fragment (Winter's anthropometry, a valid agent) and the scene's bookkeeping of an
articulated agent. The physics tests lower the body onto small objects built from boxes in their upright pose,
through the offline profile (stages 1-6), the native imagination and the kind's stage-7 rules; each would fail
with the box "pelvis" the kinds had before (it has no segments to report and no legs to reach the floor).
"""

from __future__ import annotations

import dataclasses
from typing import cast

import mujoco
import numpy as np
import pytest
import trimesh

from rail_mj.affordances import get
from rail_mj.affordances.kinds import kind_of
from rail_mj.affordances.kinds.body import HEADINGS, heading_axes, leans_back
from rail_mj.affordances.prior import FUNCTIONAL, NEGLIGIBLE
from rail_mj.core.errors import FragmentError, ImaginationError
from rail_mj.core.geometry import quat_rotate
from rail_mj.core.profile import CandidateInteraction, PoseCandidates
from rail_mj.core.types import AgentSetup, RailObject
from rail_mj.imagination import ImaginationConfig, draw_perturbations, imagine, prepare
from rail_mj.imagination.batch import outcomes_from_states
from rail_mj.imagination.inputs import agent_setup, trajectory_array
from rail_mj.imagination.perturb import Perturbation, world_model
from rail_mj.imagination.summary import result_summary
from rail_mj.imagination.worlds import ImaginedWorlds, world_outcomes
from rail_mj.llm import generate_profile
from rail_mj.mjcf import check_fragment, compose_scene, segment_state
from rail_mj.mjcf.body import SEGMENTS, body_fragment, body_size
from rail_mj.pipeline.verdicts import judge
from rail_mj.scoring import compile_scoring
from rail_mj.stable_poses import pose_from_up

DROPLET = ('<mujoco><worldbody><body name="drop"><geom type="sphere" size="0.006" mass="0.001"/></body>'
           '</worldbody></mujoco>')


def _object(name: str, boxes: list[tuple[list[float], list[float]]], density: float = 500.0,
            hulls: tuple[np.ndarray, ...] = ()) -> RailObject:
    """An object of axis-aligned ``boxes`` and other convex ``hulls`` (vertices)."""
    hulls = (*(np.asarray(trimesh.creation.box(bounds=[lo, hi]).vertices) for lo, hi in boxes), *hulls)
    mesh = cast(trimesh.Trimesh, trimesh.util.concatenate([trimesh.convex.convex_hull(h) for h in hulls]))
    return RailObject(name=name, mesh=mesh, hulls=tuple(np.asarray(h) for h in hulls), mesh_hash=f"test-{name}",
                      obb_dims=np.sort(mesh.extents)[::-1], com=mesh.center_mass, mass=float(mesh.volume * density),
                      density=density)


def _legs(x: float, y: float, top: float, t: float = 0.02) -> list[tuple[list[float], list[float]]]:
    return [([sx * x - t, sy * y - t, 0.0], [sx * x + t, sy * y + t, top]) for sx in (-1, 1) for sy in (-1, 1)]


def _chair(seat: float = 0.45) -> RailObject:
    """A plain chair: a 0.45 x 0.45 m seat ``seat`` m high on four legs, a 0.4 m back at -x."""
    return _object(f"chair{seat}", [([-0.225, -0.225, seat - 0.03], [0.225, 0.225, seat]),
                                    ([-0.225, -0.225, seat], [-0.195, 0.225, seat + 0.4]),
                                    *_legs(0.2, 0.2, seat - 0.03)])


def _chair_reaching_behind() -> RailObject:
    """A chair like FurnitureBench's: a seat 0.35 m deep before its back, 0.45 m up, and rear legs splayed 0.3 m
    behind the back: the box's centre lies 2.5 cm before the back's face."""
    return _object("chair_behind", [([-0.225, -0.225, 0.42], [0.155, 0.225, 0.45]),
                                    ([-0.225, -0.225, 0.45], [-0.195, 0.225, 0.85]),
                                    *[([sx - 0.02, sy * 0.2 - 0.02, 0.0], [sx + 0.02, sy * 0.2 + 0.02, 0.42])
                                      for sx in (-0.2, 0.13) for sy in (-1, 1)],
                                    *[([-0.495, sy * 0.2 - 0.02, 0.0], [-0.2, sy * 0.2 + 0.02, 0.04])
                                      for sy in (-1, 1)]])


def test_the_body_sits_a_quarter_forward_in_a_chair_whose_legs_reach_behind_its_back():
    """Put down over the box's centre, the buttocks land on the back and the body is pushed off the seat (the
    pelvis does not rest on it); a quarter of the way to the front it sits."""
    sat = [c.plan for c, ok, _ in _judged(_chair_reaching_behind(), "chair") if ok]
    assert any(plan.endswith("_front") for plan in sat), sat


def _stool() -> RailObject:
    """A backless stool, a 0.35 m square seat 0.46 m high."""
    return _object("stool", [([-0.175, -0.175, 0.43], [0.175, 0.175, 0.46]), *_legs(0.15, 0.15, 0.43)])


def _bed(top: float = 0.5) -> RailObject:
    """A bed: a 2.0 x 1.4 m mattress 0.2 m thick, its top ``top`` m up, on a base."""
    return _object(f"bed{top}", [([-1.0, -0.7, top - 0.2], [1.0, 0.7, top]),
                                 ([-0.95, -0.65, 0.0], [0.95, 0.65, top - 0.2])])


def _bathtub() -> RailObject:
    """A bathtub 1.7 x 0.8 x 0.55 m, walls and floor 5 cm thick."""
    L, W, H, t = 0.85, 0.4, 0.55, 0.05
    return _object("bathtub", [([-L, -W, 0.0], [L, W, t]), ([-L, -W, 0.0], [-L + t, W, H]),
                               ([L - t, -W, 0.0], [L, W, H]), ([-L, -W, 0.0], [L, -W + t, H]),
                               ([-L, W - t, 0.0], [L, W, H])])


def _imagined(obj: RailObject, affordance: str):
    """``affordance``'s offline profile, ``obj``'s upright pose, and every plan imagined on it."""
    pose = pose_from_up(obj, np.array([0.0, 0.0, 1.0]), 1.0)
    h = [float(v) for v in pose.half_extents]
    profile = generate_profile(affordance, obj.obb_dims)
    out = imagine(obj, [pose], agent_setup(profile.agent.mjcf, profile.layout),
                  trajectory_array(profile.trajectories.trajectories, h), backend="native")
    return profile, pose, out


def _judged(obj: RailObject, affordance: str) -> list[tuple[CandidateInteraction, bool, str]]:
    """Every plan of ``affordance``'s offline profile imagined on ``obj`` standing upright, with stage 7's verdict
    on it by the kind's rules."""
    profile, pose, out = _imagined(obj, affordance)
    h = [float(v) for v in pose.half_extents]
    aff = get(affordance)
    kind = kind_of(aff)
    judged = []
    for b, plan in enumerate(profile.plans.plans):
        c = CandidateInteraction(plan=plan.name, description=plan.description, via_poses=[[0.0, 0.0, 0.0]],
                                 score=0.5, summary=result_summary(out, b))
        judged.append((c, *kind.judge(aff, c, h)))
    return judged


def test_the_body_has_winters_segment_masses_and_a_dolls_scale():
    model = check_fragment(body_fragment("sit")).compile()
    assert model.body_mass[1:].sum() == pytest.approx(75.0)
    names = [model.body(i).name for i in range(1, model.nbody)]
    assert sorted(names) == sorted(SEGMENTS)
    thigh = model.body_mass[names.index("thigh_l") + 1]
    assert thigh == pytest.approx(0.100 * 75.0)  # Winter Table 4.1: a thigh is a tenth of the body
    assert model.njnt == 5  # lumbar, two hips, two knees: hinges
    doll = body_size(0.18)
    assert doll.stature == pytest.approx(0.18 * 1.75) and doll.mass == pytest.approx(75.0 * 0.18**3)
    assert check_fragment(body_fragment("lie", 0.18)).compile().body_mass[1:].sum() == pytest.approx(doll.mass)


def test_fragments_may_have_hinges_in_nested_bodies_only():
    nested = ('<mujoco><worldbody><body><geom size="0.01"/><body pos="0 0 0.05"><joint type="slide"/>'
              '<geom size="0.01"/></body></body></worldbody></mujoco>')
    with pytest.raises(FragmentError, match="type 'slide' is not allowed"):
        check_fragment(nested)
    check_fragment(nested.replace('type="slide"', 'type="hinge" axis="0 1 0"'))


def test_every_segment_is_the_agents_and_one_body_agents_are_unchanged():
    obj = _stool()
    body = compose_scene(obj, AgentSetup(fragment=body_fragment("sit"), offsets=np.zeros((1, 3))))
    assert body.articulated and len(body.hinge_dofs) == 5 and body.segment_names[0] == "pelvis"
    agent_geoms = np.nonzero(body.geom_owner == 0)[0]
    assert len(agent_geoms) == len(SEGMENTS)
    # a hinge turning fast enough keeps the world from resting, though every free body is still
    qpos, qvel = body.model.qpos0.copy(), np.zeros(body.model.nv)
    assert body.at_rest(qpos, qvel, 0.05)
    qvel[body.hinge_dofs[0]] = 1.0
    assert not body.at_rest(qpos, qvel, 0.05)
    drops = compose_scene(obj, AgentSetup(fragment=DROPLET, offsets=np.zeros((2, 3))))
    assert not drops.articulated and drops.agent_bodies.shape == (2, 1)


def test_the_body_sits_upright_in_a_plain_chair_and_on_a_stool():
    for obj, name in ((_chair(), "chair"), (_stool(), "stool")):
        sat = [(c, why) for c, ok, why in _judged(obj, name) if ok]
        assert sat, f"the body sits nowhere on the {obj.name}"
        for c, _ in sat:
            seg = {s.name: s for s in c.summary.segments}
            assert seg["torso"].up > np.cos(np.radians(45)) and abs(seg["thigh_l"].up) < 0.5
            assert seg["pelvis"].touching_object and not seg["pelvis"].on_ground
    # in the chair, sitting back, the torso leans on its back
    assert any(c.plan.endswith("_back") and {s.name: s for s in c.summary.segments}["torso"].touching_object
               for c, ok, _ in _judged(_chair(), "chair") if ok)


def _bar_stool(footrest: str = "rungs") -> RailObject:
    """A bar stool: a 0.4 m square seat 0.72 m high on four legs; ``footrest``: "rungs" between the legs 0.27 m up (a
    footrest 0.45 m under the seat, as a counter stool's is: below the soles of a sitter with knees at 90°), "none",
    or a "panel" closing each side from 0.1 m to 0.6 m up (vertical faces a foot slides down)."""
    if footrest == "rungs":
        parts = [([-0.2, sy * 0.18 - 0.01, 0.25], [0.2, sy * 0.18 + 0.01, 0.27]) for sy in (-1, 1)]
        parts += [([sx * 0.18 - 0.01, -0.2, 0.25], [sx * 0.18 + 0.01, 0.2, 0.27]) for sx in (-1, 1)]
    elif footrest == "panel":
        parts = [([-0.2, sy * 0.18 - 0.01, 0.1], [0.2, sy * 0.18 + 0.01, 0.6]) for sy in (-1, 1)]
        parts += [([sx * 0.18 - 0.01, -0.2, 0.1], [sx * 0.18 + 0.01, 0.2, 0.6]) for sx in (-1, 1)]
    else:
        parts = []
    return _object(f"bar_stool_{footrest}", [([-0.2, -0.2, 0.69], [0.2, 0.2, 0.72]), *_legs(0.18, 0.18, 0.69),
                                             *parts])


def test_the_body_sits_on_a_bar_stool_its_feet_reaching_the_rung_and_not_without_one():
    """The feet hang 0.35 m up, above and ahead of the rungs; bent on at the knee, they rest on one. Without rungs,
    or with only vertical panels below the seat, the same seat is too high for the feet (a sitter's toes reach the
    floor from 0.17 m)."""
    sat = [c for c, ok, _ in _judged(_bar_stool(), "stool") if ok]
    assert sat, "the body sits nowhere on the bar stool"
    for c in sat:
        seg = {s.name: s for s in c.summary.segments}
        assert not seg["foot_l"].on_ground and seg["foot_l"].height > 0.3
        assert seg["foot_l"].reaches_object or seg["foot_r"].reaches_object
    for footrest in ("none", "panel"):
        judged = _judged(_bar_stool(footrest), "stool")
        assert not any(ok for _, ok, _ in judged), footrest
        assert sum("the feet hang" in why for _, _, why in judged) >= 4, footrest


def _tilted(lo: list[float], hi: list[float], deg: float, pivot: list[float]) -> np.ndarray:
    """The vertices of the box ``lo``-``hi`` turned back (its +x end up) by ``deg`` about a y axis through ``pivot``."""
    turn = trimesh.transformations.rotation_matrix(np.radians(-deg), [0.0, 1.0, 0.0], pivot)
    return trimesh.transform_points(trimesh.creation.box(bounds=[lo, hi]).vertices, turn)


def _easy_chair() -> RailObject:
    """An easy chair on a pedestal: a 0.5 m square seat 0.4 m high at its front edge, tilted back 8°, its back
    reclined 20° at -x, on a 0.76 m square plinth."""
    seat = _tilted([-0.25, -0.25, 0.35], [0.25, 0.25, 0.4], 8.0, [0.25, 0.0, 0.4])
    back = _tilted([-0.3, -0.25, 0.28], [-0.25, 0.25, 0.9], 20.0, [-0.27, 0.0, 0.3])
    return _object("easy_chair", [([-0.03, -0.03, 0.06], [0.03, 0.03, 0.3]), ([-0.38, -0.38, 0.0], [0.38, 0.38, 0.06])],
                   hulls=(seat, back))


def test_the_body_sits_in_a_low_chair_and_an_easy_chair():
    """A seat lower than the knees (0.36 m, a chair's typical lowest): the feet on the floor hold the knees above the
    hips, and the body sits with its thighs risen off the seat, the seat still under them; on a rail as high nothing
    is under them. An easy chair's seat tilts back: the body sits in it leaning on its back, its pelvis tilted back
    with the seat."""
    sat = [c for c, ok, _ in _judged(_chair(0.36), "chair") if ok]
    assert len(sat) >= 4, f"the body sits in {len(sat)} of the low chair's plans"
    assert any({s.name: s for s in c.summary.segments}["thigh_l"].reaches_object for c in sat)
    # a rail as high, 5 cm deep: nothing under the thighs
    rail = _object("rail", [([-0.3, -0.025, 0.33], [0.3, 0.025, 0.36]), ([-0.3, -0.025, 0.0], [-0.26, 0.025, 0.33]),
                            ([0.26, -0.025, 0.0], [0.3, 0.025, 0.33])])
    assert not any(ok for _, ok, _ in _judged(rail, "stool"))
    leaning = [c for c, ok, _ in _judged(_easy_chair(), "chair")
               if ok and {s.name: s for s in c.summary.segments}["torso"].touching_object]
    assert leaning, "the body does not sit leaning on the easy chair's back"
    pelvis = {s.name: s for s in leaning[0].summary.segments}["pelvis"]
    assert pelvis.up < np.cos(np.radians(10))  # tilted back with the seat, past an office seat's 10°


def _deep_armchair() -> RailObject:
    """An upholstered armchair of blocks, facing +x: 0.8 m deep and wide, its seat 0.43 m up and 0.6 m deep from the
    back's front face to its front edge, arms 0.65 m up, the back 0.2 m thick and 0.86 m up."""
    return _object("deep_armchair", [([-0.4, -0.3, 0.0], [0.4, 0.3, 0.43]), ([-0.4, -0.4, 0.0], [0.4, -0.3, 0.65]),
                                     ([-0.4, 0.3, 0.0], [0.4, 0.4, 0.65]), ([-0.4, -0.3, 0.43], [-0.2, 0.3, 0.86])])


def test_the_body_sits_in_a_deep_armchair_its_feet_put_down_ahead_of_the_knees():
    """With the knees at 90° the heels came down on the seat's front edge, 0.43 m ahead of the hips, and held the body
    up off the seat in every heading; a sitter's feet go down a little ahead of the knees, clear of it."""
    obj = _deep_armchair()
    pose = pose_from_up(obj, np.array([0.0, 0.0, 1.0]), 1.0)
    # the heading that faces the chair's front (its +x) in the upright pose's task frame
    front = quat_rotate(np.asarray(pose.quat), np.array([1.0, 0.0, 0.0]))[:2]
    facing = next(h for h, _ in HEADINGS if np.allclose(heading_axes(h)[0], front, atol=1e-6))
    sat = [c for c, ok, _ in _judged(obj, "chair") if ok]
    assert sat, "the body does not sit in the deep armchair"
    assert all(c.plan.startswith(f"facing_{facing}") for c in sat), [c.plan for c in sat]


def _lounge_chair() -> RailObject:
    """A lounge chair on a sled base, facing +x: a 0.55 m deep seat 0.36 m high at its front edge, tilted back 12°,
    its back 0.6 m long at 110° to the seat (32° from vertical)."""
    seat = _tilted([-0.275, -0.26, 0.31], [0.275, -0.26 + 0.52, 0.36], 12.0, [0.275, 0.0, 0.36])
    back = _tilted([-0.30, -0.26, 0.22], [-0.26, 0.26, 0.82], 32.0, [-0.28, 0.0, 0.24])
    return _object("lounge_chair", [([-0.62, -0.26, 0.0], [0.27, 0.26, 0.03]), ([-0.25, -0.2, 0.03], [0.2, 0.2, 0.2])],
                   hulls=(seat, back))


def test_the_body_sits_in_a_lounge_chair_reclined_on_its_back():
    """A lounge chair's seat reclines and its back leans far back: the sitter's trunk reclines onto the back (the
    hips open within Keegan's 135°), its pelvis rolls back past the seat, and its hips sink below the seat's front
    edge, where the seat's height is read. Before, the torso hovering over the back counted as no back (the pelvis
    then had to be level within 15°), a torso reclined past 45° as lying, and the hips' height as the seat's."""
    obj = _lounge_chair()
    pose = pose_from_up(obj, np.array([0.0, 0.0, 1.0]), 1.0)
    front = quat_rotate(np.asarray(pose.quat), np.array([1.0, 0.0, 0.0]))[:2]
    facing = next(h for h, _ in HEADINGS if np.allclose(heading_axes(h)[0], front, atol=1e-6))
    aff, h = get("chair"), [float(v) for v in pose.half_extents]
    sat = [c for c, ok, _ in _judged(obj, "chair") if ok and c.plan.startswith(f"facing_{facing}")]
    assert sat, "the body does not sit facing the lounge chair's front"
    for c in sat:
        seg = {s.name: s for s in c.summary.segments}
        assert leans_back(seg)
        assert seg["pelvis"].height - body_size().thigh_radius < 0.36 <= kind_of(aff).rest_height(aff, c, h)
    # with nothing behind it a sitter's trunk finds no back: on a stool it reaches none
    for c, _, _ in _judged(_stool(), "stool"):
        assert not {s.name: s for s in c.summary.segments}["torso"].reaches_object


def test_the_body_does_not_sit_on_a_seat_1_2_m_up():
    judged = _judged(_chair(1.2), "chair")
    assert not any(ok for _, ok, _ in judged)
    assert any("the seat is" in why or "the feet hang" in why for _, _, why in judged)


def _upturned_stool() -> RailObject:
    """A stool upside down: its 0.35 m square seat on the floor, four 4 cm legs rising 0.43 m, their ends 0.3 m apart
    (the legs of the stool of _stool, seen from above)."""
    return _object("upturned_stool", [([-0.175, -0.175, 0.0], [0.175, 0.175, 0.03]),
                                      *[([lo[0], lo[1], 0.03], [hi[0], hi[1], 0.46]) for lo, hi in
                                        _legs(0.15, 0.15, 0.43)]])


def test_the_body_does_not_sit_on_an_upturned_stools_leg_ends():
    # the pelvis rests on the four leg ends with the thighs over two of them; nothing bears the sitting bones
    judged = _judged(_upturned_stool(), "chair")
    assert not any(ok for _, ok, _ in judged), [why for _, ok, why in judged if ok]
    assert any("sitting bones" in why for _, _, why in judged)


def _railed(bridged: bool) -> RailObject:
    """Two 4 cm rails 0.39 m apart, 0.46 m up on four legs (a chair's legs, the chair on its side), and a slab
    between them at their height: in the hulls only (a convex hull spanning the gap, the mesh without it) when
    ``bridged``, else in the mesh too (a seat)."""
    rails = [([-0.225, sy * 0.195 - 0.02, 0.42], [0.225, sy * 0.195 + 0.02, 0.46]) for sy in (-1, 1)]
    obj = _object("railed", [*rails, ([-0.225, -0.175, 0.43], [0.225, 0.175, 0.46]), *_legs(0.2, 0.195, 0.42)])
    if not bridged:
        return obj
    parts = [trimesh.creation.box(bounds=[lo, hi]) for lo, hi in [*rails, *_legs(0.2, 0.195, 0.42)]]
    return dataclasses.replace(obj, mesh=cast(trimesh.Trimesh, trimesh.util.concatenate(parts)))


def test_the_sitting_bones_are_borne_by_the_objects_own_surface_not_a_hull_spanning_a_gap():
    seat = _judged(_railed(bridged=False), "chair")
    assert any(ok for _, ok, _ in seat), [why for _, _, why in seat]
    bridged = _judged(_railed(bridged=True), "chair")
    assert not any(ok for _, ok, _ in bridged), [why for _, ok, why in bridged if ok]
    assert any("sitting bones" in why for _, _, why in bridged)


def _slotted() -> RailObject:
    """A stool's whole 0.45 m square seat 0.46 m up, whose hulls leave an 18 cm slot under the sitting bones (two
    halves, as a decomposition may leave a shell's middle uncovered)."""
    halves = [([-0.225, -0.225, 0.43], [0.225, -0.09, 0.46]), ([-0.225, 0.09, 0.43], [0.225, 0.225, 0.46])]
    obj = _object("slotted", [*halves, *_legs(0.2, 0.2, 0.43)])
    parts = [trimesh.creation.box(bounds=[lo, hi]) for lo, hi in [([-0.225, -0.225, 0.43], [0.225, 0.225, 0.46]),
                                                                 *_legs(0.2, 0.2, 0.43)]]
    return dataclasses.replace(obj, mesh=cast(trimesh.Trimesh, trimesh.util.concatenate(parts)))


def test_the_objects_own_surface_bears_the_sitting_bones_where_its_hulls_leave_a_slot():
    # facing across the slot the bones lie over it and only the mesh bears them
    judged = _judged(_slotted(), "chair")
    assert sum(ok for _, ok, _ in judged) >= 4, [why for _, _, why in judged]


def test_the_body_lies_in_a_bed_and_a_bathtub_holds_it_lying_down():
    assert any(ok for _, ok, _ in _judged(_bed(), "bed"))
    # a bathtub is no bed (its floor is below a bed's height), but it holds the body lying on its back, inside
    held = 0
    for c, _, _ in _judged(_bathtub(), "bed"):
        seg = {s.name: s for s in c.summary.segments}
        lying = all(abs(seg[n].up) < np.sin(np.radians(45)) for n in ("torso", "thigh_l", "thigh_r"))
        inside = seg["pelvis"].height < 0.55 and seg["torso"].height < 0.55  # below the rim, its legs as they fall
        carried = not any(s.on_ground for s in seg.values()) and seg["torso"].touching_object
        held += lying and inside and carried and c.summary.object_tilt_deg < 15
    assert held


def test_a_bed_higher_than_any_bed_is_weighed_by_its_rest_prior_not_vetoed():
    """The bed row's typical rest is 0.15-0.9 m; a mattress 1 m up is unusual, not impossible: the body lies on it,
    the rules accept it, and the pose's prior carries the rest height's plausibility. Past the rules' limit
    (where that prior is negligible) the rules still refuse."""
    bed = get("bed")
    assert bed.rest_limits()[1] > 1.0 > bed.envelope.rest[1]
    profile, pose, out = _imagined(_bed(1.0), "bed")
    scores = compile_scoring(profile.scoring.source)(out)
    assert np.any(scores > 0), "the scoring refuses a rest height the rules let through"
    trajectories = [trajectory_array(profile.trajectories.trajectories, [float(v) for v in pose.half_extents])]
    evidence = ImaginedWorlds("bed", 1.0, profile.plans.plans, [pose], [0], [list(trajectories[0])])
    evidence.add_nominal(out, scores)
    v, = judge(evidence, _bed(1.0).obb_dims)
    assert v.physics == 1.0 and "rest height 1" in v.prior_factors
    assert v.prior == pytest.approx(bed.rest_prior(1.0).value, abs=0.05) and NEGLIGIBLE < v.prior < FUNCTIONAL
    high = _judged(_bed(1.6), "bed")
    assert not any(ok for _, ok, _ in high) and any("the hips rest" in why for _, _, why in high)


def test_mjx_refuses_the_body_and_names_the_native_backend():
    obj = _stool()
    pose = pose_from_up(obj, np.array([0.0, 0.0, 1.0]), 1.0)
    body = AgentSetup(fragment=body_fragment("sit"), offsets=np.zeros((1, 3)))
    with pytest.raises(ImaginationError, match="backend='native'"):
        imagine(obj, [pose], body, [np.array([[0.0, 0.0, 1.5, 1, 0, 0, 0]])], backend="mjx")


def test_a_perturbed_world_scales_the_whole_body_and_keeps_its_posture():
    """A world's agent size scales every segment and its place on its parent about the root (one body, not nine
    shrunk in place), its agent mass every segment's mass; the posture springs hold the same sag (stiffness x
    mass x length, damping ratio kept), and the world's segments are read in the world's own model."""
    scene = compose_scene(_stool(), AgentSetup(fragment=body_fragment("sit"), offsets=np.zeros((1, 3))))
    m = world_model(scene, Perturbation(agent_size=1.1, agent_mass=0.8))
    base = scene.model
    nominal, world = mujoco.MjData(base), mujoco.MjData(m)
    mujoco.mj_kinematics(base, nominal)
    mujoco.mj_kinematics(m, world)
    bodies = scene.agent_bodies[0]
    np.testing.assert_allclose(world.xpos[bodies] - world.xpos[bodies[0]],
                               1.1 * (nominal.xpos[bodies] - nominal.xpos[bodies[0]]), atol=1e-9)
    np.testing.assert_allclose(m.body_mass[bodies], 0.8 * base.body_mass[bodies])
    joints = m.dof_jntid[scene.hinge_dofs]
    np.testing.assert_allclose(m.jnt_stiffness[joints], 0.8 * 1.1 * base.jnt_stiffness[joints])
    np.testing.assert_allclose(m.dof_damping[scene.hinge_dofs], 0.8 * 1.1**1.5 * base.dof_damping[scene.hinge_dofs])
    none = np.zeros((0, 2), dtype=np.int64)
    h0, h1 = segment_state(scene, nominal, none)[0], segment_state(scene, world, none, m)[0]
    np.testing.assert_allclose(h1 - h1[:, :1], 1.1 * (h0 - h0[:, :1]), atol=1e-9)


def test_the_body_reports_its_segments_in_every_perturbed_world():
    obj = _stool()
    pose = pose_from_up(obj, np.array([0.0, 0.0, 1.0]), 1.0)
    h = [float(v) for v in pose.half_extents]
    profile = generate_profile("stool", obj.obb_dims)
    trajectories = trajectory_array(profile.trajectories.trajectories, h)
    worlds = draw_perturbations(ImaginationConfig(perturbations=2, seed=1))
    out = imagine(obj, [pose], agent_setup(profile.agent.mjcf, profile.layout), trajectories, backend="native",
                  perturbations=worlds)
    assert out.batch == 3 * len(trajectories)
    for world, _ in world_outcomes(out, np.zeros(out.batch), worlds.n_worlds):
        assert world.segment_names == SEGMENTS
        assert [s.name for s in result_summary(world, 0).segments] == list(SEGMENTS)


def test_a_body_that_blew_up_reports_finite_segments():
    obj = _stool()
    pose = pose_from_up(obj, np.array([0.0, 0.0, 1.0]), 1.0)
    body = AgentSetup(fragment=body_fragment("sit"), offsets=np.zeros((1, 3)))
    scene = compose_scene(obj, body)
    batch = prepare(obj, [pose], body, [np.array([[0.0, 0.0, 1.5, 1, 0, 0, 0]])] * 2, ImaginationConfig())
    qpos = batch.initial_qpos(scene)
    qpos[1, :3] = np.nan
    n, s = 2, len(SEGMENTS)
    segments = (np.full((n, 1, s), 0.4), np.full((n, 1, s), 0.9), np.ones((n, 1, s, 3), dtype=np.int64),
                np.ones((n, 1, s), dtype=bool))
    segments[0][1] = np.nan
    segments[1][1] = np.nan
    out = outcomes_from_states(scene, batch.placement, qpos, np.zeros((n, scene.model.nv)),
                               np.zeros((n, 1, 3), dtype=np.int64), np.zeros((n, 1), dtype=bool),
                               np.ones(n, dtype=bool), None, segments)
    assert out.unstable is not None and out.unstable.tolist() == [False, True]
    for name in ("segment_height", "segment_up", "segment_contacts", "segment_reach"):
        assert np.all(np.isfinite(getattr(out, name))), name
    blown = result_summary(out, 1).segments
    assert not any(x.touching_object or x.on_ground or x.reaches_object for x in blown)
    assert result_summary(out, 0).segments[0].height == pytest.approx(0.4)


def _bench() -> RailObject:
    """A backless bench for two: a 1.2 x 0.35 m seat 0.45 m high."""
    return _object("bench", [([-0.6, -0.175, 0.42], [0.6, 0.175, 0.45]), *_legs(0.55, 0.15, 0.42)])


def _bench_with_back(side: float) -> RailObject:
    """A bench for two with a 0.4 m back along its length, at +y (``side`` 1) or -y (-1): a settee's shape."""
    back = ([-0.6, 0.145, 0.45], [0.6, 0.175, 0.85]) if side > 0 else ([-0.6, -0.175, 0.45], [0.6, -0.145, 0.85])
    return _object(f"settee{side:+.0f}", [([-0.6, -0.175, 0.42], [0.6, 0.175, 0.45]), back,
                                          *_legs(0.55, 0.15, 0.42)])


def _seat_for_one(obj: RailObject, affordance: str) -> tuple[bool, str]:
    """A seat row's pose verdict on ``obj`` upright: its accepted plans after the kind's rules for the whole pose."""
    judged = _judged(obj, affordance)
    accepted = [c for c, ok, _ in judged if ok]
    aff = get(affordance)
    pose = PoseCandidates(pose_index=0, probability=1.0, half_extents=[0.3, 0.3, 0.3],
                          candidates=[c for c, _, _ in judged])
    kept, why = kind_of(aff).accept_pose(aff, accepted, pose)
    return bool(kept), why


def test_a_seat_for_one_has_no_room_for_a_second_sitter_beside_the_first():
    assert _seat_for_one(_chair(), "chair")[0] and _seat_for_one(_stool(), "stool")[0]
    for affordance in ("chair", "stool"):
        ok, why = _seat_for_one(_bench(), affordance)
        assert not ok and "room for a second sitter" in why


def test_a_settee_is_no_chair_whichever_side_its_back_is_on():
    # the body put down to either side faced one way only: a settee whose back was on that side refused it nowhere
    for side in (1.0, -1.0):
        ok, why = _seat_for_one(_bench_with_back(side), "chair")
        assert not ok and "room for a second sitter" in why, (side, why)


def _counter_bench() -> RailObject:
    """A bar-height bench for two: a 1.2 x 0.4 m seat 0.72 m high (the bar stool's), its footrest rungs 0.27 m up
    only under the middle 0.3 m of its length, on both long sides."""
    rungs = [([-0.15, sy * 0.18 - 0.01, 0.25], [0.15, sy * 0.18 + 0.01, 0.27]) for sy in (-1, 1)]
    return _object("counter_bench", [([-0.6, -0.2, 0.69], [0.6, 0.2, 0.72]), *_legs(0.55, 0.18, 0.69), *rungs])


def test_room_for_a_second_sitter_is_the_seats_the_feet_aside_find_their_own_rest():
    """In the middle the feet reach the rung and the body sits; one hip breadth to either side the feet hang past the
    rung's ends, but the seat carries the body there: a seat for two, whatever its footrest."""
    judged = {c.plan: (ok, why) for c, ok, why in _judged(_counter_bench(), "chair")}
    assert any(ok for plan, (ok, _) in judged.items() if "_aside" not in plan), judged
    assert all("the feet hang" in why for plan, (_, why) in judged.items() if "_aside" in plan), judged
    ok, why = _seat_for_one(_counter_bench(), "chair")
    assert not ok and "room for a second sitter" in why
