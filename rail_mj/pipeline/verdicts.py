"""Per-pose verdicts as probabilities: a size prior times what the physics says under perturbation.

For each imagined stable pose of an object, with ``W = 1 + K`` worlds (the nominal one and K perturbed ones,
:mod:`rail_mj.imagination.perturb`)::

    physics(pose)     = max over plans j of  #{worlds in which plan j succeeds in this pose} / W
    probability(pose) = size_prior(object's OBB) * pose_prior(pose's box, its basin's rim) * physics(pose)

A rollout succeeds when it did not blow up (``Outcomes.unstable``: a non-finite state or a MuJoCo instability
warning), its score is above 0, and the Functional Pose Analyzer's rules accept it in its world
(:func:`rail_mj.llm.offline.judge_pose`: the kind's rules on each candidate, then on the pose's candidates
together). With an LLM provider, a pose its stage 7 rejected in the nominal world has physics 0: common sense
vetoes what the rules would let through. The priors are :meth:`Affordance.size_prior` and
:meth:`Affordance.pose_prior` (1 for an affordance outside the registry).

The result's ``probability`` is the largest pose probability; the result is functional when it is at least
:data:`FUNCTIONAL`, and its functional pose is the most probable pose (ties: stage 7's pick in the nominal
world, then the pose whose plans succeed in more worlds, then the more probable stable pose). Every probability is
finite and in [0, 1].
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from rail_mj.core.profile import MotionPlan
from rail_mj.core.results import PoseProbability
from rail_mj.core.types import Outcomes, StablePose
from rail_mj.imagination.perturb import PerturbationSet, scaled_pose, world_trajectory
from rail_mj.imagination.summary import pose_candidates
from rail_mj.llm.offline import judge_pose, rules_row
from rail_mj.llm.schemas import FunctionalPoseVerdict

__all__ = ["FUNCTIONAL", "world_outcomes", "pose_probabilities", "most_probable"]

#: A pose affords the use when it more likely does than not.
FUNCTIONAL = 0.5


def world_outcomes(outcomes: Outcomes, scores: np.ndarray, n_worlds: int) -> list[tuple[Outcomes, np.ndarray]]:
    """The (outcomes, scores) of each world of a world-major batch; a blown-up rollout scores -1."""
    unstable = np.zeros(outcomes.batch, dtype=bool) if outcomes.unstable is None else outcomes.unstable
    scores = np.where(unstable | ~np.isfinite(scores), -1.0, scores)
    per = outcomes.batch // n_worlds
    out = []
    for w in range(n_worlds):
        sl = slice(w * per, (w + 1) * per)
        fields: dict[str, Any] = {f.name: None if getattr(outcomes, f.name) is None else getattr(outcomes, f.name)[sl]
                  for f in dataclasses.fields(outcomes)}
        out.append((Outcomes(**fields), scores[sl]))
    return out


def pose_probabilities(
    affordance: str,
    scale: float,
    obb_dims: Sequence[float] | np.ndarray,
    plans: Sequence[MotionPlan],
    poses: Sequence[StablePose],
    kept: Sequence[int],
    outcomes: Outcomes,
    scores: np.ndarray,
    trajectories: Sequence[Sequence[np.ndarray]],
    perturbations: PerturbationSet,
    stage7: FunctionalPoseVerdict | None = None,
    llm_veto: bool = False,
) -> list[PoseProbability]:
    """One :class:`PoseProbability` per imagined pose (``kept``, in that order), from the batch of every world
    (``outcomes``/``scores``: world-major, :func:`rail_mj.imagination.imagine` with ``perturbations``;
    ``trajectories``: the nominal via-poses per kept pose and plan). ``stage7`` is the nominal world's verdict;
    ``llm_veto``: the poses it rejected get physics 0 (an LLM provider's common sense)."""
    aff = rules_row(affordance, scale)
    n_worlds, n_plans = perturbations.n_worlds, len(plans)
    names = [p.name for p in plans]
    wins = np.zeros((len(kept), n_plans), dtype=np.int64)
    blew_up: list[list[str]] = [[] for _ in kept]
    slot = {i: k for k, i in enumerate(kept)}
    for w, (out_w, scores_w) in enumerate(world_outcomes(outcomes, scores, n_worlds)):
        world = perturbations.worlds[w]
        if out_w.unstable is not None:
            for b in np.nonzero(out_w.unstable)[0]:
                k, j = divmod(int(b), n_plans)
                where = "the nominal world" if w == 0 else f"world {w} ({world.doc()})"
                blew_up[k].append(f"plan {names[j]!r} blew up in {where}")
        poses_w = [scaled_pose(p, world.scale) for p in poses]
        trajectories_w = [[world_trajectory(t, np.asarray(poses[i].half_extents), world) for t in trajectories[k]]
                          for k, i in enumerate(kept)]
        for pc in pose_candidates(plans, poses_w, kept, out_w, scores_w, trajectories_w):
            accepted, _ = judge_pose(aff, pc)
            for c in accepted:
                wins[slot[pc.pose_index], names.index(c.plan)] += 1
    vetoed = ({v.pose_index for v in stage7.poses if not v.accept} if llm_veto and stage7 is not None else set())
    out = []
    for k, i in enumerate(kept):
        pose = poses[i]
        if aff is None:
            prior, doc = 1.0, "outside the registry: no size prior"
        else:
            p = aff.size_prior([float(d) for d in obb_dims]) * aff.pose_prior(
                [float(v) for v in pose.half_extents], None if pose.basin is None else pose.basin.rim)
            prior, doc = p.value, p.doc()
        j = int(np.argmax(wins[k]))
        successes = 0 if i in vetoed else int(wins[k, j])
        physics = successes / n_worlds
        out.append(PoseProbability(
            index=i, prior=_unit(prior), prior_factors=doc, physics=_unit(physics),
            probability=_unit(prior * physics), best_plan=names[j] if successes else None, successes=successes,
            worlds=n_worlds, blew_up=blew_up[k],
        ))
    return out


def _unit(x: float) -> float:
    """``x`` as a probability: finite, in [0, 1] (a NaN is no evidence: 0)."""
    return min(1.0, max(0.0, float(x))) if math.isfinite(x) else 0.0


def most_probable(verdicts: Sequence[PoseProbability], poses: Sequence[StablePose],
                  stage7_best: int | None) -> PoseProbability | None:
    """The most probable pose (ties: stage 7's pick, more successful worlds, the more probable stable pose)."""
    if not verdicts:
        return None
    return max(verdicts, key=lambda v: (v.probability, v.index == stage7_best, v.successes,
                                        float(poses[v.index].probability)))
