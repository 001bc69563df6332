"""Containers and dishes on the shapes real meshes have (issue 13): a cavity, not a top, holds droplets; a rim,
not a flat top, holds food. Each rule that rejects names its reason in ``analyzer_reasons``."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rail_mj.affordances import get
from rail_mj.affordances.kinds import kind_of
from rail_mj.affordances.kinds.container import MIN_DEPTH
from rail_mj.core.profile import CandidateInteraction, ResultSummary
from rail_mj.core.results import BasinInfo
from rail_mj.dataset import shapes
from rail_mj.dataset.shapes import parts as shape_parts
from rail_mj.imagination.inputs import trajectory_array
from rail_mj.llm import generate_profile
from rail_mj.mesh import object_from_mesh
from rail_mj.pipeline.chain import Pipeline
from rail_mj.pipeline.config import RunConfig
from rail_mj.stable_poses import StablePoseConfig, pose_from_up

pytestmark = pytest.mark.usefixtures("shared_cache")


def _candidate(plan: str, mean_height: float, *, inside: float = 1.0, z0: float = 1.2) -> CandidateInteraction:
    return CandidateInteraction(
        plan=plan, description="", via_poses=[[0.0, 0.0, z0], [0.0, 0.0, z0 - 0.1]], score=0.5,
        summary=ResultSummary(frac_inside_bbox=inside, frac_on_ground=0.0, frac_touching_object=1.0,
                              mean_height=mean_height, object_tilt_deg=0.0, agent_tilt_deg=0.0, agent_speed=0.0))


@pytest.mark.parametrize("name", ["basket", "bathtub", "bowl", "cup"])
def test_droplets_just_under_the_top_are_not_in_a_cavity(name: str) -> None:
    """A closed box whose decomposed top is grooved holds droplets just under its top: rejected, with why."""
    aff = get(name)
    h = [0.5, 0.5, 0.5]
    shallow = 1.0 - 2.0 * MIN_DEPTH + 0.1  # the droplets' mean centre a little less than MIN_DEPTH below the rim
    ok, why = kind_of(aff).accept(aff, _candidate("above", shallow), h)
    assert not ok and "below the rim" in why and "cavity" in why
    ok, why = kind_of(aff).accept(aff, _candidate("above", -0.6), h)
    assert ok and "80% of the height below the rim" in why


def _block_with_pocket(size: tuple[float, float, float], depth: float, wall: float) -> trimesh.Trimesh:
    """A closed block with a shallow pocket in its top (what CoACD makes of a grooved top)."""
    lx, ly, lz = size
    block = trimesh.creation.box(extents=size)
    pocket = trimesh.creation.box(extents=(lx - 2 * wall, ly - 2 * wall, 2 * depth))
    pocket.apply_translation((0.0, 0.0, lz / 2))
    return shape_parts._difference(block, pocket)


def _verdict(mesh: trimesh.Trimesh, name: str, affordance: str):
    obj = object_from_mesh(mesh, name=name)
    pipe = Pipeline(RunConfig(provider="offline", stable_poses=StablePoseConfig(n_drops=16)))
    return pipe.run(obj, pipe.stable_poses(obj), affordance)


def test_a_closed_box_with_a_shallow_pocket_on_top_is_not_a_basket() -> None:
    r = _verdict(_block_with_pocket((0.4, 0.34, 0.2), depth=0.04, wall=0.02), "pocket_box", "basket")
    assert not r.functional, r.analyzer_reasons
    assert any("cavity" in reason for reason in r.analyzer_reasons)


def test_a_closed_flat_box_is_not_a_plate_but_a_rimmed_plate_is() -> None:
    box = trimesh.creation.box(extents=(0.22, 0.2, 0.025))
    r = _verdict(box, "flat_box", "plate")
    assert not r.functional, r.analyzer_reasons
    assert any("not below a rim" in reason for reason in r.analyzer_reasons)
    plate = shapes.GENERATORS["plate"](np.random.default_rng(3)).mesh
    r = _verdict(plate, "plate", "plate")
    assert r.functional, r.analyzer_reasons


def test_an_upturned_table_is_not_a_bathtub_but_a_bathtub_is() -> None:
    """Droplets on an upturned table's top lie deep below its leg tips, but open between its legs: the enclosure
    probe's rays leave over a wide sector, so it is no cavity."""
    top = trimesh.creation.box(extents=(1.6, 0.8, 0.04))
    top.apply_translation((0.0, 0.0, 0.02))
    legs = []
    for x in (-0.74, 0.74):
        for y in (-0.34, 0.34):
            leg = trimesh.creation.box(extents=(0.05, 0.05, 0.56))
            leg.apply_translation((x, y, 0.04 + 0.28 - 0.005))
            legs.append(leg)
    r = _verdict(shape_parts._union([top, *legs]), "upturned_table", "bathtub")
    assert not r.functional, r.analyzer_reasons
    assert any("no enclosing cavity" in reason for reason in r.analyzer_reasons)
    r = _verdict(shapes.GENERATORS["bathtub"](np.random.default_rng(0)).mesh, "bathtub", "bathtub")
    assert r.functional, r.analyzer_reasons


