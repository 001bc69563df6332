"""The evidence of one (object, affordance): every imagined world's rollouts, indexed once by pose and plan.

Up to three batched calls imagine an object for one affordance: the nominal world (every imagined pose × plan),
the perturbed worlds (:func:`rail_mj.imagination.perturb.draw_perturbations`; the candidate plans of the poses
that could be functional) and the second decomposition (every plan of the poses whose verdict it could still
change). Each call appends its worlds to one :class:`ImaginedWorlds`, which knows which poses each world imagined
and translates between the three index spaces once:

- a **pose** is an index into the object's stable poses;
- a **slot** is an index into :attr:`ImaginedWorlds.kept`, the poses that were imagined, in batch order;
- a **rollout** of a world is ``slot_in_world * n_plans + plan`` (pose-major, :func:`rollout_index`).

:mod:`rail_mj.pipeline.verdicts` judges each world once and turns the worlds into each pose's probability.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rail_mj.core.profile import MotionPlan, PoseCandidates
from rail_mj.core.types import Outcomes, StablePose
from rail_mj.imagination.batch import rollout_index
from rail_mj.imagination.perturb import Perturbation, PerturbationSet, scaled_pose, world_trajectory
from rail_mj.imagination.summary import pose_candidates

__all__ = ["World", "ImaginedWorlds", "world_outcomes", "candidate_plans", "fill_perturbed"]


@dataclass
class World:
    """One world's rollouts of the pose ``slots`` it imagined, every plan each (pose-major), with their scores (a
    blown-up rollout scores -1). ``perturbation`` is the world's (nominal for the nominal world and the second
    decomposition); ``label`` names it in a blown-up rollout's reason. ``judged`` holds the verdicts'
    judgement of this world once made (:func:`rail_mj.pipeline.verdicts.judge`): each world is judged once."""

    label: str
    slots: list[int]
    outcomes: Outcomes
    scores: np.ndarray
    perturbation: Perturbation = Perturbation()
    judged: Any = None


@dataclass
class ImaginedWorlds:
    """Every world imagined for one (object, affordance): what the verdicts judge.

    ``affordance`` and ``scale`` name the use as the profile resolved it (the rules' row is
    :func:`rail_mj.affordances.judge.rules_row` of them); ``poses`` are the object's stable poses, ``kept`` the
    ones imagined (slots), ``trajectories[slot][plan]`` each imagined pose's (K, 7) via-poses in the nominal world,
    ``perturbations`` the object's worlds (world 0 nominal).
    """

    affordance: str
    scale: float
    plans: Sequence[MotionPlan]
    poses: Sequence[StablePose]
    kept: list[int]
    trajectories: list[list[np.ndarray]]
    perturbations: PerturbationSet = PerturbationSet()
    worlds: list[World] = field(default_factory=list)
    #: the pose slots the perturbed worlds (any of them) and the second decomposition imagined
    perturbed_slots: list[int] = field(default_factory=list)
    second_slots: list[int] = field(default_factory=list)

    @property
    def n_plans(self) -> int:
        return len(self.plans)

    @property
    def plan_names(self) -> list[str]:
        return [p.name for p in self.plans]

    @property
    def nominal(self) -> World:
        if not self.worlds:
            raise ValueError("no world imagined yet: add_nominal first")
        return self.worlds[0]

    def slot_of(self, pose: int) -> int:
        return self.kept.index(pose)

    def nominal_rollout(self, pose: int, plan: int) -> int:
        """The nominal world's rollout index of ``pose``'s ``plan``."""
        return rollout_index(self.slot_of(pose), plan, self.n_plans)

    def imagined(self, slot: int) -> int:
        """How many worlds imagined the pose in ``slot``."""
        return sum(slot in w.slots for w in self.worlds)

    def add_nominal(self, outcomes: Outcomes, scores: np.ndarray) -> World:
        """The nominal world's rollouts of every kept pose and plan."""
        out, s = world_outcomes(outcomes, scores, 1)[0]
        world = World("the nominal world", list(range(len(self.kept))), out, s)
        self.worlds = [world]
        return world

    def candidate_plans(self, slots: Sequence[int], evidence: Collection[int] = ()) -> list[tuple[int, int]]:
        """The (slot, plan) rollouts the perturbed worlds imagine (:func:`candidate_plans` of the nominal world)."""
        return candidate_plans(self.nominal.scores, slots, self.n_plans, evidence)

    def add_perturbed(self, outcomes: Outcomes, scores: np.ndarray, pairs: Sequence[tuple[int, int]],
                      slots: Sequence[int], first: int = 1) -> None:
        """Perturbed worlds ``first``, ``first + 1``, ... of ``self.perturbations``: their rollouts of the ``pairs``
        (world-major, as one batched call with those worlds gives them); every other plan of the ``slots`` failed in
        the nominal world and counts as failed, as it did there, in each perturbed one (:func:`fill_perturbed`)."""
        n_worlds = outcomes.batch // len(pairs)
        nominal = self.nominal
        full = fill_perturbed((nominal.outcomes, nominal.scores), (outcomes, scores), pairs, slots, self.n_plans,
                              n_worlds)
        for w, (out_w, scores_w) in enumerate(world_outcomes(*full, n_worlds), start=first):
            world = self.perturbations.worlds[w]
            self.worlds.append(World(f"world {w} ({world.doc()})", list(slots), out_w, scores_w, world))
        self.perturbed_slots = sorted({*self.perturbed_slots, *slots})

    def add_second_decomposition(self, outcomes: Outcomes, scores: np.ndarray, slots: Sequence[int]) -> None:
        """One more world: the nominal one on the object's second decomposition, every plan of the ``slots``."""
        out, s = world_outcomes(outcomes, scores, 1)[0]
        self.worlds.append(World("the second decomposition", list(slots), out, s))
        self.second_slots = list(slots)

    def candidates(self, world: World) -> list[PoseCandidates]:
        """``world``'s poses with a candidate (a plan scored above 0), in the world's own frame (the object and the
        plans scaled and shifted with it): what the rules and stage 7 judge."""
        p = world.perturbation
        poses = [scaled_pose(pose, p.scale) for pose in self.poses] if p.scale != 1.0 else self.poses
        trajectories = [[world_trajectory(t, np.asarray(self.poses[self.kept[k]].half_extents), p)
                         for t in self.trajectories[k]] for k in world.slots] if not p.nominal else \
            [self.trajectories[k] for k in world.slots]
        return pose_candidates(self.plans, poses, [self.kept[k] for k in world.slots], world.outcomes, world.scores,
                               trajectories)


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


