"""Size ranges and pose envelopes are priors (issue 22): continuous at a range's edge, never a veto of a size a
real object of the class can have; the physics decides, and the result's probability is prior x physics."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import trimesh

from rail_mj.affordances import REGISTRY, Envelope, get
from rail_mj.affordances.prior import FUNCTIONAL, NEGLIGIBLE, WIDTH_RANGE, plausibility
from rail_mj.core.errors import ConfigError
from rail_mj.core.types import Outcomes, RailObject
from rail_mj.llm import generate_profile
from rail_mj.mesh import mesh_hash
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.render.explain import explain
from rail_mj.robot.demo import make_object
from rail_mj.scoring import compile_scoring

#: Just inside and just outside a range's edge, as a fraction of the bound.
_EPS = 1e-4


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_every_prior_is_continuous_at_its_ranges_edges(name):
    row = get(name)
    for _, value, (lo, hi) in row.envelope.values([0.1, 0.2, 0.3]):
        for bound in (b for b in (lo, hi) if 0 < b < math.inf):
            inside = plausibility(bound, lo, hi)
            outside = [plausibility(bound * (1 + s * _EPS), lo, hi) for s in (-1, 1)]
            assert inside == 1.0 and min(outside) > 0.999, (name, value, bound)


@pytest.mark.parametrize("name", sorted(n for n in REGISTRY if get(n).envelope.rest[1] < math.inf))
def test_a_rest_height_is_a_prior_continuous_at_its_windows_edges_and_vetoed_only_where_negligible(name):
    row = get(name)
    (lo, hi), (low, high) = row.envelope.rest, row.rest_limits()
    assert low < lo and high > hi
    for bound in (lo, hi):
        near = [row.rest_prior(bound * (1 + s * _EPS)).value for s in (-1, 1)]
        assert min(near) > 0.999, (name, bound)
    for limit in (low, high):
        assert row.rest_prior(limit).value == pytest.approx(NEGLIGIBLE)


def test_the_dimension_check_has_no_step_at_a_ranges_edge():
    """A bowl 11.9 cm across against a typical 12.5 cm at least is nearly as plausible as a 12.5 cm one (stage 1
    said no), and the prior falls smoothly past the edge."""
    bowl = get("bowl")
    assert generate_profile("bowl", [0.119, 0.119, 0.05]).analysis.fits
    priors = [bowl.dims_prior([w, w, 0.05]).value for w in np.linspace(0.09, 0.13, 81)]
    assert max(abs(np.diff(priors))) < 0.05 and priors[-1] == 1.0 > priors[0] > 0.0  # a step would jump by 1


def _held(name: str, half: list[float]) -> float:
    """The score of 27 droplets resting inside a pose's box, below its rim, in the scoring source of ``name``."""
    profile = generate_profile(name, sorted((2 * v for v in half), reverse=True))
    pos = np.random.default_rng(0).uniform(-0.02, 0.02, (1, 27, 3))
    z = np.zeros((1, 27), dtype=np.int64)
    out = Outcomes(
        pose_index=np.zeros(1, dtype=np.int64), plan_index=np.zeros(1, dtype=np.int64), agent_pos=pos,
        agent_quat=np.tile([1.0, 0, 0, 0], (1, 27, 1)), agent_vel=np.zeros_like(pos), contacts_object=z + 1,
        contacts_agents=z, contacts_ground=z, released_early=z.astype(bool), object_pos=np.zeros((1, 3)),
        object_quat=np.array([[1.0, 0, 0, 0]]), object_tilt=np.zeros(1),
        object_half_extents=np.asarray(half, dtype=float)[None], settled=np.ones(1, dtype=bool),
    )
    return float(compile_scoring(profile.scoring.source)(out)[0])


def test_a_pose_just_past_the_envelope_scores_as_one_just_inside():
    """The scoring is the physics alone: droplets held in a 16.01 cm tall cup score as in a 15.99 cm one (the
    envelope used to mask the first to -1)."""
    past, inside = _held("cup", [0.04, 0.04, 0.08005]), _held("cup", [0.04, 0.04, 0.07995])
    assert past == pytest.approx(inside) and inside > 0


def _scaled(obj: RailObject, k: float) -> RailObject:
    mesh = obj.mesh.copy()
    mesh.apply_scale(k)
    return replace(obj, name=f"{obj.name}_x{k:g}", mesh=mesh, hulls=tuple(h * k for h in obj.hulls),
                   mesh_hash=mesh_hash(mesh), obb_dims=np.asarray(obj.obb_dims) * k, com=obj.com * k,
                   mass=obj.mass * k**3)