def test_the_enclosure_probe_counts_the_widest_free_sector_round_the_circle() -> None:
    from rail_mj.imagination.batch import _longest_run

    free = np.zeros((3, 16), dtype=bool)
    free[1, [15, 0, 1, 2]] = True  # a sector across direction 0 counts whole
    free[2] = True
    assert _longest_run(free).tolist() == [0, 4, 16]


def test_a_vessels_spill_level_is_its_rim_not_its_rising_handle() -> None:
    """A saucepan's handle rises 4 cm above its rim; water spills at the rim. A closed box has no basin."""
    pan = object_from_mesh(shapes.GENERATORS["saucepan"](np.random.default_rng(1)).mesh, name="saucepan")
    pose = pose_from_up(pan, np.array([0.0, 0.0, 1.0]), 1.0)
    assert 2 * pose.half_extents[2] > 0.115 and pose.basin.rim == pytest.approx(0.088, abs=0.004)
    box = object_from_mesh(trimesh.creation.box(extents=(0.2, 0.15, 0.1)), name="box")
    assert pose_from_up(box, np.array([0.0, 0.0, 1.0]), 1.0).basin is None


def test_pours_aim_at_a_saucepans_pan_not_at_its_box_centre_over_the_handle():
    """The pan's box reaches along the handle, so its centre lies near the rim by the handle; the basin map finds
    the pan's middle, and the container's pours start over it, by the offset, in every plan."""
    built = shapes.GENERATORS["saucepan"](np.random.default_rng(1))
    pan = object_from_mesh(built.mesh, name="saucepan")
    pose = pose_from_up(pan, np.array([0.0, 0.0, 1.0]), 1.0)
    body = built.mesh.vertices[built.mesh.vertices[:, 2] < 0.02]  # the base: the pan's footprint, no handle
    middle = (body.min(axis=0) + body.max(axis=0))[:2] / 2 - (pan.mesh.bounds.sum(axis=0) / 2)[:2]
    assert np.linalg.norm(middle) > 0.05  # the box centre is far off the pan's middle
    # the pose's yaw may turn the handle to -x or +x: compare lengths and the direction along x
    assert abs(abs(pose.basin.opening[0]) - np.linalg.norm(middle)) < 0.01 and abs(pose.basin.opening[1]) < 0.01
    profile = generate_profile("bowl", [float(v) for v in pan.obb_dims])
    at_box = trajectory_array(profile.trajectories.trajectories, pose.half_extents)
    at_opening = trajectory_array(profile.trajectories.trajectories, pose.half_extents, pose.basin)
    for a, b in zip(at_box, at_opening):
        assert np.allclose(b[:, :2] - a[:, :2], pose.basin.opening) and np.allclose(b[:, 2], a[:, 2])


def test_a_bowls_proportions_are_its_rims_a_deep_pot_stays_no_bowl() -> None:
    """Height/width at most 0.55 for a bowl: the saucepan's box says 0.64, its rim 0.47; a deep pot's rim 0.74."""
    bowl = get("bowl")
    pan = [0.17, 0.093, 0.06]
    assert not bowl.pose_fits(pan)[0] and bowl.pose_fits(pan, rim=0.088)[0]
    pot = [0.17, 0.0865, 0.07]
    fits, why = bowl.pose_fits(pot, rim=0.128)
    assert not fits and "height/width is 0.740" in why and bowl.pose_prior(pot, rim=0.128).value < 0.5
    kind = kind_of(bowl)
    source = kind.scoring(bowl, kind.agent(bowl, [0.34, 0.186, 0.12])).source
    assert "e[:, 2]" not in source  # the proportions are the bowl's prior, not its scoring's


