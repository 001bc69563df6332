"""Claude through the Anthropic SDK: structured outputs, repair rounds, response cache."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import pydantic

from rail_mj.core.errors import ConfigError, ProviderError, StageError
from rail_mj.llm.cache import ResponseCache, cache_enabled, cache_key
from rail_mj.llm.prompts import StageSpec, repair_prompt, system_prompt, user_prompt
from rail_mj.llm.provider_base import REJECTIONS, Provider, ProviderConfig

if TYPE_CHECKING:
    from anthropic.types import MessageParam, OutputConfigParam

__all__ = ["MODEL_ENV", "DEFAULT_MODEL", "DEFAULT_TEMPERATURE", "OPTIONS", "AnthropicConfig", "AnthropicProvider"]

#: Environment variable naming the Claude model.
MODEL_ENV = "RAIL_MJ_MODEL"
DEFAULT_MODEL = "claude-sonnet-4-5"
#: The paper's sampling temperature.
DEFAULT_TEMPERATURE = 0.1


@dataclass(frozen=True)
class AnthropicConfig(ProviderConfig):
    """The Anthropic provider's settings, fixed at construction (the API key stays with the client only)."""

    model: str = DEFAULT_MODEL
    base_url: str | None = None
    timeout: float = 120.0  # s per request
    http_retries: int = 2  # the SDK's own retries of HTTP 429/5xx
    temperature: float | None = DEFAULT_TEMPERATURE
    max_tokens: int = 8192
    cache_root: Path | None = None  # default: cache_dir("llm")

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.timeout <= 0 or self.http_retries < 0 or self.max_tokens < 1:
            raise ConfigError(
                f"timeout must be > 0 s, http_retries >= 0, max_tokens >= 1; got {self.timeout}, "
                f"{self.http_retries}, {self.max_tokens}"
            )


#: Keyword options of :class:`AnthropicProvider` (and so of ``get_provider("anthropic", ...)``).
OPTIONS: tuple[str, ...] = ("api_key", *(f.name for f in fields(AnthropicConfig)))


