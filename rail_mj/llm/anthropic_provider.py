"""Claude through the Anthropic SDK: the Messages API with structured output.

The repair rounds, the response cache and the validation are :class:`rail_mj.llm.provider_base.LLMProvider`'s.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any, cast

from rail_mj.core.errors import ConfigError, ProviderError
from rail_mj.llm.pictures import Picture, picture_b64
from rail_mj.llm.prompts import StageSpec
from rail_mj.llm.provider_base import (
    MODEL_ENV,
    LLMConfig,
    LLMProvider,
    json_body,
    json_kind,
    shown_body,
)

if TYPE_CHECKING:  # the SDK is imported when a provider is made, not with rail_mj
    from anthropic.types import MessageParam, OutputConfigParam

if TYPE_CHECKING:
    from anthropic.types import MessageParam, OutputConfigParam

__all__ = ["DEFAULT_MODEL", "OPTIONS", "AnthropicConfig", "AnthropicProvider"]

DEFAULT_MODEL = "claude-sonnet-4-5"


class AnthropicConfig(LLMConfig):
    """The Anthropic provider's settings, fixed at construction (the API key stays with the client only)."""

    model: str = DEFAULT_MODEL


#: Keyword options of :class:`AnthropicProvider` (and so of ``get_provider("anthropic", ...)``).
OPTIONS: tuple[str, ...] = ("api_key", *AnthropicConfig.model_fields)


class AnthropicProvider(LLMProvider):
    """Stage answers from the Messages API with structured output (the stage schema as ``output_config``).

    An answer that fails its schema or check, or an HTTP 200 reply that is no
    Message or holds no text, is a failed attempt: it is sent back with the
    error text for up to ``max_retries`` repair rounds (:class:`LLMProvider`).
    Validated answers are cached (see :mod:`rail_mj.llm.cache`) unless ``cache`` is False. HTTP
    429/5xx are retried by the SDK itself (``http_retries``); other SDK and
    network failures become ProviderError. Affordances outside the registry are
    imagined too. The SDK is imported when a provider is made, not with rail_mj.
    """

    name = "anthropic"

    def __init__(
        self,
        model: str | None = None,
        *,
        api_key: str | None = None,
        base_url: str | None = None,
        **settings: Any,
    ) -> None:
        """``settings``: the other fields of :class:`AnthropicConfig` (timeout, http_retries, temperature,
        max_tokens, cache_root, max_retries, cache), each defaulting there."""
        key = api_key or os.environ.get("ANTHROPIC_API_KEY")
        if not key:
            raise ConfigError(
                "the anthropic provider needs an API key: set ANTHROPIC_API_KEY (or pass api_key=), "
                "or use the offline provider"
            )
        config = AnthropicConfig(model=model or os.environ.get(MODEL_ENV) or DEFAULT_MODEL, base_url=base_url,
                                 **settings)
        super().__init__(config)
        import anthropic  # here, not at module level: only this provider needs the SDK

        self._client = anthropic.Anthropic(api_key=key, base_url=base_url, timeout=config.timeout,
                                           max_retries=config.http_retries)

    @property
    def config(self) -> AnthropicConfig:
        return self._config  # type: ignore[return-value]  # always an AnthropicConfig: set in __init__

    def _call(self, stage: StageSpec, system: str, messages: list[dict[str, Any]]) -> str:
        """One request; the raw HTTP 200 body. SDK and network failures become ProviderError."""
        import anthropic

        temperature = self.config.temperature
        extra = {"temperature": temperature} if temperature is not None else None
        output: OutputConfigParam = {
            "format": {"type": "json_schema", "schema": anthropic.transform_schema(stage.output_type)}
        }
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
                "raise it (--llm-timeout SECONDS on the command line, RunConfig(llm_timeout=...) in the API) or "
                "check the network / ANTHROPIC_BASE_URL"
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

    def _picture_part(self, picture: Picture) -> dict[str, Any]:
        return {"type": "image", "source": {"type": "base64", "media_type": "image/png", "data": picture_b64(picture)}}

    def _read_reply(self, body: str) -> tuple[str, str | None]:
        text, stop_reason = _reply_text(body)
        return text, ("stop_reason 'max_tokens'" if stop_reason == "max_tokens" else None)


def _reply_text(body: str) -> tuple[str, str | None]:
    """The first text block's text and the stop reason of a Messages API reply; ProviderError for any other shape."""
    shown = shown_body(body)
    message = json_body(body)
    if not isinstance(message, dict) or message.get("type") != "message":
        what = f"type {message.get('type')!r}" if isinstance(message, dict) else json_kind(message)
        raise ProviderError(f"the API's HTTP 200 reply is not a Message ({what}): {shown}")
    content, stop_reason = message.get("content"), message.get("stop_reason")
    if not isinstance(content, list) or not all(isinstance(b, dict) and isinstance(b.get("type"), str)
                                                for b in content):
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
