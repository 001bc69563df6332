"""The decomposition perturbation (issue 22): where a use rests in the object's concavities, one more world imagines
it on the object's second decomposition, CoACD's other concavity threshold."""

from __future__ import annotations

import numpy as np
import trimesh

from rail_mj.affordances import REGISTRY, get
from rail_mj.core.types import StablePose
from rail_mj.imagination import ImaginationConfig
from rail_mj.imagination.perturb import resting_on
from rail_mj.mesh import DENSE_DECOMPOSITION, DENSE_FACES, DecompositionConfig, second_decomposition
from rail_mj.pipeline.chain import Pipeline, classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot.demo import make_object


def test_the_second_setting_is_the_other_threshold_at_the_dense_speed():
    small = trimesh.creation.box()
    dense = trimesh.creation.icosphere(subdivisions=5)
    assert len(small.faces) <= DENSE_FACES < len(dense.faces)
    assert second_decomposition(small) == DENSE_DECOMPOSITION  # a standard mesh: the coarser threshold
    finer = second_decomposition(dense)
    assert finer.threshold == DecompositionConfig().threshold  # a dense one: the finer threshold
    assert finer.mcts_iterations == DENSE_DECOMPOSITION.mcts_iterations
    assert finer.max_faces == DENSE_DECOMPOSITION.max_faces


def test_the_object_rests_on_its_second_hulls_where_it_rested_on_its_first():
    hull = trimesh.creation.box().vertices
    pose = StablePose(pos=np.array([0.1, 0.2, 0.5]), quat=np.array([0.0, 1.0, 0.0, 0.0]), probability=1.0,
                      half_extents=np.full(3, 0.5))  # upside down: the mesh's top (+z) is the lowest point
    deeper = hull + np.array([0.0, 0.0, 0.01])  # second hulls reaching 1 cm further up the mesh frame
    moved = resting_on(pose, (hull,), (deeper,))
    np.testing.assert_allclose(moved.pos, [0.1, 0.2, 0.51])
    np.testing.assert_allclose(moved.quat, pose.quat)
    assert resting_on(pose, (hull,), (hull,)).pos.tolist() == pose.pos.tolist()


def _worlds(affordance: str, **imagination) -> list[tuple[int, int]]:
    config = RunConfig(imagination=ImaginationConfig(perturbations=2, **imagination))
    r = classify([make_object("cup", 0)], [affordance], provider="offline", progress=False, workers=1,
                 pose="as_placed", config=config)[0]
    assert r.error is None
    return [(v.worlds, v.imagined) for v in r.pose_verdicts]


def test_a_cup_is_imagined_once_more_on_its_second_decomposition():
    assert _worlds("cup") == [(4, 4)]  # nominal, 2 perturbed, the second decomposition
    assert _worlds("cup", perturb_decomposition=False) == [(3, 3)]


def test_only_uses_that_rest_in_concavities_get_the_second_decomposition():
    matters = {name: Pipeline(RunConfig())._decomposition_matters(get(name)) for name in REGISTRY}
    assert matters["cup"] and matters["plate"] and matters["shelf"] and matters["bathtub"]
    # a seat, a bed and a table top are the same convex top in any decomposition
    assert not (matters["chair"] or matters["bed"] or matters["table"])
    assert Pipeline(RunConfig())._decomposition_matters(None)  # an LLM's use outside the registry may rest in one
    off = RunConfig(imagination=ImaginationConfig(perturb_decomposition=False))
    assert not any(Pipeline(off)._decomposition_matters(get(name)) for name in REGISTRY)
