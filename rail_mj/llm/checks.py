"""Semantic checks of stage answers beyond their pydantic schema.

Each check raises :class:`InvalidAnswerError` (or the collaborator's
``FragmentError`` / ``UnsafeCodeError``) with a message that an LLM can act on;
the Anthropic provider sends that message back for a repair round.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import cast

import mujoco
import numpy as np

from rail_mj.affordances.prior import FUNCTIONAL, Prior
from rail_mj.affordances.prototypes import Prototype, describe, extents
from rail_mj.core.errors import LLMError, ScoringRuntimeError
from rail_mj.core.profile import AgentLayout, ScoringCode
from rail_mj.imagination.inputs import via_positions
from rail_mj.llm.schemas import (
    AffordanceAnalysis,
    AgentModel,
    FunctionalPoseRequest,
    FunctionalPoseVerdict,
    MotionPlans,
    ScoringRequest,
    TaskDescription,
    Trajectories,
)
from rail_mj.mjcf import check_fragment

__all__ = [
    "InvalidAnswerError",
    "AgentGeometry",
    "agent_geometry",
    "check_analysis",
    "check_prototypes",
    "check_agent",
    "check_layout",
    "candidate_half_extents",
    "task_half_extents",
    "check_trajectories",
    "check_scoring",
    "check_verdict",
]

#: Largest agent bounding radius relative to the object's largest dimension...
MAX_AGENT_SCALE = 1.5
#: ...or in metres, whichever is larger (human-scale agents test small furniture too: a whole body lying reaches
#: 1.05 m from its hips, Winter's segment lengths for a 1.75 m adult).
MAX_AGENT_RADIUS_M = 1.1
#: Agent masses outside this range (kg) are not plausible for any profile.
MASS_RANGE = (1e-5, 200.0)
#: Via-poses may lie at most this many half extents (plus the layout's size) from the object.
TRAJECTORY_BOUND_H = 3.0
#: Extra room (m) beyond the bound above, for clearances and human-scale heights (seat, table).
TRAJECTORY_MARGIN_M = 1.0


class InvalidAnswerError(LLMError, ValueError):
    """A stage answer parsed but breaks the stage's rules (sizes, spacing, trajectories, verdict)."""


@dataclass(frozen=True)
class AgentGeometry:
    """What the checks need to know about a compiled agent."""

    radius: float  # bounding-sphere radius about the body origin, m
    mass: float  # kg


def agent_geometry(agent: AgentModel) -> AgentGeometry:
    """Validate the fragment (``rail_mj.mjcf.check_fragment``) and measure its bounding radius and mass."""
    model = check_fragment(agent.mjcf).compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    # about the top body's origin, which the trajectories move; all bodies, nested ones included
    radius = float(np.max(np.linalg.norm(data.geom_xpos - data.xpos[1], axis=1) + model.geom_rbound))
    return AgentGeometry(radius=radius, mass=float(model.body_mass[1:].sum()))


def check_analysis(analysis: AffordanceAnalysis, task: TaskDescription) -> None:
    """The analysis must be about the requested affordance and fill in every text; for a task of no obb_dims (a
    profile for every object of the use) it gives the use's sizes and prototypes (a positive inside the sizes and
    a negative), fits is true and there is no alternative; with obb_dims it gives neither."""
    if analysis.affordance.strip().lower() != task.affordance.strip().lower():
        raise InvalidAnswerError(f"analysis is about {analysis.affordance!r}; it must analyse {task.affordance!r}")
    empty = [n for n in ("reason", "ibd", "agent_description", "interaction_description", "expected_outcome")
             if not getattr(analysis, n).strip()]
    if empty:
        raise InvalidAnswerError(f"analysis fields must not be empty: {', '.join(empty)}")
    if task.obb_dims is not None:
        if analysis.sizes is not None or analysis.prototypes:
            raise InvalidAnswerError("the task gives the object's obb_dims: sizes must be null and prototypes [] "
                                     "(they are for a profile that serves every object of the use)")
        return
    if analysis.sizes is None:
        raise InvalidAnswerError("the task has no obb_dims, so the profile serves every object of the use: give "
                                 "sizes, the typical largest and smallest OBB dims of its objects with their basis")
    if not analysis.fits or analysis.alternative is not None:
        raise InvalidAnswerError("the task has no obb_dims: there is no object to check, so fits must be true and "
                                 "alternative null (each object is weighed by sizes)")
    sizes = analysis.sizes
    check_prototypes(analysis.prototypes, lambda p: sizes.prior(extents(p)), "sizes")


