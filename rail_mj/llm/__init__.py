"""The LLM stages: typed stage schemas, prompts, providers (offline, Anthropic, OpenAI-compatible), cache.

The profile's neutral types (plans, via-poses, layout, scoring source, rollout summaries) are
:mod:`rail_mj.core.profile`'s; what the simulator takes from a profile is :mod:`rail_mj.imagination.inputs`.
"""

from __future__ import annotations

from rail_mj.llm import schemas
from rail_mj.llm.anthropic_provider import AnthropicConfig, AnthropicProvider
from rail_mj.llm.checks import InvalidAnswerError
from rail_mj.llm.offline import known_affordances, normalize_affordance
from rail_mj.llm.openai_provider import OpenAIConfig, OpenAIProvider
from rail_mj.llm.pictures import Picture
from rail_mj.llm.prompts import PROMPT_VERSION
from rail_mj.llm.providers import OfflineProvider, Provider, ProviderConfig, get_provider

# the package's API includes every stage schema: the requests and answers a provider speaks
from rail_mj.llm.schemas import *  # noqa: F403
from rail_mj.llm.stages import (
    analyze_affordance,
    analyze_functional_poses,
    define_affordance,
    definition_row,
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
    use_task,
)

__all__ = [
    "AnthropicConfig",
    "AnthropicProvider",
    "InvalidAnswerError",
    "OfflineProvider",
    "OpenAIConfig",
    "OpenAIProvider",
    "PROMPT_VERSION",
    "Picture",
    "Provider",
    "ProviderConfig",
    "analyze_affordance",
    "analyze_functional_poses",
    "define_affordance",
    "definition_row",
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
    "use_task",
]
__all__ += schemas.__all__
