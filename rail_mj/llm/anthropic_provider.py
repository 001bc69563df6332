"""Claude through the Anthropic SDK: structured outputs, repair rounds, response cache."""

from __future__ import annotations

import os
from typing import Any

import anthropic
import pydantic

from rail_mj.errors import ConfigError, ProviderError, StageError
from rail_mj.llm.cache import ResponseCache, cache_enabled, cache_key
from rail_mj.llm.prompts import StageSpec, repair_prompt, system_prompt, user_prompt
from rail_mj.llm.providers import REJECTIONS, Provider

__all__ = ["MODEL_ENV", "DEFAULT_MODEL", "DEFAULT_TEMPERATURE", "AnthropicProvider"]

#: Environment variable naming the Claude model.
MODEL_ENV = "RAIL_MJ_MODEL"
DEFAULT_MODEL = "claude-sonnet-4-5"
#: The paper's sampling temperature.
DEFAULT_TEMPERATURE = 0.1


class AnthropicProvider(Provider):
    """Stage answers from ``client.messages.parse(output_format=<stage schema>)``.

    An answer that fails its schema or check is sent back with the error text
    for up to ``max_retries`` repair rounds. Validated answers are cached (see
    :mod:`rail_mj.llm.cache`). HTTP 429/5xx are retried by the SDK itself
    (``http_retries``); other SDK and network failures become ProviderError.
    """

    name = "anthropic"

    def __init__(
        self,
        model: str | None = None,
        *,
        api_key: str | None = None,
        base_url: str | None = None,
        timeout: float = 120.0,
        http_retries: int = 2,
        temperature: float | None = DEFAULT_TEMPERATURE,
        max_tokens: int = 8192,
        cache_root: str | os.PathLike[str] | None = None,
    ) -> None:
        self.model = model or os.environ.get(MODEL_ENV) or DEFAULT_MODEL
        key = api_key or os.environ.get("ANTHROPIC_API_KEY")
        if not key:
            raise ConfigError(
                "the anthropic provider needs an API key: set ANTHROPIC_API_KEY (or pass api_key=), "
                "or use the offline provider"
            )
        if timeout <= 0 or http_retries < 0 or max_tokens < 1:
            raise ConfigError(
                f"timeout must be > 0 s, http_retries >= 0, max_tokens >= 1; got {timeout}, {http_retries}, {max_tokens}"
            )
        self.timeout = timeout
        self.temperature = temperature
        self.max_tokens = max_tokens
        self.client = anthropic.Anthropic(api_key=key, base_url=base_url, timeout=timeout, max_retries=http_retries)
        self.cache = ResponseCache(cache_root)

    def answer(self, stage: StageSpec, request, check, *, max_retries=2, cache=True):
        if max_retries < 0:
            raise ConfigError(f"max_retries must be >= 0; got {max_retries}")
        request_json = request.model_dump(mode="json")
        key = cache_key(self.name, self.model, stage.version, stage.name, request_json)
        use_cache = cache_enabled(cache)
        if use_cache:
            cached = self.cache.get(key)
            if cached is not None:
                try:
                    result = stage.output_type.model_validate_json(cached)
                    check(result)
                    return result
                except (pydantic.ValidationError, *REJECTIONS):
                    pass  # stale under today's checks: ask again
        messages: list[dict[str, Any]] = [{"role": "user", "content": user_prompt(request)}]
        system = system_prompt(stage)
        problem = ""
        for _ in range(max_retries + 1):
            try:
                message = self._call(stage, system, messages)
            except pydantic.ValidationError as exc:
                # the text is gone with the exception; the error lists the offending values
                problem = f"the answer does not match the schema: {exc}"
                messages.append({"role": "user", "content": repair_prompt(problem)})
                continue
            text, result = _text_and_parsed(message)
            if result is None:
                problem = f"the answer held no JSON text (stop_reason {message.stop_reason!r})"
                messages.append({"role": "user", "content": repair_prompt(problem)})
                continue
            try:
                check(result)
            except REJECTIONS as exc:
                problem = str(exc)
                messages += [{"role": "assistant", "content": text}, {"role": "user", "content": repair_prompt(problem)}]
                continue
            if use_cache:
                meta = {"provider": self.name, "model": self.model, "prompt_version": stage.version,
                        "stage": stage.name, "request": request_json}
                self.cache.put(key, result.model_dump_json(), meta)
            return result
        raise StageError(
            f"stage {stage.name!r} gave no valid answer in {max_retries + 1} attempts "
            f"(model {self.model}); last problem: {problem}"
        )

    def _call(self, stage: StageSpec, system: str, messages: list[dict[str, Any]]):
        """One request; SDK and network failures become ProviderError."""
        extra = {"temperature": self.temperature} if self.temperature is not None else None
        try:
            return self.client.messages.parse(
                model=self.model,
                max_tokens=self.max_tokens,
                system=system,
                messages=messages,
                output_format=stage.output_type,
                extra_body=extra,
            )
        except anthropic.APITimeoutError as exc:
            raise ProviderError(
                f"stage {stage.name!r}: the Anthropic API did not answer within {self.timeout:g} s; "
                "raise the timeout or check the network / ANTHROPIC_BASE_URL"
            ) from exc
        except anthropic.APIConnectionError as exc:
            raise ProviderError(
                f"stage {stage.name!r}: cannot reach the Anthropic API at {self.client.base_url} ({exc}); "
                "check the network or ANTHROPIC_BASE_URL, or use the offline provider"
            ) from exc
        except anthropic.AuthenticationError as exc:
            raise ProviderError(f"stage {stage.name!r}: the API key was rejected; check ANTHROPIC_API_KEY") from exc
        except anthropic.APIStatusError as exc:
            raise ProviderError(
                f"stage {stage.name!r}: the Anthropic API answered HTTP {exc.status_code} "
                f"(after the SDK's retries for 429/5xx): {exc.message}"
            ) from exc


def _text_and_parsed(message) -> tuple[str, Any]:
    """The first text block's raw text and parsed answer, or ("", None)."""
    for block in message.content:
        if block.type == "text":
            return block.text, block.parsed_output
    return "", None
