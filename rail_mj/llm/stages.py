"""The seven stages as functions (a pydantic request and a provider in, a validated pydantic answer out).

Every stage runs through a provider (offline library or LLM) with its check;
the provider carries its settings (retries, cache, model), fixed when it is
made. :func:`task_description` resolves the affordance name once, through the
provider; :func:`task_profile` chains stages 1–6 into an
:class:`ImaginationProfile` and :func:`generate_profile` does both. Stage 7's
request wraps the rollouts' pose candidates (:func:`functional_pose_request`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from rail_mj.affordances.files import FileRow, parse
from rail_mj.affordances.judge import rules_row
from rail_mj.affordances.names import owner_scale
from rail_mj.affordances.prior import Prior
from rail_mj.affordances.prototypes import Prototype, extents
from rail_mj.core.errors import AffordanceFileError, ConfigError, UnknownAffordanceError
from rail_mj.core.profile import AgentLayout, PoseCandidates, PoseShape, ScoringCode
from rail_mj.imagination.inputs import layout_offsets
from rail_mj.llm.checks import (
    InvalidAnswerError,
    agent_geometry,
    check_agent,
    check_analysis,
    check_layout,
    check_prototypes,
    check_scoring,
    check_trajectories,
    check_verdict,
    task_half_extents,
)
from rail_mj.llm.pictures import Picture
from rail_mj.llm.prompts import PROMPT_VERSION, STAGES
from rail_mj.llm.providers import Provider, get_provider
from rail_mj.llm.schemas import (
    AffordanceAnalysis,
    AffordanceDefinition,
    AgentModel,
    AgentModelRequest,
    AnalyzerRequest,
    DefinitionRequest,
    FunctionalPoseRequest,
    FunctionalPoseVerdict,
    ImaginationProfile,
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
    "define_affordance",
    "definition_row",
    "analyze_affordance",
    "generate_agent_model",
    "generate_layout",
    "plan_motions",
    "generate_trajectories",
    "generate_scoring",
    "analyze_functional_poses",
    "task_description",
    "use_task",
    "task_profile",
    "generate_profile",
    "functional_pose_request",
    "parse_request_text",
]

ProviderLike = str | Provider


def _provider(provider: ProviderLike) -> Provider:
    return get_provider(provider) if isinstance(provider, str) else provider


def analyze_affordance(request: AnalyzerRequest, provider: ProviderLike = "offline") -> AffordanceAnalysis:
    """Stage 1: dimension check (+ alternative), IBD, agent / interaction / outcome outline."""
    return _provider(provider).answer(STAGES["affordance_analyzer"], request,
                                      lambda a: check_analysis(a, request.task))


def generate_agent_model(request: AgentModelRequest, provider: ProviderLike = "offline") -> AgentModel:
    """Stage 2: the agent as a one-body, joint-free MJCF fragment scaled to the object."""
    return _provider(provider).answer(STAGES["agent_model"], request,
                                      lambda a: check_agent(a, request.task, request.analysis))


def generate_layout(request: LayoutRequest, provider: ProviderLike = "offline") -> AgentLayout:
    """Stage 3: grid counts and spacing that keep agents apart."""
    radius = agent_geometry(request.agent).radius
    return _provider(provider).answer(STAGES["agent_configuration"], request, lambda a: check_layout(a, radius))


def plan_motions(request: PlannerRequest, provider: ProviderLike = "offline") -> MotionPlans:
    """Stage 4: at least five language plans with distinct names."""

    def check(plans: MotionPlans) -> None:
        names = [p.name for p in plans.plans]
        if len(set(names)) != len(names):
            raise InvalidAnswerError(f"plan names must be distinct; got {names}")

    return _provider(provider).answer(STAGES["motion_planner"], request, check)


def generate_trajectories(request: TrajectoryRequest, provider: ProviderLike = "offline", *,
                          half_extents: Sequence[Sequence[float]] | np.ndarray | None = None) -> Trajectories:
    """Stage 5: via-poses per plan, checked for each pose's half extents.

    ``half_extents`` (P, 3) are the object's half extents in its stable poses (what the
    check tests, not a provider setting); without them every axis-aligned orientation of
    the OBB is checked.
    """
    if half_extents is None:
        poses = task_half_extents(request.task, request.analysis)
    else:
        arr = np.asarray(half_extents, dtype=float).reshape(-1, 3)
        if arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
            raise ConfigError(f"half_extents must be positive finite (P, 3) values; got {arr.tolist()}")
        poses = list(arr)
    radius = agent_geometry(request.agent).radius
    offsets = layout_offsets(request.layout)
    return _provider(provider).answer(
        STAGES["trajectory"], request, lambda t: check_trajectories(t, request.plans, radius, offsets, poses)
    )


def generate_scoring(request: ScoringRequest, provider: ProviderLike = "offline",
                     prove: Callable[[ScoringCode], None] | None = None) -> ScoringCode:
    """Stage 6: numpy scoring source accepted by the scoring sandbox and run there on a synthetic batch; ``prove``
    then imagines the whole profile with it (InvalidAnswerError with what the simulation saw when it fails: the code
    goes back to the model for repair, as Eureka improves reward code with simulation feedback)."""

    def check(scoring: ScoringCode) -> None:
        check_scoring(scoring, request)
        if prove is not None:
            prove(scoring)

    return _provider(provider).answer(STAGES["scoring"], request, check)


def analyze_functional_poses(request: FunctionalPoseRequest, provider: ProviderLike = "offline",
                             pictures: Sequence[Picture] = ()) -> FunctionalPoseVerdict:
    """Stage 7: accept or reject each pose's successes by common sense; pick the best (pose, plan). ``pictures``
    (one per pose of the request, with its plan's end state) go with it to a model that sees them."""
    return _provider(provider).answer(STAGES["functional_pose"], request, lambda v: check_verdict(v, request),
                                      pictures)


def define_affordance(request: DefinitionRequest, provider: ProviderLike,
                      prove: Callable[[AffordanceDefinition, FileRow], None] | None = None) -> AffordanceDefinition:
    """Stage 0, the Affordance Definer, for a name outside the registry: a row of a registered kind (its row_toml
    passes every check of an affordance file, :func:`definition_row`), or no kind and the reason. ``prove`` then
    imagines the answer's prototypes with the row (InvalidAnswerError with what the simulation saw when it fails:
    the answer goes back to the model for repair like any rejected answer)."""

    def check(answer: AffordanceDefinition) -> None:
        entry = definition_row(request, answer)
        if entry is not None and prove is not None:
            prove(answer, entry)

    return _provider(provider).answer(STAGES["affordance_definition"], request, check)


def definition_row(request: DefinitionRequest, answer: AffordanceDefinition) -> FileRow | None:
    """The row of a stage-0 answer, checked as an affordance file's row is, and against the request; None when no
    kind models the use. InvalidAnswerError naming what is wrong and what is valid."""
    if answer.affordance != request.affordance:
        raise InvalidAnswerError(f"affordance must be the requested name {request.affordance!r}; got "
                                 f"{answer.affordance!r}")
    if answer.kind is None:
        if answer.row_toml is not None or answer.size_basis or answer.prototypes:
            raise InvalidAnswerError("kind is null, so row_toml must be null, size_basis [] and prototypes []: no "
                                     "kind's row")
        if not answer.reason.strip():
            raise InvalidAnswerError("reason must say what the use needs that no kind tests")
        return None
    if answer.row_toml is None:
        raise InvalidAnswerError(f"kind is {answer.kind!r}, so row_toml must hold the use's [[affordance]] table")
    try:
        rows = parse(answer.row_toml, "row_toml")
    except AffordanceFileError as exc:
        raise InvalidAnswerError(str(exc)) from exc
    if len(rows) != 1:
        raise InvalidAnswerError(f"row_toml must hold exactly one [[affordance]] table; got {len(rows)}")
    (entry,) = rows
    name = " ".join(request.affordance.lower().split())
    if entry.row.name != name:
        raise InvalidAnswerError(f"row_toml's name must be the requested use {name!r}; got {entry.row.name!r}")
    if entry.row.kind != answer.kind:
        raise InvalidAnswerError(f"row_toml's kind {entry.row.kind!r} must equal the answer's kind {answer.kind!r}")
    if entry.override:
        raise InvalidAnswerError("row_toml must not override a registered row: leave out override")
    taken = [n for n in (entry.row.name, *entry.row.aliases) if rules_row(n) is not None]
    if taken:
        raise InvalidAnswerError(f"row_toml names {taken}, already registered uses; a new use takes new names")
    if not any(line.strip() for line in answer.size_basis):
        raise InvalidAnswerError("size_basis must give, for each size range of the row, what real objects of the "
                                 "use measure and where that comes from")
    row = entry.row

    def prior(p: Prototype) -> Prior:
        box = extents(p)
        return row.size_prior(sorted(box, reverse=True)) * row.pose_prior([v / 2 for v in box], None)

    check_prototypes(answer.prototypes, prior, "the row's typical sizes")
    return entry


def parse_request_text(request: RequestText, provider: ProviderLike = "offline") -> Request:
    """The request parser: the agent, the affordance, the preposition and the owner of a sentence like "put the
    apple in the bowl". The answer's affordance is the name ``provider`` resolves (the registry's canonical name;
    an LLM provider may also name a novel use), its agent is non-empty, its owner null or one that
    :func:`rail_mj.affordances.names.owner_scale` knows, its text the sentence as given."""
    prov = _provider(provider)

    def check(answer: Request) -> None:
        if answer.text != request.text:
            raise InvalidAnswerError(f"text must be the sentence as given, {request.text!r}; got {answer.text!r}")
        if not answer.agent.strip():
            raise InvalidAnswerError("agent must name what is placed (e.g. apple, doll, water)")
        try:
            name = prov.affordance_name(answer.affordance)
        except UnknownAffordanceError as exc:
            raise InvalidAnswerError(str(exc)) from exc
        if name != answer.affordance:
            raise InvalidAnswerError(f"affordance must be the canonical name {name!r}; got {answer.affordance!r}")
        if answer.owner is not None:
            try:
                owner_scale(answer.owner)
            except ConfigError as exc:
                raise InvalidAnswerError(f"owner must be null or a figure or animal whose size sets the object's: "
                                         f"{exc}") from exc

    return prov.answer(STAGES["request_parser"], request, check)


def task_description(affordance: str, obb_dims: Sequence[float] | np.ndarray, provider: Provider, *,
                     scale: float = 1.0) -> TaskDescription:
    """The task every stage request of a profile carries: the name as ``provider`` resolves it (the
    registry's canonical name when known; see :meth:`Provider.affordance_name`), dims sorted descending,
    and the request's agent ``scale`` (a doll's chair: 0.18; :func:`rail_mj.affordances.request_scale`).

    The one place a requested name becomes the name the stages see.
    """
    dims = sorted((float(d) for d in np.asarray(obb_dims, dtype=float).ravel()), reverse=True)
    if len(dims) != 3 or not all(np.isfinite(dims)) or dims[-1] <= 0:
        raise ConfigError(f"obb_dims must be three positive finite extents in metres; got {list(obb_dims)}")
    return TaskDescription(affordance=provider.affordance_name(affordance), obb_dims=dims, scale=scale)


def use_task(affordance: str, *, scale: float = 1.0) -> TaskDescription:
    """The task of a profile that serves every object of a use (no obb_dims): its stage 1 gives the use's sizes and
    prototypes, and every position of the profile is relative to each object's half extents."""
    return TaskDescription(affordance=" ".join(affordance.split()), obb_dims=None, scale=scale)


def task_profile(task: TaskDescription, provider: Provider, *,
                 half_extents: Sequence[Sequence[float]] | np.ndarray | None = None,
                 prove: Callable[[ImaginationProfile], None] | None = None) -> ImaginationProfile:
    """Stages 1–6 for a task from :func:`task_description` or :func:`use_task` (``half_extents``: see
    :func:`generate_trajectories`); ``prove`` imagines the whole profile before stage 6's answer is accepted (see
    :func:`generate_scoring`)."""
    analysis = analyze_affordance(AnalyzerRequest(task=task), provider)
    agent = generate_agent_model(AgentModelRequest(task=task, analysis=analysis), provider)
    layout = generate_layout(LayoutRequest(task=task, analysis=analysis, agent=agent), provider)
    plans = plan_motions(PlannerRequest(task=task, analysis=analysis), provider)
    trajectories = generate_trajectories(
        TrajectoryRequest(task=task, analysis=analysis, agent=agent, layout=layout, plans=plans), provider,
        half_extents=half_extents,
    )

    def assemble(scoring: ScoringCode) -> ImaginationProfile:
        return ImaginationProfile(
            affordance=task.affordance, obb_dims=None if task.obb_dims is None else list(task.obb_dims),
            provider=provider.name, model=provider.model, scale=task.scale,
            prompt_versions={k: v for k, v in PROMPT_VERSION.items() if k != "functional_pose"},
            analysis=analysis, agent=agent, layout=layout, plans=plans, trajectories=trajectories, scoring=scoring,
        )

    scoring = generate_scoring(ScoringRequest(task=task, analysis=analysis, agent=agent, layout=layout, plans=plans),
                               provider, None if prove is None else lambda s: prove(assemble(s)))
    return assemble(scoring)


def generate_profile(
    affordance: str,
    obb_dims: Sequence[float] | np.ndarray,
    provider: ProviderLike = "offline",
    *,
    half_extents: Sequence[Sequence[float]] | np.ndarray | None = None,
    **options: Any,
) -> ImaginationProfile:
    """Stages 1–6 for one affordance and one object.

    The profile is made for the requested affordance (by its canonical name when
    the registry knows it) even when stage 1 says the dims do not fit
    (``profile.analysis.fits`` / ``.alternative`` tell the caller, who may imagine
    the alternative instead). A provider name is built with ``options``
    (``get_provider(provider, **options)``: model, max_retries, cache, ...); a
    provider object is already configured and takes none. ``half_extents`` are the
    stable poses' (see :func:`generate_trajectories`).
    """
    if isinstance(provider, str):
        prov = get_provider(provider, **options)
    elif options:
        raise ConfigError(f"the given {provider.name} provider was configured when it was made; got options "
                          f"{sorted(options)} for it: pass them to get_provider(name, ...), or pass the name")
    else:
        prov = provider
    return task_profile(task_description(affordance, obb_dims, prov), prov, half_extents=half_extents)


def functional_pose_request(profile: ImaginationProfile, candidates: Sequence[PoseCandidates],
                            shape: Callable[[int], PoseShape] | None = None,
                            came_in: PoseShape | None = None) -> FunctionalPoseRequest | None:
    """Stage 7's request: the poses of the nominal world with a candidate
    (:meth:`rail_mj.imagination.worlds.ImaginedWorlds.candidates`), each with its ``shape(pose index)`` and the
    object's shape as it ``came_in`` when given (a model's request: what it cannot read from the numbers); None
    when no plan scored above 0 in any pose."""
    if not candidates:
        return None
    poses = [p.model_copy(update={"shape": shape(p.pose_index)}) for p in candidates] if shape else list(candidates)
    return FunctionalPoseRequest(
        affordance=profile.affordance, expected_outcome=profile.analysis.expected_outcome, poses=poses,
        scale=profile.scale, came_in=came_in,
    )