def test_a_cup_20_percent_larger_than_any_cup_is_still_imagined():
    cup, row = make_object("cup", 0), get("cup")
    # the largest scale at which every size is still typical, then 20% more
    usual = max(k for k in np.linspace(1.0, 3.0, 201) if row.dims_prior(np.asarray(cup.obb_dims) * k).value == 1.0)
    big = _scaled(cup, 1.2 * usual)
    r = classify([big], ["cup"], config=RunConfig(provider="offline", pose="as_placed"), progress=False, workers=1)[0]
    assert r.error is None and not r.dims_fit  # unusual, so stage 1 says so and names it
    assert NEGLIGIBLE < get("cup").dims_prior(big.obb_dims).value < FUNCTIONAL
    assert max(max(row) for row in r.scores) > 0  # but the physics ran, and held the droplets
    assert 0.0 < r.probability < FUNCTIONAL and not r.functional and "typical" in r.prior
    assert math.isfinite(r.probability)


def test_an_absurd_size_is_not_imagined_and_its_probability_is_its_prior():
    cup = make_object("cup", 0)
    huge = _scaled(cup, 10.0)
    r = classify([huge], ["cup"], config=RunConfig(provider="offline", pose="as_placed"), progress=False, workers=1)[0]
    assert r.error is None and not r.functional and r.scores == []
    assert r.probability == pytest.approx(get("cup").dims_prior(huge.obb_dims).value) and r.probability < NEGLIGIBLE


def test_a_usual_cup_is_functional_with_probability_one():
    r = classify([make_object("cup", 0)], ["cup"], config=RunConfig(provider="offline", pose="as_placed"),
                 progress=False, workers=1)[0]
    assert r.functional and r.probability == pytest.approx(1.0) and 0.0 <= r.probability <= 1.0


@pytest.mark.parametrize("width", [0.0, 0.005, 11.0, -0.1, math.nan, math.inf, True])
def test_a_prior_width_out_of_range_is_a_config_error_naming_the_range(width):
    lo, hi = WIDTH_RANGE
    with pytest.raises(ConfigError, match=rf"\[{lo:g}, {hi:g}\]"):
        Envelope(height=(0.1, 0.2), widths=(("height", width),))
    with pytest.raises(ConfigError, match=rf"\[{lo:g}, {hi:g}\]"):
        plausibility(0.3, 0.1, 0.2, width)


def test_a_rows_own_width_widens_its_prior():
    row = get("cup")
    wide = replace(row, envelope=replace(row.envelope, widths=(("height", 0.5),)))
    tall = [0.04, 0.04, 0.1]  # 20 cm tall
    assert row.pose_prior(tall).value < wide.pose_prior(tall).value < 1.0
    assert wide.scaled(0.5).envelope.widths == wide.envelope.widths


@pytest.mark.parametrize("value", [math.nan, math.inf, -1.0, 0.0, 1e-9, 1e9])
def test_a_prior_is_always_finite_and_in_the_unit_interval(value):
    for row in REGISTRY.values():
        for p in (row.size_prior([value, 0.1, 0.05]), row.dims_prior([value, 0.1, 0.05]),
                  row.pose_prior([value, 0.1, 0.05], rim=value)):
            assert math.isfinite(p.value) and 0.0 <= p.value <= 1.0


def test_a_size_is_weighed_once_in_a_poses_prior():
    """A use whose sizes are all in its envelope has no pose-free prior; stage 1 reads the envelope in the OBB's
    best orientation, the verdict in the pose itself."""
    cup = get("cup")
    assert cup.size_prior([0.2, 0.2, 0.2]).factors == ()
    cube = cup.pose_prior([0.1, 0.1, 0.1]).value  # a 20 cm cube is an unusual cup whichever side is up
    assert cup.dims_prior([0.2, 0.2, 0.2]).value == pytest.approx(cube) and cube < 1.0
    chair = get("chair")
    assert [f.name for f in chair.size_prior([1.6, 0.6, 0.5]).factors] == ["largest dim", "smallest dim"]


def test_a_stable_pose_whose_prior_is_negligible_is_not_imagined(tmp_path):
    """A 20 x 16 x 3 cm block as a plate: lying flat it is one (3 cm tall); standing on an edge it is 16-20 cm tall,
    far past a plate's 4 cm, so that pose's prior is below NEGLIGIBLE and no physics could make it functional."""
    path = tmp_path / "block.stl"
    trimesh.creation.box(extents=(0.2, 0.16, 0.03)).export(path)
    r = classify([path], ["plate"], config=RunConfig(provider="offline"), progress=False, workers=1)[0]
    assert r.error is None
    standing = [p.index for p in r.stable_poses if p.half_extents[2] > 0.05]
    flat = [p.index for p in r.stable_poses if p.half_extents[2] < 0.02]
    assert standing and flat
    assert {v.index for v in r.pose_verdicts} == set(flat)
    for i in standing:
        assert all(s == -1.0 for s in r.scores[i])
        assert any(reason.startswith(f"pose {i}: not imagined: its prior") for reason in r.analyzer_reasons)
        assert explain(r).poses[i].analyzer.startswith("not imagined: its prior")
