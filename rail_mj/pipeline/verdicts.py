"""Per-pose verdicts as probabilities: a size prior times what the physics says under perturbation.

For each imagined stable pose of an object (a pose whose prior is below
:data:`rail_mj.affordances.prior.NEGLIGIBLE` is not imagined: its probability stays below it whatever its physics),
with ``W`` worlds (the nominal one, K perturbed ones, :mod:`rail_mj.imagination.perturb`, and the second
decomposition where it matters)::

    physics(pose)     = #{worlds in which the pose succeeds} / W
    probability(pose) = size_prior(object's OBB) * pose_prior(pose's box, its basin's rim)
                        * rest_prior(where its best plan's agent came to rest) * physics(pose)

A pose succeeds in a world when the Functional Pose Analyzer's rules accept it there
(:func:`rail_mj.llm.offline.judge_pose`: the kind's rules on each candidate, a rollout that scored above 0
and did not blow up, then the pose's rules on its candidates together, which may need several plans: a seat's
centre and area, a table top's two placements); a world whose agent is resized is judged, where the kind's rules
read the agent's size (``Kind.rules_read_agent_size``: a body's reach), by the row scaled for that agent. Its best
plan is the plan accepted in the most worlds (ties: stage
7's plan for the pose, then the better nominal score). A rollout
that blew up (``Outcomes.unstable``: a non-finite state or a MuJoCo instability warning) is a failure and is named.
The nominal world imagines every pose and plan; the K perturbed worlds, one more batched call, imagine again
the candidates (the plans that scored above 0, :func:`candidate_plans`), and the plans the kind's pose rules read
whatever they scored (``Kind.evidence_plans``: every pour, for a leak; a bench's places side by side), of
the poses with a candidate whose prior is at least :data:`rail_mj.affordances.prior.FUNCTIONAL`: a pose
without a candidate has no success to confirm (its physics is 0), and one with a smaller prior stays below it
whatever its physics, so its verdict cannot change (its physics is the nominal world's, 0 or 1). A perturbation
asks whether what succeeded still succeeds in a slightly different world: any other plan failed in the nominal
world and counts as failed, as it did there, in each perturbed one (:func:`spread`). Where the use rests in
the object's concavities (a kind's ``decomposition_matters``), one more world imagines again, on the object's
second decomposition (:func:`rail_mj.mesh.second_decomposition`: CoACD's other concavity threshold), every plan of
the poses whose verdict it could still change (:func:`undecided`; its hulls may let a plan that failed on the
first ones succeed), in a third batched call (its hulls differ in number and shape, so it cannot share the
perturbed worlds' model layout). ``W`` is the number of worlds a pose was imagined in. With an LLM provider, a
pose its stage 7 rejected in the nominal world has physics 0: common sense vetoes what the rules would let
through. The priors are :meth:`Affordance.size_prior`, :meth:`Affordance.pose_prior` and, for a seat or a bed,
:meth:`Affordance.rest_prior` of the median height (at the object's nominal scale) at which the best plan's agent
came to rest in the worlds that accepted it: the envelope's ``rest`` window is a prior like its box sizes, and the
rules refuse only a rest height past :meth:`Affordance.rest_limits` (1 for an affordance outside the registry).

The result's ``probability`` is the largest pose probability; the result is functional when it is at least
:data:`rail_mj.affordances.prior.FUNCTIONAL`, and its functional pose is the most probable pose, where a pose within
one world's worth of it (prior / W: a count of W worlds tells no finer) is as probable (ties: stage 7's pick in
the nominal world, then the more probable, then the pose that succeeds in more worlds, then the more probable
stable pose). Every probability is finite and in [0, 1].
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Collection, Sequence
from typing import Any

import numpy as np

from rail_mj.affordances import Affordance
from rail_mj.affordances.kinds import kind_of
from rail_mj.affordances.prior import FUNCTIONAL, Prior
from rail_mj.core.profile import MotionPlan
from rail_mj.core.results import PoseProbability
from rail_mj.core.types import Outcomes, StablePose
from rail_mj.imagination.perturb import PerturbationSet, scaled_pose, world_trajectory
from rail_mj.imagination.summary import pose_candidates
from rail_mj.llm.offline import judge_pose, rules_row
from rail_mj.llm.schemas import FunctionalPoseVerdict

__all__ = ["world_outcomes", "candidate_slots", "candidate_plans", "spread", "undecided", "pose_prior",
           "pose_probabilities", "most_probable"]


def world_outcomes(outcomes: Outcomes, scores: np.ndarray, n_worlds: int) -> list[tuple[Outcomes, np.ndarray]]:
    """The (outcomes, scores) of each world of a world-major batch; a blown-up rollout scores -1."""
    unstable = np.zeros(outcomes.batch, dtype=bool) if outcomes.unstable is None else outcomes.unstable
    scores = np.where(unstable | ~np.isfinite(scores), -1.0, scores)
    per = outcomes.batch // n_worlds
    out = []
    for w in range(n_worlds):
        sl = slice(w * per, (w + 1) * per)
        out.append((_take(outcomes, sl), scores[sl]))
    return out


def candidate_slots(scores: np.ndarray, n_kept: int, n_plans: int,
                    priors: Sequence[float] | None = None) -> list[int]:
    """The imagined poses (slots into ``kept``) with a candidate in the nominal world (a plan scored above 0) and,
    given their ``priors``, a prior of at least FUNCTIONAL: the ones the perturbed worlds imagine again. A pose
    without a candidate has no success to confirm; one with a smaller prior stays below FUNCTIONAL whatever
    the physics."""
    grid = np.asarray(scores, dtype=float).reshape(n_kept, n_plans)
    return [k for k in range(n_kept) if np.any(grid[k] > 0) and (priors is None or priors[k] >= FUNCTIONAL)]


def candidate_plans(scores: np.ndarray, slots: Sequence[int], n_plans: int,
                    evidence: Collection[int] = ()) -> list[tuple[int, int]]:
    """The (pose slot, plan) rollouts the perturbed worlds imagine again: of the ``slots`` (:func:`candidate_slots`),
    each plan that scored above 0 in the nominal world, and the ``evidence`` plans (indices; the kind's pose rules
    read them whatever they scored, :meth:`Kind.evidence_plans`). A perturbation asks whether what succeeded in the
    imagined world still succeeds when the world is a little different; any other plan failed there and is taken
    to fail the same way in every perturbed world (:func:`spread`)."""
    grid = np.asarray(scores, dtype=float).reshape(-1, n_plans)
    return [(k, j) for k in slots for j in range(n_plans) if grid[k, j] > 0 or j in evidence]


def _take(outcomes: Outcomes, index: np.ndarray | slice) -> Outcomes:
    """The rollouts ``index`` of ``outcomes`` (every per-rollout array; the segments' names are every rollout's)."""
    fields: dict[str, Any] = {f.name: v[index] if isinstance(v := getattr(outcomes, f.name), np.ndarray) else v
                              for f in dataclasses.fields(outcomes)}
    return Outcomes(**fields)


def spread(nominal: tuple[Outcomes, np.ndarray], again: tuple[Outcomes, np.ndarray],
           pairs: Sequence[tuple[int, int]], slots: Sequence[int], n_plans: int,
           n_worlds: int) -> tuple[Outcomes, np.ndarray]:
    """The perturbed worlds' (outcomes, scores) of every plan of the pose ``slots``, world-major and pose-major (as
    one call imagining them all would give), from ``again``: the ``n_worlds`` worlds' rollouts of the ``pairs``
    (:func:`candidate_plans`, world-major). Every other plan is the ``nominal`` world's rollout with its score (at
    most 0: a failure), not blown up in the perturbed world."""
    out0, scores0 = nominal
    per = len(slots) * n_plans
    base = np.array([k * n_plans + j for k in slots for j in range(n_plans)], dtype=np.int64)
    filler = _take(out0, np.tile(base, n_worlds))
    pos = {(k, j): s * n_plans + j for s, k in enumerate(slots) for j in range(n_plans)}
    at = (np.arange(n_worlds)[:, None] * per + np.array([pos[p] for p in pairs])[None, :]).ravel()
    fields: dict[str, Any] = {}
    for f in dataclasses.fields(out0):
        v, w = getattr(filler, f.name), getattr(again[0], f.name)
        if isinstance(v, np.ndarray) and isinstance(w, np.ndarray):
            v = v.copy()
            v[at] = w
        fields[f.name] = v
    unstable = np.zeros(n_worlds * per, dtype=bool)
    if again[0].unstable is not None:
        unstable[at] = again[0].unstable
    fields.update(pose_index=np.tile(np.repeat(np.arange(len(slots)), n_plans), n_worlds),
                  plan_index=np.tile(np.arange(n_plans), len(slots) * n_worlds),
                  world=np.repeat(np.arange(n_worlds), per), unstable=unstable)
    scores = np.asarray(scores0, dtype=float)[np.tile(base, n_worlds)]
    scores[at] = again[1]
    return Outcomes(**fields), scores


def undecided(verdicts: Sequence[PoseProbability], slots: Sequence[int]) -> list[int]:
    """Of the pose ``slots`` (into the imagined poses, whose ``verdicts`` these are, in order) the ones whose verdict
    one more world could change: with it counted, ``prior x successes / (imagined + 1)`` is below FUNCTIONAL and
    ``prior x (successes + 1) / (imagined + 1)`` is not. For the others the verdict is the same whatever that world
    shows (and the same as without it), so it is not imagined."""
    out = []
    for k in slots:
        v = verdicts[k]
        n = v.imagined + 1
        if v.prior * v.successes / n < FUNCTIONAL <= v.prior * (v.successes + 1) / n:
            out.append(k)
    return out


def pose_prior(aff: Affordance | None, obb_dims: Sequence[float] | np.ndarray, pose: StablePose) -> Prior:
    """One pose's prior: the size prior of the object's OBB times the pose's envelope prior (its basin's rim for
    a vessel's aspect); no factor for an affordance outside the registry."""
    if aff is None:
        return Prior()
    return aff.size_prior([float(d) for d in obb_dims]) * aff.pose_prior(
        [float(v) for v in pose.half_extents], None if pose.basin is None else pose.basin.rim)


