"""The LLM stages: typed stage schemas, prompts, providers (offline library, Anthropic), response cache.

The profile's neutral types (plans, via-poses, layout, scoring source, rollout summaries) are
:mod:`rail_mj.core.profile`'s; what the simulator takes from a profile is :mod:`rail_mj.imagination.inputs`.
"""

from __future__ import annotations

from rail_mj.llm.anthropic_provider import AnthropicConfig, AnthropicProvider
from rail_mj.llm.checks import InvalidAnswerError
from rail_mj.llm.offline import known_affordances, normalize_affordance
from rail_mj.llm.prompts import PROMPT_VERSION
from rail_mj.llm.providers import OfflineProvider, Provider, ProviderConfig, get_provider
from rail_mj.llm.schemas import (
    AffordanceAnalysis,
    AgentModel,
    AgentModelRequest,
    AnalyzerRequest,
    FunctionalPoseRequest,
    FunctionalPoseVerdict,
    ImaginationProfile,
    LayoutRequest,
    MotionPlans,
    PlannerRequest,
    PoseVerdict,
    Request,
    RequestText,
    ScoringRequest,
    TaskDescription,
    Trajectories,
    TrajectoryRequest,
)
from rail_mj.llm.stages import (
    analyze_affordance,
    analyze_functional_poses,
    functional_pose_request,
    generate_agent_model,
    generate_layout,
    generate_profile,
    generate_scoring,
    generate_trajectories,
    parse_request_text,
    plan_motions,
    task_description,
    task_profile,
)

__all__ = [
    "AffordanceAnalysis",
    "AgentModel",
    "AgentModelRequest",
    "AnalyzerRequest",
    "AnthropicConfig",
    "AnthropicProvider",
    "FunctionalPoseRequest",
    "FunctionalPoseVerdict",
    "ImaginationProfile",
    "InvalidAnswerError",
    "LayoutRequest",
    "MotionPlans",
    "OfflineProvider",
    "PROMPT_VERSION",
    "PlannerRequest",
    "PoseVerdict",
    "Provider",
    "Request",
    "RequestText",
    "ProviderConfig",
    "ScoringRequest",
    "TaskDescription",
    "TrajectoryRequest",
    "Trajectories",
    "analyze_affordance",
    "analyze_functional_poses",
    "functional_pose_request",
    "generate_agent_model",
    "generate_layout",
    "generate_profile",
    "generate_scoring",
    "generate_trajectories",
    "get_provider",
    "known_affordances",
    "normalize_affordance",
    "parse_request_text",
    "plan_motions",
    "task_description",
    "task_profile",
]
