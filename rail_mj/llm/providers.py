"""Providers answer a stage's request with a validated answer: the offline library or an LLM."""

from __future__ import annotations

import os
from typing import Any

import rail_mj.llm.offline as offline
import rail_mj.llm.openai_provider as openai_provider
from rail_mj.core.errors import ConfigError, StageError
from rail_mj.llm.provider_base import REJECTIONS, Provider, ProviderConfig

__all__ = ["Provider", "ProviderConfig", "OfflineProvider", "PROVIDERS", "get_provider", "REJECTIONS"]

#: Provider names accepted by :func:`get_provider`.
PROVIDERS = ("auto", "offline", "anthropic", "openai")
#: Options every provider takes.
_COMMON = tuple(ProviderConfig.model_fields)


class OfflineProvider(Provider):
    """The built-in profile library (:mod:`rail_mj.llm.offline`) for the registry's affordances.

    It takes the common settings so that a run configures any provider alike, and needs neither:
    its answers are deterministic (nothing to cache) and a rejected one cannot be repaired.
    """

    name = "offline"
    novel_affordances = False

    def __init__(self, **settings: Any) -> None:
        super().__init__(ProviderConfig(**settings))

    @property
    def model(self) -> str:
        return "offline-library"

    def answer(self, stage, request, check, pictures=()):
        result = offline.answer(request)  # the library reads the numbers; it has no eyes for pictures
        try:
            check(result)
        except REJECTIONS as exc:
            # no repair possible: the library's answer for these dims breaks a rule
            raise StageError(f"stage {stage.name!r} (offline library): {exc}") from exc
        return result


def get_provider(name: str = "auto", **options: Any) -> Provider:
    """``offline``, ``anthropic``, ``openai`` (any OpenAI-compatible chat-completions server), or ``auto``
    (anthropic when ANTHROPIC_API_KEY is set, else offline), configured once with ``options``.

    Every provider takes ``max_retries`` and ``cache`` (:class:`ProviderConfig`); the Anthropic one also
    the options of :class:`rail_mj.llm.anthropic_provider.AnthropicProvider` (model, api_key, base_url,
    timeout, temperature, ...), the OpenAI-compatible one those of
    :class:`rail_mj.llm.openai_provider.OpenAIProvider` (the same and ``strict``). Options a provider does
    not take are a ConfigError naming the valid ones.
    """
    key = name.strip().lower()
    if key == "auto":
        key = "anthropic" if os.environ.get("ANTHROPIC_API_KEY") else "offline"
    if key == "offline":
        unknown = sorted(set(options) - set(_COMMON))
        if unknown:
            raise ConfigError(f"the offline provider takes no LLM options; got {unknown}; "
                              f"valid: {', '.join(_COMMON)}")
        return OfflineProvider(**options)
    if key == "anthropic":
        from rail_mj.llm.anthropic_provider import OPTIONS, AnthropicProvider  # when asked for: it loads the SDK

        unknown = sorted(set(options) - set(OPTIONS))
        if unknown:
            raise ConfigError(f"the anthropic provider takes no option {unknown}; valid: {', '.join(OPTIONS)}")
        return AnthropicProvider(**options)
    if key == "openai":
        unknown = sorted(set(options) - set(openai_provider.OPTIONS))
        if unknown:
            raise ConfigError(f"the openai provider takes no option {unknown}; "
                              f"valid: {', '.join(openai_provider.OPTIONS)}")
        return openai_provider.OpenAIProvider(**options)
    raise ConfigError(f"unknown LLM provider {name!r}; valid: {', '.join(PROVIDERS)}")
