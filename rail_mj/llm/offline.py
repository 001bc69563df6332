"""The offline provider: the stages' answers from the affordance registry and its kinds of physics.

What an affordance is (name, kind, definition, sizes, pose envelope) lives in
:mod:`rail_mj.affordances.registry`; how its kind is imagined (agent, layout,
plans, via-poses, scoring source) in :mod:`rail_mj.affordances.kinds`; the Functional Pose Analyzer's rules in
:mod:`rail_mj.affordances.judge`, which stage 7 here only wraps. This module turns a stage request into the
same typed answer an LLM stage returns; the answers also serve as the LLM
prompts' few-shot examples.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pydantic import BaseModel

from rail_mj.affordances import REGISTRY, Affordance, get, kinds, known_affordances
from rail_mj.affordances import normalize as normalize_affordance
from rail_mj.affordances.judge import functional_poses
from rail_mj.affordances.names import parse_words
from rail_mj.affordances.prior import FUNCTIONAL
from rail_mj.core.errors import ConfigError
from rail_mj.core.profile import AgentLayout, PlanTrajectory, ScoringCode
from rail_mj.llm.schemas import (
    AffordanceAnalysis,
    AgentModel,
    AgentModelRequest,
    AnalyzerRequest,
    FunctionalPoseRequest,
    FunctionalPoseVerdict,
    LayoutRequest,
    MotionPlans,
    PlannerRequest,
    Request,
    RequestText,
    ScoringRequest,
    TaskDescription,
    Trajectories,
    TrajectoryRequest,
)

__all__ = [
    "known_affordances",
    "normalize_affordance",
    "offline_analysis",
    "offline_agent",
    "offline_layout",
    "offline_plans",
    "offline_trajectories",
    "offline_scoring",
    "offline_functional_poses",
    "offline_request",
    "ANSWERS",
    "answer",
]


def _row(task: TaskDescription) -> Affordance:
    """The task's registry row at the task's agent scale (a doll's chair: every size × 0.18)."""
    return get(task.affordance).scaled(task.scale)


def _dims(task: TaskDescription) -> list[float]:
    """The task's object dims: the library's profiles are made for an object (a task of none is a model's)."""
    if task.obb_dims is None:
        raise ConfigError(f"the offline library writes {task.affordance!r}'s profile for an object's obb_dims; a "
                          "profile for every object of a use (obb_dims null) is written by a model")
    return list(task.obb_dims)


def _resolve(task: TaskDescription) -> tuple[Affordance, kinds.Kind, kinds.AgentShape]:
    """The task's registry row, its kind and the kind's agent scaled to the object."""
    aff = _row(task)
    kind = kinds.kind_of(aff)
    return aff, kind, kind.agent(aff, _dims(task))


def offline_analysis(task: TaskDescription) -> AffordanceAnalysis:
    """Stage 1: the size prior against real-world typical ranges (:meth:`Affordance.dims_prior`), IBD and
    outline. The dims fit when the prior is at least :data:`~rail_mj.affordances.prior.FUNCTIONAL`; when they do
    not, the alternative is the row of the same kind whose prior is the highest of those that fit (the paper's
    first), and the chain still imagines the requested use unless its prior is negligible."""
    aff = _row(task)
    kind = kinds.kind_of(aff)
    dims = _dims(task)
    prior = aff.dims_prior(dims)
    fits = prior.value >= FUNCTIONAL
    sizes = f"{dims[0]:.3f} x {dims[1]:.3f} x {dims[2]:.3f} m"
    alternative = None
    if fits:
        reason = f"The object ({sizes}) is plausible as a {aff.name}: {prior.doc()}."
    else:
        priors = [(a.dims_prior(dims).value, a.paper, a.name) for a in (r.scaled(task.scale) for r in REGISTRY.values())
                  if a.kind == aff.kind and a.name != aff.name]
        fitting = [p for p in priors if p[0] >= FUNCTIONAL]
        if fitting:
            alternative = max(fitting, key=lambda p: (p[1], p[0]))[2]
        reason = (f"The object ({sizes}) is unusual for a {aff.name}: {prior.doc()}. "
                  + (f"Its size fits a {alternative}." if alternative else "No similar affordance fits its size."))
    return AffordanceAnalysis(
        affordance=task.affordance,
        fits=fits,
        reason=reason,
        alternative=alternative,
        ibd=aff.ibd,
        agent_description=kind.agent_description,
        interaction_description=kind.interaction_description,
        expected_outcome=kind.expected_outcome.format(name=aff.name),
    )


def offline_agent(task: TaskDescription) -> AgentModel:
    """Stage 2: the kind's agent as an MJCF fragment (one body of one geom, or the kind's articulated body),
    scaled to the object."""
    _, kind, shape = _resolve(task)
    xml = shape.fragment or (f'<mujoco><worldbody><body name="{shape.label}">'
           f'<geom name="{shape.label}_geom" {shape.geom} mass="{shape.mass:.6g}" rgba="0.2 0.5 0.9 1"/>'
           "</body></worldbody></mujoco>")
    return AgentModel(name=shape.label, description=kind.agent_description, mjcf=xml)


def offline_layout(task: TaskDescription) -> AgentLayout:
    """Stage 3: the kind's grid of agents (droplets in a 3×3×3 grid; one agent otherwise)."""
    _, kind, shape = _resolve(task)
    return kind.layout(shape)


def offline_plans(task: TaskDescription) -> MotionPlans:
    """Stage 4: five or six plans from above and from the four sides."""
    _, kind, shape = _resolve(task)
    return MotionPlans(plans=kind.plans(shape))


def offline_trajectories(task: TaskDescription, layout: AgentLayout) -> Trajectories:
    """Stage 5: via-poses of the layout centre for each plan of :func:`offline_plans`."""
    _, kind, shape = _resolve(task)
    return Trajectories(trajectories=[PlanTrajectory(plan=p.name, via_poses=kind.via_poses(p.name, shape, layout))
                                      for p in kind.plans(shape)])


def offline_scoring(task: TaskDescription) -> ScoringCode:
    """Stage 6: vectorised numpy scoring source of the kind's physics (constants baked in; sizes are priors)."""
    aff, kind, shape = _resolve(task)
    return kind.scoring(aff, shape)


def offline_functional_poses(request: FunctionalPoseRequest) -> FunctionalPoseVerdict:
    """Stage 7 by the rules (:func:`rail_mj.affordances.judge.functional_poses`), the judge every provider's
    verdicts meet."""
    return functional_poses(request.affordance, request.scale, request.poses)


def offline_request(request: RequestText) -> Request:
    """The request parser by rules (:func:`rail_mj.affordances.names.parse_words`)."""
    words = parse_words(request.text)
    return Request(text=request.text, agent=words.agent, affordance=words.affordance, preposition=words.preposition,
                   owner=words.owner)


#: The offline answer to each request type (looked up by name when called, so a patched function answers).
ANSWERS: dict[type[BaseModel], Callable[[Any], BaseModel]] = {
    AnalyzerRequest: lambda r: offline_analysis(r.task),
    AgentModelRequest: lambda r: offline_agent(r.task),
    LayoutRequest: lambda r: offline_layout(r.task),
    PlannerRequest: lambda r: offline_plans(r.task),
    TrajectoryRequest: lambda r: offline_trajectories(r.task, r.layout),
    ScoringRequest: lambda r: offline_scoring(r.task),
    FunctionalPoseRequest: lambda r: offline_functional_poses(r),
    RequestText: lambda r: offline_request(r),
}


def answer(request: BaseModel) -> BaseModel:
    """The offline library's answer to a stage request (:data:`ANSWERS`); ConfigError for any other request."""
    handler = next((ANSWERS[t] for t in type(request).__mro__ if t in ANSWERS), None)
    if handler is None:
        raise ConfigError(f"the offline provider has no answer for a {type(request).__name__}")
    return handler(request)