def _accepted(aff: Affordance | None, plans: Sequence[MotionPlan], poses: Sequence[StablePose],
              kept: Sequence[int], outcomes: Outcomes, scores: np.ndarray,
              trajectories: Sequence[Sequence[np.ndarray]]) -> dict[int, dict[str, float | None]]:
    """Per stable pose with a candidate: the plans stage 7's rules accept in this world's rollouts, each with the
    height its agent came to rest at where the kind measures one (:meth:`Kind.rest_height`)."""
    kind = kind_of(aff) if aff is not None else None
    out: dict[int, dict[str, float | None]] = {}
    for pc in pose_candidates(plans, poses, kept, outcomes, scores, trajectories):
        h = list(pc.half_extents)
        out[pc.pose_index] = {c.plan: kind.rest_height(aff, c, h) if kind is not None and aff is not None else None
                              for c in judge_pose(aff, pc)[0]}
    return out


def _blown(outcomes: Outcomes, names: Sequence[str], where: str) -> dict[int, list[str]]:
    """Per pose slot of a world's (pose-major) rollouts: the plans that blew up, in words."""
    out: dict[int, list[str]] = {}
    if outcomes.unstable is not None:
        for b in np.nonzero(outcomes.unstable)[0]:
            k, j = divmod(int(b), len(names))
            out.setdefault(k, []).append(f"plan {names[j]!r} blew up in {where}")
    return out


