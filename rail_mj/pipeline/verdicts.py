"""Per-pose verdicts as probabilities: a size prior times what the physics says under perturbation.

For each imagined stable pose of an object (a pose whose prior is below :data:`rail_mj.affordances.prior.NEGLIGIBLE` is
not imagined: its probability stays below it whatever its physics), with ``W`` worlds (the nominal one, K perturbed
ones, :mod:`rail_mj.imagination.perturb`, and the second decomposition where it matters)::

    physics(pose)     = #{worlds in which the pose succeeds} / W
    probability(pose) = size_prior(object's OBB) * pose_prior(pose's box, its basin's rim)
                        * rest_prior(where its best plan's agent came to rest) * physics(pose)

A pose succeeds in a world when the Functional Pose Analyzer's rules accept it there
(:func:`rail_mj.affordances.judge.judge_pose`: the kind's rules on each candidate, a rollout that scored above 0 and did
not blow up, then the pose's rules on its candidates together, which may need several plans: a seat's centre and area, a
table top's two placements); a world whose agent is resized is judged, where the kind's rules read the agent's size
(``Kind.rules_read_agent_size``: a body's reach), by the row scaled for that agent. Its best plan is the plan accepted
in the most worlds (ties: stage 7's plan for the pose, then the better nominal score). Each world is judged once
(:func:`judge` keeps its judgement on the world). A rollout that blew up (``Outcomes.unstable``: a non-finite state or a
MuJoCo instability warning) is a failure and is named. The nominal world imagines every pose and plan; the K perturbed
worlds imagine again the candidates (the plans that scored above 0,
:func:`rail_mj.imagination.worlds.candidate_plans`), and the plans the kind's pose rules read whatever they scored
(``Kind.evidence_plans``: every pour, for a leak; a bench's places side by side), of the poses with a candidate whose
prior is at least :data:`rail_mj.affordances.prior.FUNCTIONAL` (and that a model's stage 7 did not veto): a pose
without a candidate has no success to confirm (its physics is 0), and one with a smaller prior stays below it whatever
its physics, so its verdict cannot change (its physics is the nominal world's, 0 or 1). They are drawn a few at a time
(:func:`next_worlds`), each round one batched call: a pose goes on while the worlds left could still turn its verdict
either way, and while another pose could pass too (their counts of every world say which is the more probable); it
stops once they cannot, and its physics is then its successes over the worlds it was imagined in. Stopping never
changes a verdict (functional or not, and which pose) from the one every world would have given, the second
decomposition counted as a world still to come; it changes the probability's value, an estimate over fewer worlds
(``imagined`` says how many). A perturbation asks whether what succeeded still succeeds in a slightly
different world: any other plan failed in the nominal world and counts as failed, as it did there, in each perturbed one
(:func:`rail_mj.imagination.worlds.fill_perturbed`). Where the use rests in the object's concavities (a kind's
``decomposition_matters``), one more world imagines again, on the object's second decomposition
(:func:`rail_mj.mesh.second_decomposition`: CoACD's other concavity threshold), every plan of the poses whose verdict it
could still change (:func:`undecided`; its hulls may let a plan that failed on the first ones succeed), in a third
batched call (its hulls differ in number and shape, so it cannot share the perturbed worlds' model layout). ``W`` is the
number of worlds a pose was imagined in. With an LLM provider, a pose its stage 7 rejected in the nominal world has
physics 0: common sense vetoes what the rules would let through. The priors are :meth:`Affordance.size_prior`,
:meth:`Affordance.pose_prior` and, for a seat or a bed, :meth:`Affordance.rest_prior` of the median height (at the
object's nominal scale) at which the best plan's agent came to rest in the worlds that accepted it: the envelope's
``rest`` window is a prior like its box sizes, and the rules refuse only a rest height past
:meth:`Affordance.rest_limits` (1 for an affordance outside the registry).

The result's ``probability`` is the largest pose probability; the result is functional when it is at least
:data:`rail_mj.affordances.prior.FUNCTIONAL`, and its functional pose is the most probable pose, where a pose within one
world's worth of it (prior / W: a count of W worlds tells no finer) is as probable (ties: stage 7's pick in the nominal
world, then the more probable, then the pose that succeeds in more worlds, then the more probable stable pose). Every
probability is finite and in [0, 1].
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from rail_mj.affordances import Affordance
from rail_mj.affordances.judge import judge_pose, rules_row, world_row
from rail_mj.affordances.kinds import kind_of
from rail_mj.affordances.prior import FUNCTIONAL, Factor, Prior
from rail_mj.affordances.sizes import UseSizes
from rail_mj.core.profile import FunctionalPoseVerdict
from rail_mj.core.results import PoseProbability
from rail_mj.core.types import StablePose
from rail_mj.imagination.worlds import ImaginedWorlds, World

__all__ = ["candidate_slots", "undecided", "next_worlds", "pose_prior", "judge", "most_probable"]

#: a world's judgement: per pose with a candidate, the plans the rules accept, each with its agent's rest height
#: (at the world's scale) where the kind measures one
Accepted = dict[int, dict[str, float | None]]


def candidate_slots(scores: np.ndarray, n_kept: int, n_plans: int,
                    priors: Sequence[float] | None = None) -> list[int]:
    """The imagined poses (slots into ``kept``) with a candidate in the nominal world (a plan scored above 0) and,
    given their ``priors``, a prior of at least FUNCTIONAL: the ones the perturbed worlds imagine again. A pose
    without a candidate has no success to confirm; one with a smaller prior stays below FUNCTIONAL whatever
    the physics."""
    grid = np.asarray(scores, dtype=float).reshape(n_kept, n_plans)
    return [k for k in range(n_kept) if np.any(grid[k] > 0) and (priors is None or priors[k] >= FUNCTIONAL)]


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


def next_worlds(verdicts: Sequence[PoseProbability], slots: Sequence[int], upper: Sequence[float], most: int,
                perturbed: int, prior_final: bool) -> list[tuple[list[int], int, int]]:
    """The next perturbed worlds worth imagining for the pose ``slots`` (into the imagined poses, whose ``verdicts``
    these are, in order; the poses with a candidate): groups of (slots, first world, how many worlds in a row),
    none when no world left could change a verdict.

    A pose imagined so far in ``n`` worlds (the nominal one and perturbed worlds 1 .. n - 1, of ``perturbed``) with
    ``s`` successes can be imagined in at most ``most - n`` more (``most``: the nominal world, every perturbed one
    and the second decomposition where it may run). Its verdict can still pass FUNCTIONAL when
    ``upper x (s + most - n) / most`` does (``upper[k]``: its prior without a rest prior, which is at most 1) and
    is sure to when ``prior x s / most`` does, whatever the worlds left show (only where the prior is final,
    ``prior_final``: a rest prior moves with each world's rest height). The poses that can but are not sure to
    pass go on, together, for as many worlds as no outcome of fewer could decide one of them. Once none is left (the
    second decomposition, when it is still to come for one, imagined first), and two poses or more can pass, those
    go on to the last perturbed world: which of them is most probable reads their counts of every world. Every other
    pose stops: its verdict is the same whatever the worlds left would show, and its physics is ``s / n`` over the
    worlds it was imagined in (``PoseProbability.imagined``)."""
    # each bound is computed as judge computes a probability, prior * (successes / worlds): a count of successes
    # over worlds that is at least (at most) the bound's as a fraction is so as a float, exactly
    def bounds(k: int) -> tuple[float, float, int, int, int]:
        v = verdicts[k]
        return (v.prior if prior_final else 0.0), upper[k], v.successes, most - v.imagined, perturbed + 1 - v.imagined

    def can_pass(k: int) -> bool:
        _, hi, s, rest, _ = bounds(k)
        return hi * ((s + rest) / most) >= FUNCTIONAL

    def sure(k: int) -> bool:
        lo, _, s, _, _ = bounds(k)
        return lo * (s / most) >= FUNCTIONAL

    def worlds_to_decide(k: int) -> int:
        """The fewest next worlds after which the pose could be decided (all of them succeeding, or failing)."""
        lo, hi, s, rest, left = bounds(k)
        return next((j for j in range(1, left) if lo * ((s + j) / most) >= FUNCTIONAL
                     or hi * ((s + rest - j) / most) < FUNCTIONAL), left)

    could = [k for k in slots if can_pass(k)]
    undecided_ = [k for k in could if not sure(k)]
    # the undecided poses have gone on together since the nominal world: one first world
    going = [k for k in undecided_ if bounds(k)[4] > 0]
    if going:
        return [(going, verdicts[going[0]].imagined, min(worlds_to_decide(k) for k in going))]
    if len(could) < 2 or any(bounds(k)[3] > 0 for k in undecided_):
        return []  # one pose can pass; or the second decomposition, still to come, may rule one out first
    at: dict[int, list[int]] = {}
    for k in could:
        if bounds(k)[4] > 0:
            at.setdefault(verdicts[k].imagined, []).append(k)
    return [(ks, first, perturbed + 1 - first) for first, ks in sorted(at.items())]


def pose_prior(aff: Affordance | None, obb_dims: Sequence[float] | np.ndarray, pose: StablePose,
               sizes: UseSizes | None = None, design: tuple[str, float] | None = None) -> Prior:
    """One pose's prior: the size prior of the object's OBB times the pose's envelope prior (its basin's rim for
    a vessel's aspect); for an affordance outside the registry, the ``sizes`` of its profile for every object
    (no factor without them); times ``design``, the probability that the object was made to stand in the pose
    (:func:`rail_mj.stable_poses.came_in.design_factors`: words and a number), when there is evidence of it."""
    made = Prior((Factor.said(*design),)) if design is not None else Prior()
    if aff is None:
        return (sizes.prior(obb_dims) if sizes is not None else Prior()) * made
    basin = pose.basin
    return aff.size_prior([float(d) for d in obb_dims]) * aff.pose_prior(
        [float(v) for v in pose.half_extents], None if basin is None else basin.rim,
        None if basin is None else basin.floor) * made


def _judged(evidence: ImaginedWorlds, world: World) -> Accepted:
    """``world`` judged by the rules, once: per pose with a candidate, the plans accepted and their rest heights."""
    if world.judged is None:
        aff = world_row(evidence.affordance, evidence.scale, world.perturbation.agent_size)
        kind = kind_of(aff) if aff is not None else None
        out: Accepted = {}
        for pc in evidence.candidates(world):
            h = list(pc.half_extents)
            out[pc.pose_index] = {c.plan: kind.rest_height(aff, c, h) if kind is not None and aff is not None
                                  else None for c in judge_pose(aff, pc)[0]}
        world.judged = out
    return world.judged


def _blown(world: World, names: Sequence[str]) -> dict[int, list[str]]:
    """Per pose slot: the plans that blew up in ``world``, in words."""
    out: dict[int, list[str]] = {}
    if world.outcomes.unstable is not None:
        for b in np.nonzero(world.outcomes.unstable)[0]:
            k, j = divmod(int(b), len(names))
            out.setdefault(world.slots[k], []).append(f"plan {names[j]!r} blew up in {world.label}")
    return out


def judge(evidence: ImaginedWorlds, obb_dims: Sequence[float] | np.ndarray,
          stage7: FunctionalPoseVerdict | None = None, llm_veto: bool = False,
          sizes: UseSizes | None = None,
          design: Sequence[tuple[str, float] | None] | None = None) -> list[PoseProbability]:
    """One :class:`PoseProbability` per imagined pose (``evidence.kept``, in that order), from every world of the
    ``evidence``, each judged once by the rules (:func:`rail_mj.affordances.judge.judge_pose`).

    ``obb_dims`` are the object's (its size prior; ``sizes``: a profile's for every object of a use outside the
    registry, :func:`pose_prior`); ``design`` per stable pose, the probability that the object was made to stand in
    it where there is evidence (:func:`pose_prior`). ``stage7`` is the provider's verdict on the nominal world: its
    plan for a pose breaks a tie between plans; with ``llm_veto`` (a model's answer, not the rules' own), a pose it
    rejected has physics 0: common sense vetoes what the rules would let through. Here the model's answer and the
    rules meet.
    """
    aff = rules_row(evidence.affordance, evidence.scale)
    names = evidence.plan_names
    n_kept = len(evidence.kept)
    wins: list[dict[str, int]] = [{} for _ in range(n_kept)]
    rests: list[dict[str, list[float]]] = [{} for _ in range(n_kept)]  # per plan: rest heights at the nominal scale
    worlds_ok = np.zeros(n_kept, dtype=np.int64)
    blew_up: list[list[str]] = [[] for _ in range(n_kept)]
    slot = {i: k for k, i in enumerate(evidence.kept)}
    for world in evidence.worlds:
        for i, plans_ok in _judged(evidence, world).items():
            if plans_ok:
                worlds_ok[slot[i]] += 1
                for name, rest in plans_ok.items():
                    wins[slot[i]][name] = wins[slot[i]].get(name, 0) + 1
                    if rest is not None:
                        rests[slot[i]].setdefault(name, []).append(rest / world.perturbation.scale)
        for k, lines in _blown(world, names).items():
            blew_up[k] += lines
    stage7_plans = {v.pose_index: v.plan for v in stage7.poses} if stage7 is not None else {}
    vetoed = ({v.pose_index for v in stage7.poses if not v.accept} if llm_veto and stage7 is not None else set())
    scores0 = evidence.nominal.scores
    second = set(evidence.second_slots)
    out = []
    for k, i in enumerate(evidence.kept):
        successes = 0 if i in vetoed else int(worlds_ok[k])
        # ties: stage 7's plan for the pose, then the better nominal score
        chosen, row = stage7_plans.get(i), scores0[k * len(names) : (k + 1) * len(names)]
        best = (max(wins[k], key=lambda name: (wins[k][name], name == chosen, float(row[names.index(name)])))
                if successes else None)
        p = pose_prior(aff, obb_dims, evidence.poses[i], sizes, design[i] if design is not None else None)
        if aff is not None and best is not None and rests[k].get(best):
            p = p * aff.rest_prior(float(np.median(rests[k][best])))
        prior = p.value
        doc = p.doc() if aff is not None or sizes is not None else "outside the registry: no size prior"
        imagined = evidence.imagined(k)
        physics = successes / imagined
        out.append(PoseProbability(
            index=i, prior=_unit(prior), prior_factors=doc, physics=_unit(physics),
            probability=_unit(prior * physics), best_plan=best, successes=successes,
            worlds=evidence.perturbations.n_worlds + (k in second), imagined=imagined, blew_up=blew_up[k],
        ))
    return out


def _unit(x: float) -> float:
    """``x`` as a probability: finite, in [0, 1] (a NaN is no evidence: 0)."""
    return min(1.0, max(0.0, float(x))) if math.isfinite(x) else 0.0


def most_probable(verdicts: Sequence[PoseProbability], poses: Sequence[StablePose],
                  stage7_best: int | None, common: float = 1.0) -> PoseProbability | None:
    """The most probable pose. A pose's physics counts successes in W worlds, so it tells probabilities apart only
    by more than one world's worth, prior x 1/W: a pose within that of the most probable one (and functional, as it
    is) ties with it. ``common`` is a factor every pose's prior carries alike (an object of unknown up's,
    :func:`rail_mj.stable_poses.came_in.common_factor`): it says nothing of which pose, so a tied pose is functional
    with it taken out. Ties: stage 7's pick, the more probable, more successful worlds, the more probable stable
    pose."""
    if not verdicts:
        return None
    top = max(verdicts, key=lambda v: v.probability)
    step = top.prior / max(top.imagined, 1)  # one world of the top pose's
    floor = FUNCTIONAL * min(1.0, max(common, 0.0))
    tied = [v for v in verdicts if v.probability >= max(top.probability - step, floor) - 1e-9] or [top]
    return max(tied, key=lambda v: (v.index == stage7_best, v.probability, v.successes,
                                    float(poses[v.index].probability)))
