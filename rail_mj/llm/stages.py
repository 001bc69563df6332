"""The seven stages as functions (pydantic request in, validated pydantic answer out) and the profile.

Every stage runs through a provider (offline library or LLM) with its check;
:func:`generate_profile` chains stages 1–6 into an :class:`ImaginationProfile`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rail_mj.errors import ConfigError
from rail_mj.llm.checks import (
    InvalidAnswerError,
    agent_geometry,
    candidate_half_extents,
    check_agent,
    check_analysis,
    check_layout,
    check_scoring,
    check_trajectories,
    check_verdict,
    layout_offsets,
    via_positions,
)
from rail_mj.llm.prompts import PROMPT_VERSION, STAGES
from rail_mj.llm.providers import Provider, get_provider
from rail_mj.llm.schemas import (
    AffordanceAnalysis,
    AgentLayout,
    AgentModel,
    AgentModelRequest,
    AnalyzerRequest,
    FunctionalPoseRequest,
    FunctionalPoseVerdict,
    ImaginationProfile,
    LayoutRequest,
    MotionPlans,
    PlannerRequest,
    PlanTrajectory,
    ResultSummary,
    ScoringCode,
    ScoringRequest,
    TaskDescription,
    TrajectoryRequest,
    Trajectories,
)
from rail_mj.types import AgentSetup, Outcomes

__all__ = [
    "analyze_affordance",
    "generate_agent_model",
    "generate_layout",
    "plan_motions",
    "generate_trajectories",
    "generate_scoring",
    "analyze_functional_poses",
    "generate_profile",
    "trajectory_array",
    "agent_setup",
    "result_summary",
]

ProviderLike = str | Provider


def _provider(provider: ProviderLike) -> Provider:
    return get_provider(provider) if isinstance(provider, str) else provider


def analyze_affordance(request: AnalyzerRequest, provider: ProviderLike = "offline", *, max_retries: int = 2,
                       cache: bool = True) -> AffordanceAnalysis:
    """Stage 1: dimension check (+ alternative), IBD, agent / interaction / outcome outline."""
    return _provider(provider).answer(STAGES["affordance_analyzer"], request,
                                      lambda a: check_analysis(a, request.task), max_retries=max_retries, cache=cache)


def generate_agent_model(request: AgentModelRequest, provider: ProviderLike = "offline", *, max_retries: int = 2,
                         cache: bool = True) -> AgentModel:
    """Stage 2: the agent as a one-body, joint-free MJCF fragment scaled to the object."""
    return _provider(provider).answer(STAGES["agent_model"], request, lambda a: check_agent(a, request.task),
                                      max_retries=max_retries, cache=cache)


def generate_layout(request: LayoutRequest, provider: ProviderLike = "offline", *, max_retries: int = 2,
                    cache: bool = True) -> AgentLayout:
    """Stage 3: grid counts and spacing that keep agents apart."""
    radius = agent_geometry(request.agent).radius
    return _provider(provider).answer(STAGES["agent_configuration"], request, lambda a: check_layout(a, radius),
                                      max_retries=max_retries, cache=cache)


def plan_motions(request: PlannerRequest, provider: ProviderLike = "offline", *, max_retries: int = 2,
                 cache: bool = True) -> MotionPlans:
    """Stage 4: at least five language plans with distinct names."""

    def check(plans: MotionPlans) -> None:
        names = [p.name for p in plans.plans]
        if len(set(names)) != len(names):
            raise InvalidAnswerError(f"plan names must be distinct; got {names}")

    return _provider(provider).answer(STAGES["motion_planner"], request, check, max_retries=max_retries, cache=cache)


def generate_trajectories(request: TrajectoryRequest, provider: ProviderLike = "offline", *,
                          half_extents: Sequence[Sequence[float]] | np.ndarray | None = None, max_retries: int = 2,
                          cache: bool = True) -> Trajectories:
    """Stage 5: via-poses per plan, checked for each pose's half extents.

    ``half_extents`` (P, 3) are the object's half extents in its stable poses;
    without them every axis-aligned orientation of the OBB is checked.
    """
    if half_extents is None:
        poses = candidate_half_extents(request.task.obb_dims)
    else:
        arr = np.asarray(half_extents, dtype=float).reshape(-1, 3)
        if arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
            raise ConfigError(f"half_extents must be positive finite (P, 3) values; got {arr.tolist()}")
        poses = list(arr)
    radius = agent_geometry(request.agent).radius
    offsets = layout_offsets(request.layout)
    return _provider(provider).answer(
        STAGES["trajectory"], request,
        lambda t: check_trajectories(t, request.plans, radius, offsets, poses),
        max_retries=max_retries, cache=cache,
    )


def generate_scoring(request: ScoringRequest, provider: ProviderLike = "offline", *, max_retries: int = 2,
                     cache: bool = True) -> ScoringCode:
    """Stage 6: numpy scoring source accepted by the scoring sandbox and run there on a synthetic batch."""
    return _provider(provider).answer(STAGES["scoring"], request, lambda s: check_scoring(s, request),
                                      max_retries=max_retries, cache=cache)


def analyze_functional_poses(request: FunctionalPoseRequest, provider: ProviderLike = "offline", *,
                             max_retries: int = 2, cache: bool = True) -> FunctionalPoseVerdict:
    """Stage 7: accept or reject each pose's successes by common sense; pick the best (pose, plan)."""
    return _provider(provider).answer(STAGES["functional_pose"], request, lambda v: check_verdict(v, request),
                                      max_retries=max_retries, cache=cache)