def test_a_cups_depth_is_its_rims_a_scoops_rising_handle_makes_it_no_deeper() -> None:
    """A 13.3 cm scoop's handle raises its box to 0.65 of its width, a cup's proportions; its rim stands at 0.44 of
    it, a dipper's: no cup. A mug's rim is its top, and its proportions stay a cup's."""
    cup = get("cup")
    scoop = [0.121, 0.0665, 0.0434]
    assert cup.pose_prior(scoop).value >= 0.5
    assert cup.pose_prior(scoop, rim=0.059).value < 0.5
    mug = [0.06, 0.043, 0.05]
    assert cup.pose_prior(mug, rim=0.1).value == 1.0


def _wine_glass() -> trimesh.Trimesh:
    """A 20 cm wine glass: a 12 cm bowl (rim 7 cm, 8.6 cm at its widest) on an 8 cm stem and a 7 cm foot."""
    from scipy.interpolate import PchipInterpolator

    top, base = 0.2, 0.088  # the bowl's outside starts on the stem 8.8 cm up; its inside floor is 9.4 cm up
    r_of = PchipInterpolator([base, base + 0.017, base + 0.062, top], [0.006, 0.026, 0.043, 0.035])
    outer = [(float(r_of(z)), float(z)) for z in np.linspace(base, top, 16)]
    inner = [(max(float(r_of(z)) - 0.0025, 0.002), float(z)) for z in np.linspace(top, base + 0.006, 16)]
    foot = [(0.0, 0.0), (0.035, 0.0), (0.035, 0.004), (0.01, 0.008), (0.004, 0.016), (0.004, base - 0.004)]
    return trimesh.creation.revolve(np.array(foot + outer + inner + [(0.0, base + 0.006)]), sections=48)


def test_a_wine_glass_is_a_cup_by_its_bowl_not_its_bowl_on_a_stem() -> None:
    """Its box is 20 cm tall, past a cup's 16 cm (prior 0.02); its basin's floor stands 9.4 cm up, and without the
    stem under it (all but a heavy tumbler's 3 cm base) it is a 14 cm cup. A table is weighed whole: its top is no
    vessel's floor on a stem."""
    cup, table = get("cup"), get("table")
    glass = [0.043, 0.043, 0.1]
    assert cup.pose_prior(glass, rim=0.2).value < 0.05
    assert cup.pose_prior(glass, rim=0.2, floor=0.094).value == 1.0
    assert table.pose_prior([0.6, 0.4, 0.38], floor=0.74).value == table.pose_prior([0.6, 0.4, 0.38]).value
    r = _verdict(_wine_glass(), "wine_glass", "cup")
    assert r.functional and r.probability > 0.9, (r.prior, r.analyzer_reasons)
    upright = r.stable_poses[r.functional_pose.index] if r.functional_pose is not None else None
    assert upright is not None and upright.basin is not None and upright.basin.floor == pytest.approx(0.094, abs=0.01)


def test_a_scoop_whose_handle_rises_above_its_rim_is_a_bowl() -> None:
    """Its handle makes the box 0.82 as high as wide; its rim is 0.47 of its width."""
    r = _verdict(shapes.GENERATORS["scoop"](np.random.default_rng(1)).mesh, "scoop", "bowl")
    assert r.functional, r.analyzer_reasons
    assert r.functional_pose is not None and r.functional_pose.up_in_mesh_frame[2] > 0.95


def _probe(mesh: trimesh.Trimesh, hulls: list[np.ndarray], at: list[float]) -> tuple[int, int]:
    """The enclosure probe's widest free sector for one droplet resting at ``at`` (mesh frame), cast against the
    mesh's surface and against ``hulls`` (what the probe casts against where MuJoCo refuses the mesh)."""
    from dataclasses import replace

    from rail_mj.core.types import AgentSetup, RailObject
    from rail_mj.imagination.batch import open_sectors
    from rail_mj.mjcf import compose_scene
    from rail_mj.mjcf.surface import static_meshes

    obj = RailObject(name="probe", mesh=mesh, hulls=tuple(hulls), mesh_hash="probe", obb_dims=mesh.extents,
                     com=np.zeros(3), mass=1.0, density=500.0)
    drop = '<mujoco><worldbody><body><geom type="sphere" size="0.01"/></body></worldbody></mujoco>'
    scene = compose_scene(obj, AgentSetup(fragment=drop, offsets=np.zeros((1, 3))))
    qpos = np.zeros((1, scene.model.nq))
    qpos[0, scene.object_qpos + 3] = 1.0
    a = int(scene.agent_qpos[0])
    qpos[0, a : a + 3], qpos[0, a + 3] = at, 1.0
    in_hulls = replace(scene, surface=static_meshes([(h, None) for h in hulls]))
    return int(open_sectors(scene, qpos)[0, 0]), int(open_sectors(in_hulls, qpos)[0, 0])


