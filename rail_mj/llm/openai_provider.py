"""OpenAI-compatible chat completions over plain HTTP: OpenAI itself, or a local vLLM, Ollama, llama.cpp, LM Studio.

One ``POST {base_url}/chat/completions`` per attempt, with the stage's answer schema as
``response_format={"type": "json_schema", ...}`` (structured output). Only the standard library
(``urllib.request``, ``json``) is used. The repair rounds, the response cache and the validation are
:class:`rail_mj.llm.provider_base.LLMProvider`'s.

Configuration: ``OPENAI_BASE_URL`` (default the hosted API, ``https://api.openai.com/v1``),
``OPENAI_API_KEY`` (sent as a Bearer token; required only for the hosted API, a local server usually needs
none), ``RAIL_MJ_MODEL`` (required for any other server: it has no default model there). Tested only
against a loopback server in the tests, never against a live model.
"""

from __future__ import annotations

import http.client
import json
import os
import time
import urllib.error
import urllib.request
from email.message import Message
from typing import Any

from pydantic import Field, field_validator

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

__all__ = [
    "API_KEY_ENV",
    "BASE_URL_ENV",
    "DEFAULT_BASE_URL",
    "DEFAULT_MODEL",
    "OPTIONS",
    "OpenAIConfig",
    "OpenAIProvider",
    "strict_schema",
]

#: Environment variable with the server's URL up to ``/v1``.
BASE_URL_ENV = "OPENAI_BASE_URL"
#: Environment variable with the API key (a Bearer token).
API_KEY_ENV = "OPENAI_API_KEY"
#: The hosted OpenAI API: the only URL for which a key is required and a default model is assumed.
DEFAULT_BASE_URL = "https://api.openai.com/v1"
DEFAULT_MODEL = "gpt-4.1"
#: Longest wait (s) before retrying an HTTP 429/5xx, whatever the server's retry-after says.
_MAX_BACKOFF_S = 30.0
#: Largest reply body read (bytes); a longer one is refused, not read into memory.
_MAX_BODY = 32 * 1024 * 1024
#: Statuses retried (``http_retries`` times) before they become a ProviderError.
_RETRIED = frozenset({408, 409, 429, 500, 502, 503, 504})


class OpenAIConfig(LLMConfig):
    """The OpenAI-compatible provider's settings, fixed at construction (the API key stays with the provider)."""

    model: str = DEFAULT_MODEL
    base_url: str | None = DEFAULT_BASE_URL
    strict: bool = Field(default=True, strict=True,
                         description="json_schema.strict: the hosted API then decodes exactly the schema")

    @field_validator("base_url")
    @classmethod
    def _url(cls, url: str | None) -> str | None:
        if not isinstance(url, str) or not url.startswith(("http://", "https://")):
            raise ValueError("must be an http:// or https:// URL up to /v1 (e.g. http://localhost:8000/v1)")
        return url

    @field_validator("model")
    @classmethod
    def _model(cls, model: str) -> str:
        if not model.strip():
            raise ValueError(f"must be non-empty: set {MODEL_ENV} (or pass model=)")
        return model


#: Keyword options of :class:`OpenAIProvider` (and so of ``get_provider("openai", ...)``).
OPTIONS: tuple[str, ...] = ("api_key", *OpenAIConfig.model_fields)


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    """A redirect is an HTTP error here: urllib would turn the POST into a GET without its body."""

    def redirect_request(self, req, fp, code, msg, headers, newurl):
        return None


