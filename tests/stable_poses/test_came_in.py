"""The pose an object came in as evidence of the pose it was made to stand in: a shelf box that came standing is
no basket on its back; a cup that came upside down is still a cup, less certainly; an object in an arbitrary
orientation is made for no pose for certain."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh

from rail_mj.core.profile import PoseShape
from rail_mj.core.types import RailObject, StablePose
from rail_mj.mesh import object_from_mesh
from rail_mj.pipeline.chain import Pipeline, classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot.demo import make_object
from rail_mj.stable_poses.came_in import (
    PLACED,
    STORED_TURNED,
    came_in_pose,
    common_factor,
    design_factors,
    made_for_other,
    made_to_stand,
    turned_over,
)
from rail_mj.stable_poses.shape import came_in_shape, pose_shape


def _open_front_box() -> RailObject:
    """A cubby 40 cm wide, 30 cm deep, 32 cm tall of 1.5 cm boards, open at its front (+x), standing as built."""
    w, d, h, t = 0.40, 0.30, 0.32, 0.015
    boards = [([d, w, t], [0, 0, t / 2]), ([d, w, t], [0, 0, h - t / 2]), ([d, t, h], [0, -w / 2 + t / 2, h / 2]),
              ([d, t, h], [0, w / 2 - t / 2, h / 2]), ([t, w, h], [-d / 2 + t / 2, 0, h / 2])]
    parts = []
    for extents, centre in boards:
        b = trimesh.creation.box(extents=extents)
        b.apply_translation(centre)
        parts.append(b)
    return object_from_mesh(trimesh.boolean.union(parts, engine="manifold"), name="cubby")


_BOX = object_from_mesh(trimesh.creation.box(extents=[0.3, 0.2, 0.1]), name="box")


def _turned_over(obj: RailObject) -> RailObject:
    """``obj`` as it came turned over (half a turn about x)."""
    mesh = obj.mesh.copy()
    mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi, [1, 0, 0]))
    return object_from_mesh(mesh, name=f"{obj.name}_turned_over")


def test_another_pose_was_made_to_stand_in_at_most_a_third_of_the_time() -> None:
    assert PLACED == 0.5
    assert made_to_stand(0.0) == 0.0
    values = [made_to_stand(p) for p in np.linspace(0.0, 1.0, 11)]
    # the likelier a fall ends in the pose it came in, the weaker the evidence
    assert all(a < b for a, b in zip(values, values[1:], strict=False))
    assert made_to_stand(1.0) == pytest.approx(1 / 3)


def test_the_pose_it_came_in_carries_no_factor_and_every_other_one() -> None:
    cubby = _open_front_box()
    poses = Pipeline(RunConfig(provider="offline")).stable_poses(cubby)
    came = came_in_pose(cubby, poses)
    assert came is not None and poses[came].up_in_mesh_frame[2] > 0.9
    factors = design_factors(cubby, poses, lambda: came_in_shape(cubby), lambda i: pose_shape(cubby, poses[i]))
    assert factors[came] is None
    others = [f for i, f in enumerate(factors) if i != came]
    assert others and all(f is not None and f[1] == made_to_stand(poses[came].probability) for f in others)
    assert common_factor(factors) == 1.0  # the pose it came in carries none: the factors tell poses apart


def test_an_object_whose_up_is_unknown_was_made_for_no_pose_for_certain() -> None:
    """In an arbitrary orientation every pose carries one factor: what the pose it came in would have told, on
    average over how an object made to stand in a pose comes (placed so, or fallen into any pose), with even odds
    among the poses for the one it was made for."""
    cubby = dataclasses.replace(_open_front_box(), oriented=False)
    poses = Pipeline(RunConfig(provider="offline")).stable_poses(cubby)
    assert came_in_pose(cubby, poses) is None and len(poses) > 1
    factors = design_factors(cubby, poses, lambda: pytest.fail("no pose it came in to measure"),
                             lambda i: pose_shape(cubby, poses[i]))
    p = np.array([q.probability for q in poses]) / sum(q.probability for q in poses)
    other = [made_for_other(p[a], turned_over(pose_shape(cubby, poses[a]))) for a in range(len(poses))]
    f = [PLACED + (1 - PLACED) * (p[d] + sum(p[a] * other[a] for a in range(len(poses)) if a != d))
         for d in range(len(poses))]
    assert all(x is not None and "its up unknown" in x[0] and x[1] == pytest.approx(np.mean(f)) for x in factors)
    assert PLACED < np.mean(f) < 1.0
    one = design_factors(cubby, list(poses)[:1], lambda: pytest.fail("unused"), lambda i: pytest.fail("unused"))
    assert one == [None]  # one stable pose: it is made to stand in it


@pytest.mark.parametrize("seed", range(5))
def test_an_unknown_up_never_makes_a_use_of_one_pose_of_several_certain(seed: int) -> None:
    """With two stable poses or more the factor is at most 5/6, or 11/12 where a pose is turned over: a use the
    physics alone accepts stays below the calibration's top bin (0.9-1.0) unless a pose is turned over."""
    rng = np.random.default_rng(seed)
    for _ in range(200):
        n = int(rng.integers(2, 8))
        poses = [StablePose(pos=np.zeros(3), quat=np.array([1.0, 0, 0, 0]), probability=float(p),
                            half_extents=np.ones(3)) for p in rng.dirichlet(np.full(n, rng.uniform(0.05, 3.0)))]
        turned = rng.random(n) < 0.3
        shape = [PoseShape(open_faces=["bottom"] if t else ["top"], cavity=0.2, as_it_came=None) for t in turned]
        arbitrary = dataclasses.replace(_BOX, oriented=False)
        factors = design_factors(arbitrary, poses, lambda: pytest.fail("unused"), lambda i, shape=shape: shape[i])
        factor = factors[0][1] if factors[0] is not None else 1.0
        assert len({f for f in factors}) == 1  # one factor for every pose: the physics orders them
        assert common_factor(factors) == factor
        assert PLACED < factor <= (11 / 12 if turned.any() else 5 / 6) + 1e-12