def candidate_plans(scores: np.ndarray, slots: Sequence[int], n_plans: int,
                    evidence: Collection[int] = ()) -> list[tuple[int, int]]:
    """The (pose slot, plan) rollouts the perturbed worlds imagine again: of the ``slots``
    (:func:`rail_mj.pipeline.verdicts.candidate_slots`),
    each plan that scored above 0 in the nominal world, and the ``evidence`` plans (indices; the kind's pose rules
    read them whatever they scored, :meth:`Kind.evidence_plans`). A perturbation asks whether what succeeded in the
    imagined world still succeeds when the world is a little different; any other plan failed there and is taken
    to fail the same way in every perturbed world (:func:`fill_perturbed`)."""
    grid = np.asarray(scores, dtype=float).reshape(-1, n_plans)
    return [(k, j) for k in slots for j in range(n_plans) if grid[k, j] > 0 or j in evidence]


def _take(outcomes: Outcomes, index: np.ndarray | slice) -> Outcomes:
    """The rollouts ``index`` of ``outcomes`` (every per-rollout array; the segments' names are every rollout's)."""
    fields: dict[str, Any] = {f.name: v[index] if isinstance(v := getattr(outcomes, f.name), np.ndarray) else v
                              for f in dataclasses.fields(outcomes)}
    return Outcomes(**fields)


def fill_perturbed(nominal: tuple[Outcomes, np.ndarray], again: tuple[Outcomes, np.ndarray],
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