def generate_profile(
    affordance: str,
    obb_dims: Sequence[float] | np.ndarray,
    provider: ProviderLike = "offline",
    *,
    half_extents: Sequence[Sequence[float]] | np.ndarray | None = None,
    model: str | None = None,
    cache: bool = True,
    max_retries: int = 2,
) -> ImaginationProfile:
    """Stages 1–6 for one affordance and one object.

    The profile is made for the requested affordance even when stage 1 says
    the dims do not fit (``profile.analysis.fits`` / ``.alternative`` tell the
    caller, who may imagine the alternative instead). ``model`` picks the LLM
    when ``provider`` is a name; ``half_extents`` are the stable poses' (see
    :func:`generate_trajectories`).
    """
    dims = sorted((float(d) for d in np.asarray(obb_dims, dtype=float).ravel()), reverse=True)
    if len(dims) != 3 or not all(np.isfinite(dims)) or dims[-1] <= 0:
        raise ConfigError(f"obb_dims must be three positive finite extents in metres; got {list(obb_dims)}")
    if isinstance(provider, str):
        prov = get_provider(provider, model=model) if model is not None else get_provider(provider)
    elif model is not None and model != provider.model:
        raise ConfigError(f"model {model!r} conflicts with the given provider's model {provider.model!r}; "
                          "pass one or the other")
    else:
        prov = provider
    opts = {"max_retries": max_retries, "cache": cache}
    task = TaskDescription(affordance=affordance.strip(), obb_dims=dims)
    analysis = analyze_affordance(AnalyzerRequest(task=task), prov, **opts)
    agent = generate_agent_model(AgentModelRequest(task=task, analysis=analysis), prov, **opts)
    layout = generate_layout(LayoutRequest(task=task, analysis=analysis, agent=agent), prov, **opts)
    plans = plan_motions(PlannerRequest(task=task, analysis=analysis), prov, **opts)
    trajectories = generate_trajectories(
        TrajectoryRequest(task=task, analysis=analysis, agent=agent, layout=layout, plans=plans), prov,
        half_extents=half_extents, **opts,
    )
    scoring = generate_scoring(ScoringRequest(task=task, analysis=analysis, agent=agent, layout=layout, plans=plans),
                               prov, **opts)
    return ImaginationProfile(
        affordance=task.affordance, obb_dims=dims, provider=prov.name, model=prov.model,
        prompt_versions={k: v for k, v in PROMPT_VERSION.items() if k != "functional_pose"},
        analysis=analysis, agent=agent, layout=layout, plans=plans, trajectories=trajectories, scoring=scoring,
    )


def trajectory_array(profile_or_traj: ImaginationProfile | Trajectories | PlanTrajectory,
                     half_extents: Sequence[float] | np.ndarray) -> list[np.ndarray]:
    """Via-poses per plan as (K, 7) arrays (task-frame position xyz, quat wxyz) for one pose's ``h``."""
    h = np.asarray(half_extents, dtype=float)
    if h.shape != (3,) or not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise ConfigError(f"half_extents must be three positive finite values; got {h.tolist()}")
    if isinstance(profile_or_traj, ImaginationProfile):
        trajs = profile_or_traj.trajectories.trajectories
    elif isinstance(profile_or_traj, Trajectories):
        trajs = profile_or_traj.trajectories
    else:
        trajs = [profile_or_traj]
    out = []
    for t in trajs:
        quat = np.array([v.quat for v in t.via_poses], dtype=float)
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        out.append(np.concatenate([via_positions(t.via_poses, h), quat], axis=1))
    return out


def agent_setup(profile: ImaginationProfile) -> AgentSetup:
    """The agent fragment and grid offsets the imagination needs."""
    return AgentSetup(fragment=profile.agent.mjcf, offsets=layout_offsets(profile.layout),
                      collide_agents=profile.layout.collide_agents)


def result_summary(outcomes: Outcomes, b: int) -> ResultSummary:
    """Summary of rollout ``b`` for the Functional Pose Analyzer."""
    h = outcomes.object_half_extents[b]
    pos = outcomes.agent_pos[b]
    q = outcomes.agent_quat[b]
    cos_tilt = np.clip(1.0 - 2.0 * (q[:, 1] ** 2 + q[:, 2] ** 2), -1.0, 1.0)
    rel = pos - outcomes.object_pos[b]  # the object may have slid under the agents' impacts
    beneath = (rel[:, 0] / h[0]) ** 2 + (rel[:, 1] / h[1]) ** 2 < 0.25
    return ResultSummary(
        frac_inside_bbox=float(np.mean(np.all(np.abs(pos) < h, axis=1))),
        frac_on_ground=float(np.mean(outcomes.contacts_ground[b] > 0)),
        frac_touching_object=float(np.mean(outcomes.contacts_object[b] > 0)),
        mean_height=float(np.mean(pos[:, 2]) / h[2]),
        object_tilt_deg=float(np.degrees(outcomes.object_tilt[b])),
        agent_tilt_deg=float(np.mean(np.degrees(np.arccos(cos_tilt)))),
        agent_speed=float(np.mean(np.linalg.norm(outcomes.agent_vel[b], axis=1))),
        frac_through_object=float(np.mean(beneath & (outcomes.contacts_ground[b] > 0))),
    )