class OpenAIProvider(LLMProvider):
    """Stage answers from a chat-completions API with structured output (the stage schema as ``response_format``).

    An HTTP 200 body that is no chat completion, holds no choice or no text, or is a refusal is a failed
    attempt (repaired like a wrong answer); an answer cut off at ``max_tokens`` (``finish_reason`` ``length``)
    is told so in the repair. HTTP 408/409/429/5xx are retried ``http_retries`` times (after the server's
    ``retry-after``, at most 30 s, else 0.5 s doubling); other HTTP statuses, timeouts and network failures are
    a ProviderError naming the status and what to check. ``strict=False`` sends the schema as pydantic writes
    it, for a server that refuses strict mode.
    """

    name = "openai"

    def __init__(
        self,
        model: str | None = None,
        *,
        api_key: str | None = None,
        base_url: str | None = None,
        **settings: Any,
    ) -> None:
        """``settings``: the other fields of :class:`OpenAIConfig` (timeout, http_retries, temperature, max_tokens,
        cache_root, strict, max_retries, cache), each defaulting there."""
        url = (base_url or os.environ.get(BASE_URL_ENV) or DEFAULT_BASE_URL).strip().rstrip("/")
        hosted = url == DEFAULT_BASE_URL
        key = api_key or os.environ.get(API_KEY_ENV) or ""
        if hosted and not key:
            raise ConfigError(
                f"the openai provider needs an API key for the hosted OpenAI API ({DEFAULT_BASE_URL}): set "
                f"{API_KEY_ENV} (or pass api_key=); a local server (vLLM, Ollama, llama.cpp, LM Studio) needs "
                f"none: set {BASE_URL_ENV} to its URL (e.g. http://localhost:11434/v1); or use the offline provider"
            )
        chosen = model or os.environ.get(MODEL_ENV) or (DEFAULT_MODEL if hosted else "")
        if not chosen:
            raise ConfigError(
                f"the openai provider needs a model name for the server at {url}: set {MODEL_ENV} (or pass "
                f"model=) to a model it serves, e.g. {MODEL_ENV}=llama3.1 for Ollama"
            )
        config = OpenAIConfig(model=chosen, base_url=url, **settings)
        super().__init__(config)
        self._headers = {"content-type": "application/json", "accept": "application/json"}
        if key:
            self._headers["authorization"] = f"Bearer {key}"
        self._opener = urllib.request.build_opener(_NoRedirect)

    @property
    def config(self) -> OpenAIConfig:
        return self._config  # type: ignore[return-value]  # always an OpenAIConfig: set in __init__

    @property
    def url(self) -> str:
        """Where every request goes."""
        return f"{self.config.base_url}/chat/completions"

    def _call(self, stage: StageSpec, system: str, messages: list[dict[str, Any]]) -> str:
        """One request, retried on 408/409/429/5xx; the HTTP 200 body. Other failures become ProviderError."""
        schema = stage.output_type.model_json_schema()
        request: dict[str, Any] = {
            "model": self.model,
            "messages": [{"role": "system", "content": system}, *messages],
            "response_format": {"type": "json_schema", "json_schema": {
                "name": stage.output_type.__name__,
                "schema": strict_schema(schema) if self.config.strict else schema,
                "strict": self.config.strict,
            }},
            "max_tokens": self.config.max_tokens,
        }
        if self.config.temperature is not None:
            request["temperature"] = self.config.temperature
        data = json.dumps(request).encode()
        retries, attempt = self.config.http_retries, 0
        while True:
            status, text, headers = self._post(stage, data)
            if 200 <= status < 300:
                return text
            if status not in _RETRIED or attempt == retries:
                raise ProviderError(self._http_problem(stage, status, text, retried=attempt))
            time.sleep(_backoff(headers, attempt))
            attempt += 1

    def _post(self, stage: StageSpec, data: bytes) -> tuple[int, str, Message]:
        """The status, body text and headers of one POST; ProviderError when no HTTP reply came."""
        req = urllib.request.Request(self.url, data=data, headers=self._headers, method="POST")
        try:
            with self._opener.open(req, timeout=self.config.timeout) as resp:
                return resp.status, _read(resp), resp.headers
        except urllib.error.HTTPError as exc:
            with exc:
                return exc.code, _read(exc), exc.headers
        except TimeoutError as exc:
            raise self._timeout(stage) from exc
        except urllib.error.URLError as exc:
            if isinstance(exc.reason, TimeoutError):
                raise self._timeout(stage) from exc
            raise self._unreachable(stage, exc.reason) from exc
        except (OSError, http.client.HTTPException) as exc:  # a connection reset, a reply that is no HTTP
            raise self._unreachable(stage, exc) from exc

    def _timeout(self, stage: StageSpec) -> ProviderError:
        return ProviderError(
            f"stage {stage.name!r}: the OpenAI-compatible API at {self.config.base_url} did not answer within "
            f"{self.config.timeout:g} s; raise it (--llm-timeout SECONDS on the command line, "
            "RunConfig(llm_timeout=...) in the API; a model served on a CPU may need minutes) or check the server"
        )

    def _unreachable(self, stage: StageSpec, reason: object) -> ProviderError:
        return ProviderError(
            f"stage {stage.name!r}: cannot reach the OpenAI-compatible API at {self.config.base_url} ({reason}); "
            f"check that the server is running and {BASE_URL_ENV}, or use the offline provider"
        )

    def _http_problem(self, stage: StageSpec, status: int, text: str, *, retried: int) -> str:
        head = f"stage {stage.name!r}: the OpenAI-compatible API at {self.config.base_url} answered HTTP {status}"
        detail = _error_detail(text)
        if status in (401, 403):
            return f"{head} ({detail}): the API key is missing or was rejected; check {API_KEY_ENV}"
        if status == 404:
            return (f"{head} ({detail}): check {BASE_URL_ENV} (it ends where /chat/completions starts, "
                    f"usually in /v1) and that the server serves the model {self.model!r} ({MODEL_ENV})")
        if status in (400, 422):
            return (f"{head} ({detail}): the server refused the request; check that it serves the model "
                    f"{self.model!r} ({MODEL_ENV}) and supports response_format json_schema (structured output), "
                    "or pass strict=False")
        if retried:
            return (f"{head} after {retried} retries ({detail}); try again later, raise http_retries, "
                    "or check the server")
        if 300 <= status < 400:
            return f"{head} (a redirect, not followed: a POST would lose its body); set {BASE_URL_ENV} to the final URL"
        return f"{head} ({detail})"

    def _picture_part(self, picture: Picture) -> dict[str, Any]:
        return {"type": "image_url", "image_url": {"url": f"data:image/png;base64,{picture_b64(picture)}"}}

    def _read_reply(self, body: str) -> tuple[str, str | None]:
        text, finish_reason = _reply_text(body)
        return text, ("finish_reason 'length'" if finish_reason == "length" else None)


