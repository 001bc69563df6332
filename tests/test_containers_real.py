"""Containers and dishes on the shapes real meshes have (issue 13): a cavity, not a top, holds droplets; a rim,
not a flat top, holds food. Each rule that rejects names its reason in ``analyzer_reasons``."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rail_mj import shapes
from rail_mj.affordances import get
from rail_mj.affordances.kinds import kind_of
from rail_mj.affordances.kinds.container import MIN_DEPTH
from rail_mj.llm.schemas import CandidateInteraction, ResultSummary
from rail_mj.objects import object_from_mesh
from rail_mj.pipeline import Pipeline, RunConfig
from rail_mj.stable_poses import pose_from_up


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


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
    return shapes._difference(block, pocket)


def _verdict(mesh: trimesh.Trimesh, name: str, affordance: str):
    obj = object_from_mesh(mesh, name=name)
    pipe = Pipeline(RunConfig(provider="offline", n_drops=16))
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
    plate = shapes.plate(np.random.default_rng(3)).mesh
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
    r = _verdict(shapes._union([top, *legs]), "upturned_table", "bathtub")
    assert not r.functional, r.analyzer_reasons
    assert any("no enclosing cavity" in reason for reason in r.analyzer_reasons)
    r = _verdict(shapes.bathtub(np.random.default_rng(0)).mesh, "bathtub", "bathtub")
    assert r.functional, r.analyzer_reasons


def test_the_enclosure_probe_counts_the_widest_free_sector_round_the_circle() -> None:
    from rail_mj.imagination.batch import _longest_run

    free = np.zeros((3, 16), dtype=bool)
    free[1, [15, 0, 1, 2]] = True  # a sector across direction 0 counts whole
    free[2] = True
    assert _longest_run(free).tolist() == [0, 4, 16]


def test_a_vessels_spill_level_is_its_rim_not_its_rising_handle() -> None:
    """A saucepan's handle rises 4 cm above its rim; water spills at the rim. A closed box has no basin."""
    pan = object_from_mesh(shapes.saucepan(np.random.default_rng(1)).mesh, name="saucepan")
    pose = pose_from_up(pan, np.array([0.0, 0.0, 1.0]), 1.0)
    assert 2 * pose.half_extents[2] > 0.115 and pose.rim == pytest.approx(0.088, abs=0.004)
    box = object_from_mesh(trimesh.creation.box(extents=(0.2, 0.15, 0.1)), name="box")
    assert pose_from_up(box, np.array([0.0, 0.0, 1.0]), 1.0).rim is None


def test_a_bowls_proportions_are_its_rims_a_deep_pot_stays_no_bowl() -> None:
    """Height/width at most 0.55 for a bowl: the saucepan's box says 0.64, its rim 0.47; a deep pot's rim 0.74."""
    bowl = get("bowl")
    pan = [0.17, 0.093, 0.06]
    assert not bowl.pose_fits(pan)[0] and bowl.pose_fits(pan, rim=0.088)[0]
    pot = [0.17, 0.0865, 0.07]
    fits, why = bowl.pose_fits(pot, rim=0.128)
    assert not fits and "height/width is 0.740" in why
    kind = kind_of(bowl)
    source = kind.scoring(bowl, kind.agent(bowl, [0.34, 0.186, 0.12])).source
    assert "e[:, 2] / np.maximum" not in source and "(2.0 * e[:, 2] <= 0.2)" in source


def test_a_scoop_whose_handle_rises_above_its_rim_is_a_bowl() -> None:
    """Its handle makes the box 0.82 as high as wide; its rim is 0.47 of its width."""
    r = _verdict(shapes.scoop(np.random.default_rng(1)).mesh, "scoop", "bowl")
    assert r.functional, r.analyzer_reasons
    assert r.functional_pose is not None and r.functional_pose.up_in_mesh_frame[2] > 0.95
