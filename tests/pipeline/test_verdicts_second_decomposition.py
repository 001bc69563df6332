"""The decomposition perturbation (issue 22): where a use rests in the object's concavities, one more world imagines
it on the object's second decomposition, CoACD's other concavity threshold."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rail_mj.affordances import REGISTRY, get
from rail_mj.core.results import AffordanceResult, PoseProbability
from rail_mj.core.types import StablePose
from rail_mj.imagination import ImaginationConfig
from rail_mj.imagination.perturb import resting_on
from rail_mj.mesh import DENSE_DECOMPOSITION, DENSE_FACES, DecompositionConfig, second_decomposition
from rail_mj.pipeline import chain
from rail_mj.pipeline.chain import Pipeline, classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.pipeline.verdicts import undecided
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


def _cup(**imagination) -> AffordanceResult:
    config = RunConfig(imagination=ImaginationConfig(perturbations=2, **imagination))
    r = classify([make_object("cup", 0)], ["cup"], config=config.model_copy(update=dict(provider="offline",
                 pose="as_placed")), progress=False, workers=1)[0]
    assert r.error is None
    return r


def test_a_settled_verdict_is_not_imagined_again_an_open_one_is(monkeypatch):
    settled = _cup()
    # held in the nominal world and the first perturbed one, prior 1: 2 of 4 worlds (the second perturbed one and
    # the second decomposition failing) would still be functional, so neither is imagined
    assert [(v.worlds, v.imagined, v.successes) for v in settled.pose_verdicts] == [(3, 2, 2)]
    assert "second_decomposition" not in settled.timings
    monkeypatch.setattr(chain, "undecided", lambda verdicts, slots: list(slots))  # as if the verdict were open
    opened = _cup()
    assert [(v.worlds, v.imagined) for v in opened.pose_verdicts] == [(4, 3)]
    assert opened.timings["second_decomposition"] > 0
    assert _cup(perturb_decomposition=False).pose_verdicts[0].imagined == 2


def _verdict(prior: float, successes: int, imagined: int = 5) -> PoseProbability:
    physics = successes / imagined
    return PoseProbability(index=0, prior=prior, physics=physics, probability=prior * physics, successes=successes,
                           worlds=imagined, imagined=imagined, best_plan="above" if successes else None)


@pytest.mark.parametrize("prior, successes, open_", [
    (1.0, 5, False),  # 5 of 6 even if it fails: functional either way
    (1.0, 2, True),  # 2 of 6 or 3 of 6: it decides
    (0.6, 5, False),  # 0.6 x 5/6 = 0.5: functional either way
    (0.6, 4, True),  # 0.6 x 4/6 = 0.4 or 0.6 x 5/6 = 0.5
    (1.0, 1, False),  # 1 or 2 of 6: not functional either way
])
def test_undecided_names_the_poses_one_more_world_could_turn(prior, successes, open_):
    verdicts = [_verdict(1.0, 5), _verdict(prior, successes)]
    assert undecided(verdicts, [0, 1]) == ([1] if open_ else [])


def test_only_uses_that_rest_in_concavities_get_the_second_decomposition():
    matters = {name: Pipeline(RunConfig())._decomposition_matters(get(name)) for name in REGISTRY}
    assert matters["cup"] and matters["plate"] and matters["shelf"] and matters["bathtub"]
    # a seat, a bed and a table top are the same convex top in any decomposition
    assert not (matters["chair"] or matters["bed"] or matters["table"])
    assert Pipeline(RunConfig())._decomposition_matters(None)  # an LLM's use outside the registry may rest in one
    off = RunConfig(imagination=ImaginationConfig(perturb_decomposition=False))
    assert not any(Pipeline(off)._decomposition_matters(get(name)) for name in REGISTRY)
