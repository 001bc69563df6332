"""The pure verdict functions on small arrays: a pose's probability from its worlds, the poses one more world could
decide, the most probable pose, and the candidates the perturbed worlds imagine again."""

import numpy as np
import pytest
from pipeline_arrays import evidence_of as _evidence
from pipeline_arrays import outcomes_of as _outcomes
from pipeline_arrays import pose_of as _pose
from pipeline_arrays import world_major as _world_major

from rail_mj.core.results import PoseProbability
from rail_mj.pipeline.verdicts import candidate_slots, judge, most_probable, next_worlds, undecided


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


@pytest.mark.parametrize("prior, successes, imagined, most, expected", [
    # 3 of 5 is functional whatever worlds 3 and 4 show: the next two worlds may decide it, one cannot
    (1.0, 1, 1, 5, [([0], 1, 2)]),
    (1.0, 3, 3, 5, []),  # decided: 3 of 5 at the least
    (1.0, 0, 3, 5, []),  # 0 + 2 of 5 is not functional: decided the other way
    # a pose that failed in the nominal world, with the second decomposition still to come: 3 of 6 passes, so only
    # three failures in a row decide it
    (1.0, 0, 1, 6, [([0], 1, 3)]),
    (0.4, 1, 1, 5, []),  # a prior of 0.4 stays below 0.5 whatever the physics
    (0.7, 3, 4, 5, [([0], 4, 1)]),  # 0.7 x 4/5 = 0.56 or 0.7 x 3/5 = 0.42: the last world decides
])
def test_the_next_perturbed_worlds_are_the_fewest_that_could_decide_a_pose(prior, successes, imagined, most,
                                                                           expected):
    assert next_worlds([_verdict(0, prior, successes, imagined)], [0], [prior], most, 4, True) == expected


def test_a_pose_sure_to_pass_waits_for_the_others_and_goes_on_only_if_another_could_pass_too():
    sure, undecided_, failed = _verdict(0, 1.0, 3, 3), _verdict(1, 1.0, 1, 1), _verdict(2, 1.0, 0, 3)
    # the undecided pose goes on alone; the sure one waits where it stopped
    assert next_worlds([sure, undecided_, failed], [0, 1, 2], [1.0] * 3, 5, 4, True) == [([1], 1, 2)]
    # once it is sure too, both go on to the last world from where each stopped: their counts say which is likelier
    both = [sure, _verdict(1, 1.0, 3, 4), failed]
    assert next_worlds(both, [0, 1, 2], [1.0] * 3, 5, 4, True) == [([0], 3, 2), ([1], 4, 1)]
    # a pose through every perturbed world that the second decomposition may still make pass: it comes first, and
    # may leave the sure pose alone
    failed = _verdict(2, 1.0, 0, 4)  # 0 + 2 of 6
    assert next_worlds([sure, _verdict(1, 1.0, 2, 5), failed], [0, 1, 2], [1.0] * 3, 6, 4, True) == []
    assert next_worlds([sure, _verdict(1, 1.0, 2, 6), failed], [0, 1, 2], [1.0] * 3, 6, 4, True) == []
    assert next_worlds([sure, _verdict(1, 1.0, 3, 6), failed], [0, 1, 2], [1.0] * 3, 6, 4, True) == [([0], 3, 2)]


def test_a_rest_prior_that_moves_with_each_world_never_makes_a_pose_sure():
    # seated in every world so far at a rest height the prior likes: the worlds left may move it, so they are drawn
    assert next_worlds([_verdict(0, 1.0, 3, 3)], [0], [1.0], 5, 4, prior_final=False) == [([0], 3, 2)]
    # but a pose that cannot pass even with a rest prior of 1 stops
    assert next_worlds([_verdict(0, 1.0, 0, 3)], [0], [1.0], 5, 4, prior_final=False) == []