def check_prototypes(prototypes: Sequence[Prototype], prior: Callable[[Prototype], Prior], sizes: str) -> None:
    """At least one positive and one near-miss negative prototype, each positive inside the typical ``sizes`` (its
    ``prior`` at least FUNCTIONAL): what a model-written row or profile is proven on."""
    roles = [p.role for p in prototypes]
    if "positive" not in roles or "negative" not in roles:
        raise InvalidAnswerError(f"prototypes must hold at least one positive and one near-miss negative prototype; "
                                 f"got roles {roles}")
    for p in prototypes:
        value = prior(p)
        if p.role == "positive" and value.value < FUNCTIONAL:
            raise InvalidAnswerError(f"the positive prototype {describe(p)} is not inside {sizes} (prior "
                                     f"{value.value:.2f} < {FUNCTIONAL:g}: {value.doc()}); give one that is")


def task_half_extents(task: TaskDescription, analysis: AffordanceAnalysis | None) -> list[np.ndarray]:
    """The half extents an answer is checked for: the object's box in each axis-aligned orientation, or, for a
    task of no obb_dims, each extreme typical box of the analysis's sizes in each orientation."""
    if task.obb_dims is not None:
        return candidate_half_extents(list(task.obb_dims))
    if analysis is None or analysis.sizes is None:
        raise InvalidAnswerError("the task has no obb_dims and the analysis no sizes: nothing to check against")
    return [h for box in analysis.sizes.boxes() for h in candidate_half_extents(box)]


def check_agent(agent: AgentModel, task: TaskDescription, analysis: AffordanceAnalysis | None = None) -> AgentGeometry:
    """Fragment rules plus a size and mass plausible for the object (for every object of the use: its largest
    typical size)."""
    geometry = agent_geometry(agent)
    largest = 2 * max(float(h.max()) for h in task_half_extents(task, analysis))  # the object's, or the sizes' hi
    limit = max(MAX_AGENT_SCALE * largest, MAX_AGENT_RADIUS_M)
    if not 0.001 <= geometry.radius <= limit:
        raise InvalidAnswerError(
            f"agent bounding radius {geometry.radius:.4f} m is out of scale for an object of largest dimension "
            f"{largest:.3f} m; valid: 0.001 m to {limit:.3f} m"
        )
    if not MASS_RANGE[0] <= geometry.mass <= MASS_RANGE[1]:
        raise InvalidAnswerError(
            f"agent mass {geometry.mass:.6g} kg is not plausible; valid: {MASS_RANGE[0]} to {MASS_RANGE[1]} kg "
            "(give every geom an explicit mass)"
        )
    return geometry


def check_layout(layout: AgentLayout, radius: float) -> None:
    """Neighbouring agents must not overlap: spacing ≥ agent diameter on every axis with more than one agent."""
    tight = [
        f"{axis} (spacing {s:.4f} m < diameter {2 * radius:.4f} m)"
        for axis, n, s in (("x", layout.nx, layout.sx), ("y", layout.ny, layout.sy), ("z", layout.nz, layout.sz))
        if n > 1 and s < 2 * radius
    ]
    if tight:
        raise InvalidAnswerError(f"agents overlap along {', '.join(tight)}; make the spacing at least the diameter")


def candidate_half_extents(obb_dims: list[float]) -> list[np.ndarray]:
    """Half extents of the object's box in each axis-aligned orientation (each dimension vertical once)."""
    half = np.asarray(obb_dims, dtype=float) / 2.0
    seen: dict[tuple[float, ...], np.ndarray] = {}
    for perm in itertools.permutations(range(3)):
        h = half[list(perm)]
        seen.setdefault(tuple(np.round(h, 9)), h)
    return list(seen.values())