def pose_probabilities(
    affordance: str,
    scale: float,
    obb_dims: Sequence[float] | np.ndarray,
    plans: Sequence[MotionPlan],
    poses: Sequence[StablePose],
    kept: Sequence[int],
    nominal: tuple[Outcomes, np.ndarray],
    trajectories: Sequence[Sequence[np.ndarray]],
    perturbations: PerturbationSet,
    perturbed: tuple[Outcomes, np.ndarray, Sequence[int]] | None = None,
    stage7: FunctionalPoseVerdict | None = None,
    llm_veto: bool = False,
    decomposed: tuple[Outcomes, np.ndarray, Sequence[int]] | None = None,
) -> list[PoseProbability]:
    """One :class:`PoseProbability` per imagined pose (``kept``, in that order).

    ``nominal`` is the nominal world's (outcomes, scores) of every kept pose and plan (pose-major),
    ``trajectories`` its via-poses per kept pose and plan; ``perturbations`` the object's worlds
    (:func:`rail_mj.imagination.perturb.draw`, world 0 nominal); ``perturbed`` the (outcomes, scores, slots) of
    its perturbed worlds (world-major, ``perturbations.perturbed``) for the pose slots into ``kept`` that were
    imagined again (:func:`candidate_slots`); None without perturbed worlds. ``stage7`` is the nominal world's
    verdict; ``llm_veto``: the poses it rejected get physics 0 (an LLM provider's common sense). ``decomposed``:
    the (outcomes, scores, slots) of one more world, the nominal one on the object's second decomposition
    (:func:`rail_mj.mesh.second_decomposition`), for the pose slots it imagined; None without it.
    """
    aff = rules_row(affordance, scale)
    names = [p.name for p in plans]
    wins: list[dict[str, int]] = [{} for _ in kept]
    rests: list[dict[str, list[float]]] = [{} for _ in kept]  # per plan: its rest heights at the nominal scale
    worlds_ok = np.zeros(len(kept), dtype=np.int64)
    blew_up: list[list[str]] = [[] for _ in kept]
    slot = {i: k for k, i in enumerate(kept)}
    again = set() if perturbed is None else set(perturbed[2])

    def count(accepted: dict[int, dict[str, float | None]], scale: float = 1.0) -> None:
        for i, plans_ok in accepted.items():
            if plans_ok:
                worlds_ok[slot[i]] += 1
                for name, rest in plans_ok.items():
                    wins[slot[i]][name] = wins[slot[i]].get(name, 0) + 1
                    if rest is not None:
                        rests[slot[i]].setdefault(name, []).append(rest / scale)

    out0, scores0 = world_outcomes(*nominal, 1)[0]
    count(_accepted(aff, plans, poses, kept, out0, scores0, trajectories))
    for k, lines in _blown(out0, names, "the nominal world").items():
        blew_up[k] += lines
    if perturbed is not None:
        out_p, scores_p, slots = perturbed
        sub = [kept[k] for k in slots]
        rest = perturbations.worlds[1:]
        for w, (out_w, scores_w) in enumerate(world_outcomes(out_p, scores_p, len(rest)), start=1):
            world = perturbations.worlds[w]
            poses_w = [scaled_pose(p, world.scale) for p in poses]
            trajectories_w = [[world_trajectory(t, np.asarray(poses[kept[k]].half_extents), world)
                               for t in trajectories[k]] for k in slots]
            count(_accepted(_agent_row(aff, affordance, scale, world.agent_size), plans, poses_w, sub, out_w,
                            scores_w, trajectories_w), world.scale)
            for k, lines in _blown(out_w, names, f"world {w} ({world.doc()})").items():
                blew_up[slots[k]] += lines
    second: set[int] = set()
    if decomposed is not None:
        out_d, scores_d, slots_d = decomposed
        second = set(slots_d)
        out_d, scores_d = world_outcomes(out_d, scores_d, 1)[0]
        count(_accepted(aff, plans, poses, [kept[k] for k in slots_d], out_d, scores_d,
                        [trajectories[k] for k in slots_d]))
        for k, lines in _blown(out_d, names, "the second decomposition").items():
            blew_up[slots_d[k]] += lines
    stage7_plans = {v.pose_index: v.plan for v in stage7.poses} if stage7 is not None else {}
    vetoed = ({v.pose_index for v in stage7.poses if not v.accept} if llm_veto and stage7 is not None else set())
    out = []
    for k, i in enumerate(kept):
        successes = 0 if i in vetoed else int(worlds_ok[k])
        # ties: stage 7's plan for the pose, then the better nominal score
        chosen, row = stage7_plans.get(i), scores0[k * len(names) : (k + 1) * len(names)]
        best = (max(wins[k], key=lambda name: (wins[k][name], name == chosen, float(row[names.index(name)])))
                if successes else None)
        p = pose_prior(aff, obb_dims, poses[i])
        if aff is not None and best is not None and rests[k].get(best):
            p = p * aff.rest_prior(float(np.median(rests[k][best])))
        prior, doc = p.value, (p.doc() if aff is not None else "outside the registry: no size prior")
        imagined = (perturbations.n_worlds if k in again else 1) + (k in second)
        physics = successes / imagined
        out.append(PoseProbability(
            index=i, prior=_unit(prior), prior_factors=doc, physics=_unit(physics),
            probability=_unit(prior * physics), best_plan=best, successes=successes,
            worlds=perturbations.n_worlds + (k in second), imagined=imagined, blew_up=blew_up[k],
        ))
    return out