def test_the_enclosure_probe_meets_the_surface_not_hulls_that_fill_it_out() -> None:
    """An upturned desk's top with its two end panels, decomposed as CoACD may (one hull over top and panels):
    a droplet on the top is walled all round by that hull, but its front and back are open."""
    top = trimesh.creation.box(extents=(1.2, 0.6, 0.03))
    panels = [trimesh.creation.box(extents=(0.03, 0.6, 0.5)) for _ in range(2)]
    panels[0].apply_translation((-0.585, 0.0, 0.265))
    panels[1].apply_translation((0.585, 0.0, 0.265))
    desk = shape_parts._union([top, *panels])
    free, free_in_hulls = _probe(desk, [np.asarray(desk.convex_hull.vertices)], [0.0, 0.0, 0.03])
    assert free >= 4 and free_in_hulls == 0


def test_the_enclosure_probe_does_not_leave_through_a_baskets_slots() -> None:
    """Slats 2 cm wide with 1 cm slots between them, 12 cm round a droplet: every way meets a slat within the
    spread of a direction's rays, so the basket walls it in; with a quarter of its slats gone it lies open."""
    def ring(slats: int) -> trimesh.Trimesh:
        parts = [trimesh.creation.cylinder(radius=0.125, height=0.008)]
        n = 25  # 2 pi 0.12 / 3 cm
        for k in range(slats):
            slat = trimesh.creation.box(extents=(0.02, 0.006, 0.1))
            slat.apply_translation((0.0, 0.12, 0.05))
            slat.apply_transform(trimesh.transformations.rotation_matrix(2 * np.pi * k / n, (0, 0, 1)))
            parts.append(slat)
        return shape_parts._union(parts)

    basket = ring(25)
    assert _probe(basket, [np.asarray(basket.convex_hull.vertices)], [0.0, 0.0, 0.02])[0] < 4
    broken = ring(18)
    assert _probe(broken, [np.asarray(broken.convex_hull.vertices)], [0.0, 0.0, 0.02])[0] >= 4


def test_a_console_on_its_back_holds_water_in_compartments_too_short_for_a_bather() -> None:
    """On its back a TV console's open compartments face up and hold water, 0.5-0.9 m long each: no basin a person
    lies in. A bathtub's one basin is 1.3 m long; the analyser refuses the console's pose and keeps the tub's."""
    from rail_mj.core.profile import PoseCandidates
    from rail_mj.llm import FunctionalPoseRequest, analyze_functional_poses

    console = object_from_mesh(shapes.GENERATORS["console"](np.random.default_rng([9, 0])).mesh, name="console")
    lying = pose_from_up(console, np.array([0.0, -1.0, 0.0]), 1.0)  # its open front up
    tub = object_from_mesh(shapes.GENERATORS["bathtub"](np.random.default_rng(0)).mesh, name="bathtub")
    upright = pose_from_up(tub, np.array([0.0, 0.0, 1.0]), 1.0)
    assert lying.basin.length < 0.9 and upright.basin.length > 1.2
    poses = [PoseCandidates(pose_index=i, probability=0.5, half_extents=[float(v) for v in p.half_extents],
                            basin=BasinInfo.of(p.basin), candidates=[_candidate("above", -0.8)])
             for i, p in enumerate((lying, upright))]
    verdict = analyze_functional_poses(FunctionalPoseRequest(affordance="bathtub", expected_outcome="", poses=poses))
    assert [v.accept for v in verdict.poses] == [False, True] and "basin holds water" in verdict.poses[0].reason


def test_flower_stems_stand_in_a_vase_but_lie_across_a_goblets_bowl() -> None:
    """A goblet holds water, but its bowl is about as wide as it is deep: a stem on its floor leans on the rim
    some 40 deg from vertical, and it is no vase. A vase's narrow, deep body keeps the stem within 30 deg."""
    goblet = _verdict(shapes.GENERATORS["goblet"](np.random.default_rng(9)).mesh, "goblet", "vase")
    assert not goblet.functional and any("flower stem" in r for r in goblet.analyzer_reasons), goblet.analyzer_reasons
    vase = _verdict(shapes.GENERATORS["vase"](np.random.default_rng(3)).mesh, "vase", "vase")
    assert vase.functional, vase.analyzer_reasons