def check_trajectories(
    trajectories: Trajectories,
    plans: MotionPlans,
    radius: float,
    offsets: np.ndarray,
    half_extents: list[np.ndarray],
) -> None:
    """One finite, bounded trajectory per plan whose start keeps every agent outside the box and above ground."""
    plan_names = [p.name for p in plans.plans]
    traj_names = [t.plan for t in trajectories.trajectories]
    if traj_names != plan_names:
        raise InvalidAnswerError(
            f"give one trajectory per plan in the same order: expected {plan_names}, got {traj_names}"
        )
    spread = np.max(np.abs(offsets), axis=0) + radius  # half size of the whole grid
    for traj in trajectories.trajectories:
        quats = np.array([v.quat for v in traj.via_poses], dtype=float)
        if not np.all(np.isfinite(quats)) or np.any(np.abs(np.linalg.norm(quats, axis=1) - 1.0) > 1e-3):
            raise InvalidAnswerError(f"plan {traj.plan!r}: every quat must be a finite unit quaternion (w, x, y, z)")
        for h in half_extents:
            pos = via_positions(traj.via_poses, h)
            where = f"plan {traj.plan!r} with half extents h={np.round(h, 4).tolist()}"
            if not np.all(np.isfinite(pos)):
                raise InvalidAnswerError(f"{where}: via-poses must be finite numbers")
            bound = TRAJECTORY_BOUND_H * float(np.max(h)) + float(np.max(spread)) + TRAJECTORY_MARGIN_M
            far = np.linalg.norm(pos, axis=1) > bound
            if np.any(far):
                raise InvalidAnswerError(
                    f"{where}: via-pose {int(np.argmax(far))} is {np.linalg.norm(pos[far][0]):.3f} m from the object "
                    f"centre; keep every via-pose within {bound:.3f} m"
                )
            start = pos[0]
            lo, hi = start - spread, start + spread
            if np.all(hi > -h) and np.all(lo < h):
                raise InvalidAnswerError(
                    f"{where}: the agent grid at the start (centre {np.round(start, 4).tolist()} m, half size "
                    f"{np.round(spread, 4).tolist()} m) overlaps the object's box [-h, h]; start outside it"
                )
            if lo[2] <= -h[2]:
                raise InvalidAnswerError(
                    f"{where}: the agent grid at the start reaches z={lo[2]:.4f} m, at or below the ground "
                    f"z={-h[2]:.4f} m; start above the ground"
                )


def check_scoring(scoring: ScoringCode, request: ScoringRequest) -> None:
    """The scoring sandbox's static check, then a run on a synthetic batch of the real shapes.

    The batch (:func:`rail_mj.scoring.probe_outcomes`) has the request's number of agents and plans over
    every axis-aligned orientation of its object's box; the code must return one finite score per rollout.
    """
    from rail_mj.scoring import WorkerStartError, compile_scoring, probe_outcomes

    score = compile_scoring(scoring.source)
    outcomes = probe_outcomes(request.layout.n_agents, len(request.plans.plans),  # each row: 3 half extents
                              cast(Sequence[Sequence[float]], task_half_extents(request.task, request.analysis)))
    try:
        score(outcomes)
    except WorkerStartError:
        raise  # the machine's problem: no repair round can fix it
    except ScoringRuntimeError as exc:
        shapes = ", ".join(f"{name} {a.dtype} {a.shape}" for name, a in outcomes.scoring_kwargs().items())
        raise InvalidAnswerError(
            f"score fails when run on a synthetic batch of B={outcomes.batch} rollouts x N={outcomes.n_agents} "
            f"agents shaped like the real input ({shapes}): {exc}. Fix the code so that it runs on any such batch "
            f"and returns a float array of shape (B,)"
        ) from exc


def check_verdict(verdict: FunctionalPoseVerdict, request: FunctionalPoseRequest) -> None:
    """One verdict per pose; the best (pose, plan) must be an accepted candidate."""
    expected = [p.pose_index for p in request.poses]
    got = [v.pose_index for v in verdict.poses]
    if got != expected:
        raise InvalidAnswerError(f"give one verdict per pose in the same order: expected {expected}, got {got}")
    accepted = {v.pose_index: v.plan for v in verdict.poses if v.accept}
    plans = {p.pose_index: {c.plan for c in p.candidates} for p in request.poses}
    for v in verdict.poses:
        if v.accept and v.plan not in plans[v.pose_index]:
            raise InvalidAnswerError(
                f"pose {v.pose_index} is accepted with plan {v.plan!r}; valid: {sorted(plans[v.pose_index])}"
            )
    if verdict.best_pose is None:
        if accepted:
            raise InvalidAnswerError(f"poses {sorted(accepted)} are accepted, so best_pose must be one of them")
        return
    if verdict.best_pose not in accepted or verdict.best_plan not in plans[verdict.best_pose]:
        raise InvalidAnswerError(
            f"best (pose {verdict.best_pose}, plan {verdict.best_plan!r}) must be an accepted pose and one of its "
            f"candidate plans; accepted: {accepted}"
        )
