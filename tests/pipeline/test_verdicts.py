"""The pure verdict functions on small arrays: a pose's probability from its worlds, the poses one more world could
decide, the most probable pose, and the candidates the perturbed worlds imagine again."""

import numpy as np
import pytest
from pipeline_arrays import evidence_of as _evidence
from pipeline_arrays import outcomes_of as _outcomes
from pipeline_arrays import pose_of as _pose
from pipeline_arrays import world_major as _world_major

from rail_mj.core.results import PoseProbability
from rail_mj.pipeline.verdicts import candidate_slots, judge, most_probable, undecided


def _verdict(index: int, prior: float, successes: int, imagined: int) -> PoseProbability:
    return PoseProbability(index=index, prior=prior, prior_factors="", physics=successes / imagined,
                           probability=prior * successes / imagined, best_plan="plan0" if successes else None,
                           successes=successes, worlds=imagined, imagined=imagined)


def test_a_pose_that_succeeds_in_every_world_has_probability_one_and_a_failed_plan_scores_nothing():
    evidence = _evidence(2)
    evidence.add_nominal(_outcomes(2), np.array([0.5, -1.0, -1.0, -1.0]))  # pose 0 plan 0 succeeds, pose 1 none
    first, second = judge(evidence, np.ones(3))
    assert (first.probability, first.best_plan, first.successes, first.imagined) == (1.0, "plan0", 1, 1)
    assert (second.probability, second.best_plan, second.successes) == (0.0, None, 0)


def test_a_pose_the_rules_refuse_fails_however_it_scored():
    evidence = _evidence(1)
    evidence.add_nominal(_outcomes(1, tilt_deg=80.0), np.array([0.5, 0.5]))  # tipped over: no common sense
    (v,) = judge(evidence, np.ones(3))
    assert v.probability == 0.0 and v.successes == 0


def test_physics_counts_the_worlds_that_accept_the_pose():
    evidence = _evidence(1, worlds=4)
    evidence.add_nominal(_outcomes(1), np.array([0.5, -1.0]))
    # three perturbed worlds of the one candidate plan: two accept it
    evidence.add_perturbed(_world_major(3), np.array([0.5, -1.0, 0.4]), [(0, 0)], [0])
    (v,) = judge(evidence, np.ones(3))
    assert (v.successes, v.imagined, v.worlds) == (3, 4, 4) and v.physics == pytest.approx(0.75)


def test_each_world_is_judged_once_however_often_the_verdicts_are_asked_for():
    evidence = _evidence(1)
    evidence.add_nominal(_outcomes(1), np.array([0.5, -1.0]))
    judge(evidence, np.ones(3))
    judged = evidence.nominal.judged
    assert judged is not None
    judge(evidence, np.ones(3))
    assert evidence.nominal.judged is judged


def test_a_model_s_stage_7_veto_is_physics_zero():
    from rail_mj.core.profile import FunctionalPoseVerdict, PoseVerdict

    evidence = _evidence(1)
    evidence.add_nominal(_outcomes(1), np.array([0.5, -1.0]))
    stage7 = FunctionalPoseVerdict(poses=[PoseVerdict(pose_index=0, accept=False, reason="a lid", plan=None)],
                                   best_pose=None, best_plan=None, reason="none")
    assert judge(evidence, np.ones(3), stage7)[0].probability == 1.0  # the rules' own answer vetoes nothing
    assert judge(evidence, np.ones(3), stage7, llm_veto=True)[0].probability == 0.0


def test_one_more_world_is_imagined_only_where_it_could_turn_the_verdict():
    verdicts = [_verdict(0, 1.0, 5, 5), _verdict(1, 1.0, 2, 5), _verdict(2, 1.0, 3, 5), _verdict(3, 0.4, 5, 5)]
    # with a sixth world: 5 of 6 stays functional and 3 of 6 is 0.5 whatever it shows; 2 of 6 is below 0.5 and
    # 3 of 6 is not, so only that pose is undecided; a prior of 0.4 stays below 0.5 whatever the physics
    assert undecided(verdicts, [0, 1, 2, 3]) == [1]


def test_the_most_probable_pose_ties_within_one_world_and_prefers_stage_7s_pick():
    poses = [_pose(0.6), _pose(0.4)]
    one_world_apart = [_verdict(0, 1.0, 5, 5), _verdict(1, 1.0, 4, 5)]
    assert most_probable(one_world_apart, poses, stage7_best=None).index == 0  # type: ignore[union-attr]
    assert most_probable(one_world_apart, poses, stage7_best=1).index == 1  # type: ignore[union-attr]
    two_worlds_apart = [_verdict(0, 1.0, 5, 5), _verdict(1, 1.0, 3, 5)]
    assert most_probable(two_worlds_apart, poses, stage7_best=1).index == 0  # type: ignore[union-attr]
    assert most_probable([], poses, None) is None


def test_the_perturbed_worlds_take_the_poses_with_a_candidate_and_a_prior_that_can_be_functional():
    scores = np.array([0.5, -1.0, -1.0, -1.0, 0.2, 0.1])
    assert candidate_slots(scores, 3, 2) == [0, 2]
    assert candidate_slots(scores, 3, 2, priors=[1.0, 1.0, 0.3]) == [0]
