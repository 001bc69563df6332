"""ImaginedWorlds: the three index spaces (pose, slot, rollout) translated once, and what each world imagined."""

from dataclasses import replace

import numpy as np
from pipeline_arrays import PLANS, evidence_of, outcomes_of, world_major

from rail_mj.imagination.worlds import candidate_plans, fill_perturbed, world_outcomes


def test_poses_slots_and_rollouts_are_translated_in_one_place():
    evidence = evidence_of(3, kept=[0, 2])  # pose 1 was not imagined
    evidence.add_nominal(outcomes_of(2), np.array([-1.0, -1.0, 0.3, -1.0]))
    assert evidence.slot_of(2) == 1 and evidence.nominal_rollout(2, 0) == 2
    (pc,) = evidence.candidates(evidence.nominal)
    assert pc.pose_index == 2 and [c.plan for c in pc.candidates] == [PLANS[0].name] and len(pc.failed) == 1


def test_each_world_knows_the_poses_it_imagined():
    evidence = evidence_of(2, worlds=3)
    evidence.add_nominal(outcomes_of(2), np.array([0.5, -1.0, -1.0, -1.0]))
    evidence.add_perturbed(world_major(2), np.array([0.5, 0.5]), [(0, 0)], [0])
    evidence.add_second_decomposition(outcomes_of(1), np.array([0.5, -1.0]), [0])
    assert [w.slots for w in evidence.worlds] == [[0, 1], [0], [0], [0]]
    assert [evidence.imagined(k) for k in (0, 1)] == [4, 1]
    assert evidence.worlds[-1].label == "the second decomposition" and evidence.second_slots == [0]


def test_perturbed_worlds_come_in_rounds_each_pose_counting_the_worlds_it_was_imagined_in():
    evidence = evidence_of(2, worlds=4)
    evidence.add_nominal(outcomes_of(2), np.array([0.5, -1.0, 0.5, -1.0]))
    evidence.add_perturbed(world_major(4), np.full(4, 0.5), [(0, 0), (1, 0)], [0, 1])  # worlds 1 and 2, both poses
    evidence.add_perturbed(world_major(1), np.array([0.5]), [(1, 0)], [1], first=3)  # world 3, pose 1 alone
    assert [w.label.split(" (")[0] for w in evidence.worlds] == ["the nominal world", "world 1", "world 2", "world 3"]
    assert [w.slots for w in evidence.worlds] == [[0, 1], [0, 1], [0, 1], [1]]
    assert [evidence.imagined(k) for k in (0, 1)] == [3, 4] and evidence.perturbed_slots == [0, 1]


def test_a_blown_up_rollout_scores_minus_one_and_other_plans_keep_their_nominal_failure():
    out = replace(outcomes_of(1), unstable=np.array([True, False]))
    ((_, scores),) = world_outcomes(out, np.array([0.9, np.nan]), 1)
    assert scores.tolist() == [-1.0, -1.0]
    nominal = outcomes_of(2)
    assert candidate_plans(np.array([0.5, -1.0, -0.5, 0.2]), [0, 1], 2) == [(0, 0), (1, 1)]
    full, full_scores = fill_perturbed((nominal, np.array([0.5, -1.0, -0.5, 0.2])), (world_major(2), np.ones(2)),
                                       [(0, 0)], [0], 2, 2)
    assert full.batch == 4 and full_scores.tolist() == [1.0, -1.0, 1.0, -1.0]
