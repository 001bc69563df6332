"""Providers answer a stage's request with a validated answer: the offline library or an LLM."""

from __future__ import annotations

import os
from typing import Any

from rail_mj.errors import ConfigError, StageError
from rail_mj.llm import offline
from rail_mj.llm.provider_base import REJECTIONS, Provider
from rail_mj.llm.schemas import (
    AgentModelRequest,
    AnalyzerRequest,
    FunctionalPoseRequest,
    LayoutRequest,
    PlannerRequest,
    ScoringRequest,
    TrajectoryRequest,
)

__all__ = ["Provider", "OfflineProvider", "PROVIDERS", "get_provider", "REJECTIONS"]

#: Provider names accepted by :func:`get_provider`.
PROVIDERS = ("auto", "offline", "anthropic")


class OfflineProvider(Provider):
    """The built-in profile library (:mod:`rail_mj.llm.offline`); deterministic, needs no cache."""

    name = "offline"
    model = "offline-library"

    def answer(self, stage, request, check, *, max_retries=2, cache=True):
        if isinstance(request, AnalyzerRequest):
            result = offline.offline_analysis(request.task)
        elif isinstance(request, AgentModelRequest):
            result = offline.offline_agent(request.task)
        elif isinstance(request, LayoutRequest):
            result = offline.offline_layout(request.task)
        elif isinstance(request, PlannerRequest):
            result = offline.offline_plans(request.task)
        elif isinstance(request, TrajectoryRequest):
            result = offline.offline_trajectories(request.task, request.layout)
        elif isinstance(request, ScoringRequest):
            result = offline.offline_scoring(request.task)
        elif isinstance(request, FunctionalPoseRequest):
            result = offline.offline_functional_poses(request)
        else:
            raise ConfigError(f"the offline provider has no answer for a {type(request).__name__}")
        try:
            check(result)
        except REJECTIONS as exc:
            # no repair possible: the library's answer for these dims breaks a rule
            raise StageError(f"stage {stage.name!r} (offline library): {exc}") from exc
        return result


def get_provider(name: str = "auto", **options: Any) -> Provider:
    """``offline``, ``anthropic``, or ``auto`` (anthropic when ANTHROPIC_API_KEY is set, else offline).

    ``options`` go to :class:`rail_mj.llm.anthropic_provider.AnthropicProvider`
    (model, api_key, base_url, timeout, temperature, ...).
    """
    key = name.strip().lower()
    if key == "auto":
        key = "anthropic" if os.environ.get("ANTHROPIC_API_KEY") else "offline"
    if key == "offline":
        if options:
            raise ConfigError(f"the offline provider takes no options; got {sorted(options)}")
        return OfflineProvider()
    if key == "anthropic":
        from rail_mj.llm.anthropic_provider import AnthropicProvider  # imported when asked for: it loads the SDK

        return AnthropicProvider(**options)
    raise ConfigError(f"unknown LLM provider {name!r}; valid: {', '.join(PROVIDERS)}")