class AnthropicProvider(Provider):
    """Stage answers from the Messages API with structured output (the stage schema as ``output_config``).

    An answer that fails its schema or check, or an HTTP 200 reply that is no
    Message or holds no text, is a failed attempt: it is sent back with the
    error text for up to ``max_retries`` repair rounds. Validated answers are
    cached (see :mod:`rail_mj.llm.cache`) unless ``cache`` is False. HTTP
    429/5xx are retried by the SDK itself (``http_retries``); other SDK and
    network failures become ProviderError. Affordances outside the registry are
    imagined too. The SDK is imported when a provider is made, not with rail_mj.
    """

    name = "anthropic"
    novel_affordances = True

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
        max_retries: int = 2,
        cache: bool = True,
    ) -> None:
        key = api_key or os.environ.get("ANTHROPIC_API_KEY")
        if not key:
            raise ConfigError(
                "the anthropic provider needs an API key: set ANTHROPIC_API_KEY (or pass api_key=), "
                "or use the offline provider"
            )
        config = AnthropicConfig(
            max_retries=max_retries, cache=cache, model=model or os.environ.get(MODEL_ENV) or DEFAULT_MODEL,
            base_url=base_url, timeout=timeout, http_retries=http_retries, temperature=temperature,
            max_tokens=max_tokens, cache_root=Path(cache_root) if cache_root is not None else None,
        )
        super().__init__(config)
        import anthropic  # here, not at module level: only this provider needs the SDK

        self._client = anthropic.Anthropic(api_key=key, base_url=base_url, timeout=timeout,
                                           max_retries=http_retries)
        self._responses = ResponseCache(config.cache_root)

    @property
    def config(self) -> AnthropicConfig:
        return self._config  # type: ignore[return-value]  # always an AnthropicConfig: set in __init__

    @property
    def model(self) -> str:
        return self.config.model

    def answer(self, stage: StageSpec, request, check):
        max_retries = self.config.max_retries
        request_json = request.model_dump(mode="json")
        key = cache_key(self.name, self.model, stage.version, stage.name, request_json)
        use_cache = cache_enabled(self.config.cache)
        if use_cache:
            cached = self._responses.get(key)
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
            body = self._call(stage, system, messages)
            try:
                text, stop_reason = _reply_text(body)
            except ProviderError as exc:  # an HTTP 200 that is no usable Message: a failed attempt
                problem = str(exc)
                messages.append({"role": "user", "content": repair_prompt(problem)})
                continue
            turn = [{"role": "assistant", "content": text}] if text.strip() else []
            try:
                result = stage.output_type.model_validate_json(text)
            except pydantic.ValidationError as exc:
                cut = (f"the answer was cut off at max_tokens={self.config.max_tokens} (stop_reason 'max_tokens'); "
                       "give a complete, shorter answer; " if stop_reason == "max_tokens" else "")
                problem = f"{cut}the answer does not match the schema: {exc}"
                messages += [*turn, {"role": "user", "content": repair_prompt(problem)}]
                continue
            try:
                check(result)
            except REJECTIONS as exc:
                problem = str(exc)
                messages += [*turn, {"role": "user", "content": repair_prompt(problem)}]
                continue
            if use_cache:
                meta = {"provider": self.name, "model": self.model, "prompt_version": stage.version,
                        "stage": stage.name, "request": request_json}
                self._responses.put(key, result.model_dump_json(), meta)
            return result
        raise StageError(
            f"stage {stage.name!r} gave no valid answer in {max_retries + 1} attempts "
            f"(model {self.model}); last problem: {problem}"
        )

    def _call(self, stage: StageSpec, system: str, messages: list[dict[str, Any]]) -> str:
        """One request; the raw HTTP 200 body. SDK and network failures become ProviderError."""
        import anthropic

        temperature = self.config.temperature
        extra = {"temperature": temperature} if temperature is not None else None
        output = {"format": {"type": "json_schema", "schema": anthropic.transform_schema(stage.output_type)}}
        try:
            # the raw body, so that a reply of any shape is read here (the SDK's parser crashed on non-Messages)
            return self._client.messages.with_raw_response.create(
                model=self.model,
                max_tokens=self.config.max_tokens,
                system=system,
                messages=cast("list[MessageParam]", messages),  # dicts of the Messages API's shape
                output_config=cast("OutputConfigParam", output),
                extra_body=extra,
            ).http_response.text
        except anthropic.APITimeoutError as exc:
            raise ProviderError(
                f"stage {stage.name!r}: the Anthropic API did not answer within {self.config.timeout:g} s; "
                "raise the timeout or check the network / ANTHROPIC_BASE_URL"
            ) from exc
        except anthropic.APIConnectionError as exc:
            raise ProviderError(
                f"stage {stage.name!r}: cannot reach the Anthropic API at {self._client.base_url} ({exc}); "
                "check the network or ANTHROPIC_BASE_URL, or use the offline provider"
            ) from exc
        except anthropic.AuthenticationError as exc:
            raise ProviderError(f"stage {stage.name!r}: the API key was rejected; check ANTHROPIC_API_KEY") from exc
        except anthropic.APIStatusError as exc:
            raise ProviderError(
                f"stage {stage.name!r}: the Anthropic API answered HTTP {exc.status_code} "
                f"(after the SDK's retries for 429/5xx): {exc.message}"
            ) from exc


_JSON_TYPES = {list: "array", str: "string", int: "number", float: "number", bool: "boolean", type(None): "null"}


def _reply_text(body: str) -> tuple[str, str | None]:
    """The first text block's text and the stop reason of a Messages API reply; ProviderError for any other shape."""
    shown = repr(body[:300]) + (f" (+{len(body) - 300} characters)" if len(body) > 300 else "")
    try:
        message = json.loads(body)
    except ValueError:
        raise ProviderError(f"the API's HTTP 200 reply is not JSON: {shown}") from None
    if not isinstance(message, dict) or message.get("type") != "message":
        what = f"type {message.get('type')!r}" if isinstance(message, dict) else f"a JSON {_JSON_TYPES[type(message)]}"
        raise ProviderError(f"the API's HTTP 200 reply is not a Message ({what}): {shown}")
    content, stop_reason = message.get("content"), message.get("stop_reason")
    typed = isinstance(content, list) and all(isinstance(b, dict) and isinstance(b.get("type"), str) for b in content)
    if not typed:
        raise ProviderError(f"the API's HTTP 200 Message has no list of typed content blocks: {shown}")
    assert isinstance(content, list)  # typed says so
    for block in content:
        if block["type"] == "text":
            if not isinstance(block.get("text"), str):
                raise ProviderError(f"the API's HTTP 200 Message has a text block without text: {shown}")
            return block["text"], stop_reason
    raise ProviderError(
        f"the answer held no text (stop_reason {stop_reason!r}, content blocks {[b['type'] for b in content]})"
    )