def _agent_row(aff: Affordance | None, affordance: str, scale: float, agent_size: float) -> Affordance | None:
    """The row a world whose agent is ``agent_size`` times the size is judged by: scaled for that agent where the
    kind's rules read the agent's size (a body's reach), else ``aff``."""
    if aff is None or agent_size == 1.0 or not kind_of(aff).rules_read_agent_size:
        return aff
    return rules_row(affordance, scale * agent_size)


def _unit(x: float) -> float:
    """``x`` as a probability: finite, in [0, 1] (a NaN is no evidence: 0)."""
    return min(1.0, max(0.0, float(x))) if math.isfinite(x) else 0.0


def most_probable(verdicts: Sequence[PoseProbability], poses: Sequence[StablePose],
                  stage7_best: int | None) -> PoseProbability | None:
    """The most probable pose. A pose's physics counts successes in W worlds, so it tells probabilities apart only
    by more than one world's worth, prior x 1/W: a pose within that of the most probable one (and functional, as it
    is) ties with it. Ties: stage 7's pick, the more probable, more successful worlds, the more probable stable
    pose."""
    if not verdicts:
        return None
    top = max(verdicts, key=lambda v: v.probability)
    step = top.prior / max(top.imagined, 1)  # one world of the top pose's
    tied = [v for v in verdicts if v.probability >= max(top.probability - step, FUNCTIONAL) - 1e-9] or [top]
    return max(tied, key=lambda v: (v.index == stage7_best, v.probability, v.successes,
                                    float(poses[v.index].probability)))