def _read(resp: Any) -> str:
    """At most ``_MAX_BODY`` bytes of a reply, as text; a longer reply is a ProviderError."""
    raw = resp.read(_MAX_BODY + 1)
    if len(raw) > _MAX_BODY:
        raise ProviderError(f"the API's reply is longer than {_MAX_BODY} bytes; refused")
    return raw.decode("utf-8", errors="replace")


def _backoff(headers: Message, attempt: int) -> float:
    """Seconds before retry ``attempt + 1``: the server's retry-after-ms / retry-after, else 0.5 s doubling."""
    for name, scale in (("retry-after-ms", 0.001), ("retry-after", 1.0)):
        try:
            wait = float(headers.get(name, "")) * scale
        except ValueError:
            continue
        if wait >= 0:
            return min(wait, _MAX_BACKOFF_S)
    return min(0.5 * 2 ** attempt, _MAX_BACKOFF_S)


def _error_detail(text: str) -> str:
    """The ``error.message`` of an error body (OpenAI's shape, which vLLM and Ollama copy), else its start."""
    try:
        body = json.loads(text)
    except ValueError:
        body = None
    error = body.get("error") if isinstance(body, dict) else None
    message = error.get("message") if isinstance(error, dict) else error
    if isinstance(message, str) and message.strip():
        return repr(message[:300])
    return shown_body(text) if text else "no body"


def _reply_text(body: str) -> tuple[str, str | None]:
    """The first choice's message text and finish reason of a chat completion; ProviderError for any other shape."""
    shown = shown_body(body)
    completion = json_body(body)
    if not isinstance(completion, dict):
        raise ProviderError(f"the API's HTTP 200 reply is not a chat completion ({json_kind(completion)}): {shown}")
    choices = completion.get("choices")
    if not isinstance(choices, list) or not choices:
        raise ProviderError(f"the API's HTTP 200 reply is not a chat completion (no choices): {shown}")
    choice = choices[0]
    message = choice.get("message") if isinstance(choice, dict) else None
    if not isinstance(message, dict):
        raise ProviderError(f"the API's HTTP 200 chat completion has a choice without a message: {shown}")
    finish_reason = choice.get("finish_reason")
    refusal = message.get("refusal")
    if isinstance(refusal, str) and refusal.strip():
        raise ProviderError(f"the model refused to answer: {shown_body(refusal)}")
    content = message.get("content")
    if content is not None and not isinstance(content, str):
        raise ProviderError(f"the API's HTTP 200 message content is not text: {shown}")
    if not content:
        raise ProviderError(f"the answer held no text (finish_reason {finish_reason!r})")
    return content, finish_reason


def strict_schema(schema: dict[str, Any]) -> dict[str, Any]:
    """``schema`` (pydantic's JSON schema of an answer type) as OpenAI's strict structured output takes it.

    Every object lists all its properties as required and allows no others, a ``default`` of null goes, and a
    ``$ref`` with sibling keys is inlined (strict mode allows none beside it), as the openai SDK's own
    ``to_strict_json_schema`` does. Optional fields thus become fields the model must write; the answer is
    validated by the stage's pydantic type all the same.
    """
    defs = schema.get("$defs", {})

    def walk(node: Any) -> Any:
        if isinstance(node, list):
            return [walk(n) for n in node]
        if not isinstance(node, dict):
            return node
        ref = node.get("$ref")
        if isinstance(ref, str) and len(node) > 1 and ref.startswith("#/$defs/"):
            return walk({**defs[ref.removeprefix("#/$defs/")], **{k: v for k, v in node.items() if k != "$ref"}})
        out = {k: walk(v) for k, v in node.items() if not (k == "default" and v is None)}
        if out.get("type") == "object" and isinstance(out.get("properties"), dict):
            out["additionalProperties"] = False
            out["required"] = list(out["properties"])
        return out

    return walk(schema)