def test_an_object_that_came_turned_over_was_stored_so_or_stands_as_made() -> None:
    """Mouth down, a cup stored upside down and a display riser on its open side look alike: every other pose gets
    even odds of the two, between 1/2 and 2/3, so the cup stays a cup and no use with the cavity up is certain."""
    cup = _turned_over(make_object("cup", 0))
    poses = Pipeline(RunConfig(provider="offline")).stable_poses(cup)
    came = came_in_pose(cup, poses)
    assert came is not None and poses[came].up_in_mesh_frame[2] > 0.9  # it came at rest, mouth down
    factors = design_factors(cup, poses, lambda: came_in_shape(cup), lambda i: pose_shape(cup, poses[i]))
    assert factors[came] is None
    others = [f for i, f in enumerate(factors) if i != came]
    assert STORED_TURNED == 0.5
    stored = STORED_TURNED + (1 - STORED_TURNED) * made_to_stand(poses[came].probability)
    assert others and all(f is not None and f[1] == pytest.approx(stored) and "turned over" in f[0] for f in others)
    assert 0.5 <= stored <= 2 / 3
    verdict, = classify([cup], ["cup"], config=RunConfig(provider="offline"), progress=False, workers=1)
    assert verdict.functional and 0.5 <= verdict.probability <= 2 / 3


def test_a_shelf_box_that_came_standing_is_no_basket_on_its_back() -> None:
    cubby = _open_front_box()
    config = RunConfig(provider="offline")
    standing, = classify([cubby], ["basket"], config=config, progress=False, workers=1)
    anyhow, = classify([dataclasses.replace(cubby, oriented=False)], ["basket"], config=config, progress=False,
                       workers=1)
    # in an arbitrary orientation on its back it holds what is dropped in, but nothing says it was made to
    assert anyhow.functional and 0.5 <= anyhow.probability < 0.9
    assert not standing.functional and standing.probability < 1 / 3
    best = max(standing.pose_verdicts, key=lambda v: v.probability)
    assert "made to stand this way" in best.prior_factors
