"""The provider interface every provider implements, and what every LLM provider shares.

:mod:`rail_mj.llm.providers` (offline library, :func:`get_provider`) imports the
Anthropic provider only when it is asked for, and the LLM providers import this
module, so none imports another at load time and the SDK stays unloaded.

A provider is configured once, at construction, with a frozen config (like
mujoco_playground's ``MjxEnv`` locking its config); the stage functions then
take only a request and the provider.

:class:`LLMProvider` is the provider-neutral half of an LLM provider (Anthropic's
Messages API, OpenAI-compatible chat completions): the response cache, the
validation of an answer against the stage's schema and check, the repair rounds
and the reading of an untrusted HTTP 200 body. A subclass sends one request and
reads the text out of its reply.
"""

from __future__ import annotations

import json
from abc import ABC, abstractmethod
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, ClassVar

import pydantic
from pydantic import BaseModel, ConfigDict, Field

from rail_mj.affordances import normalize
from rail_mj.core.config import config_error
from rail_mj.core.errors import (
    ConfigError,
    FragmentError,
    ProviderError,
    StageError,
    UnknownAffordanceError,
    UnsafeCodeError,
)
from rail_mj.llm.cache import ResponseCache, cache_enabled, cache_key
from rail_mj.llm.checks import InvalidAnswerError
from rail_mj.llm.pictures import Picture, pictures_key
from rail_mj.llm.prompts import StageSpec, repair_prompt, system_prompt, user_prompt

__all__ = [
    "DEFAULT_TEMPERATURE",
    "MODEL_ENV",
    "LLMConfig",
    "LLMProvider",
    "Provider",
    "ProviderConfig",
    "REJECTIONS",
    "json_body",
    "json_kind",
    "shown_body",
]

#: Errors a check raises for an answer that parsed but is wrong (repairable by an LLM).
REJECTIONS: tuple[type[Exception], ...] = (InvalidAnswerError, FragmentError, UnsafeCodeError)
#: Environment variable naming the LLM's model (every LLM provider reads it).
MODEL_ENV = "RAIL_MJ_MODEL"
#: The paper's sampling temperature.
DEFAULT_TEMPERATURE = 0.1


class ProviderConfig(BaseModel):
    """Settings every provider takes, fixed for its life; a bad value is a ConfigError naming its range."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    max_retries: int = Field(default=2, ge=0, strict=True, description="repair rounds per stage after a rejected "
                                                                         "answer")
    cache: bool = Field(default=True, strict=True, description="read and write the on-disk answer cache "
                                                               "(RAIL_MJ_NO_CACHE=1 still turns it off)")

    def __init__(self, **data: Any) -> None:
        try:
            super().__init__(**data)
        except pydantic.ValidationError as exc:
            raise config_error(type(self), exc) from None


class Provider(ABC):
    """Answers stage requests; ``check`` raises one of ``REJECTIONS`` for an unacceptable answer."""

    name: ClassVar[str]
    #: Whether the provider imagines affordances outside the registry (an LLM can; the offline library cannot).
    novel_affordances: ClassVar[bool]

    def __init__(self, config: ProviderConfig) -> None:
        self._config = config
        #: requests sent to the model per stage (a stage's first attempt), and repair rounds per stage, since the
        #: provider was made; a cached answer sends none
        self.calls: Counter[str] = Counter()
        self.repairs: Counter[str] = Counter()

    @property
    def config(self) -> ProviderConfig:
        return self._config

    @property
    @abstractmethod
    def model(self) -> str:
        """The model that answers (a fixed label for the offline library)."""

    def affordance_name(self, name: str) -> str:
        """The name that stage requests carry: the registry's canonical name when it knows ``name`` (any
        spelling, alias or plural), else the text as given when this provider imagines novel affordances.

        Raises ConfigError for an empty name and UnknownAffordanceError (listing the known names) for an
        unregistered one when the provider cannot imagine it.
        """
        text = name.strip() if isinstance(name, str) else ""
        if not text:
            raise ConfigError(f"an affordance name must be non-empty text; got {name!r}")
        try:
            return normalize(text)
        except UnknownAffordanceError:
            if self.novel_affordances:
                return text
            raise

    @property
    def sees_pictures(self) -> bool:
        """Whether requests go with pictures (:class:`~rail_mj.llm.pictures.Picture`) to this provider's model."""
        return False

    @abstractmethod
    def answer(self, stage: StageSpec, request: BaseModel, check: Callable[[Any], object],
               pictures: Sequence[Picture] = ()) -> Any:
        """A validated answer of type ``stage.output_type``; StageError when none is found. ``pictures`` go with
        the request to a model that sees them (:attr:`sees_pictures`); other providers leave them."""


class LLMConfig(ProviderConfig):
    """The settings every LLM provider takes, fixed at construction (an API key stays with the provider only)."""

    model: str = ""
    base_url: str | None = None
    timeout: float = Field(default=120.0, gt=0, description="s per request")
    http_retries: int = Field(default=2, ge=0, description="retries of HTTP 429/5xx")
    temperature: float | None = DEFAULT_TEMPERATURE
    max_tokens: int = Field(default=8192, ge=1)
    cache_root: Path | None = Field(default=None, description="default: cache_dir('llm')")
    pictures: bool = Field(default=True, description="send stage 7 a picture of each pose with its plan's end "
                                                     "state (a server that refuses or fails on them is asked again "
                                                     "without)")


class LLMProvider(Provider):
    """Stage answers from a model behind an HTTP API, validated, repaired and cached.

    An answer that fails its schema or check, or an HTTP 200 reply that :meth:`_read_reply` cannot use
    (it raises ProviderError), is a failed attempt: it is sent back with the error text for up to
    ``max_retries`` repair rounds, then StageError. Validated answers are cached (see
    :mod:`rail_mj.llm.cache`) unless ``cache`` is False. A ProviderError from :meth:`_call` (HTTP and
    network failures) ends the stage at once. Affordances outside the registry are imagined too.
    """

    novel_affordances = True

    def __init__(self, config: LLMConfig) -> None:
        super().__init__(config)
        self._responses = ResponseCache(config.cache_root)
        #: why the model was found to take no pictures (its API refused a request with them), else None
        self.pictures_refused: str | None = None

    @property
    def sees_pictures(self) -> bool:
        return self.config.pictures and self.pictures_refused is None

    @abstractmethod
    def _picture_part(self, picture: Picture) -> dict[str, Any]:
        """One picture as a content block of this API's user message."""

    def _content(self, text: str, pictures: Sequence[Picture]) -> str | list[dict[str, Any]]:
        """A user message's content: the text, then each picture after its caption."""
        if not pictures:
            return text
        parts: list[dict[str, Any]] = [{"type": "text", "text": text}]
        for p in pictures:
            parts += [{"type": "text", "text": p.caption}, self._picture_part(p)]
        return parts

    @property
    def config(self) -> LLMConfig:
        return self._config  # type: ignore[return-value]  # always an LLMConfig: set in __init__

    @property
    def model(self) -> str:
        return self.config.model

    @abstractmethod
    def _call(self, stage: StageSpec, system: str, messages: list[dict[str, Any]]) -> str:
        """One request (the system prompt, then ``messages``); the raw HTTP 200 body, ProviderError on failure."""

    @abstractmethod
    def _read_reply(self, body: str) -> tuple[str, str | None]:
        """The answer text of an HTTP 200 body, and the API's reason when it was cut off at ``max_tokens``
        (e.g. ``"stop_reason 'max_tokens'"``), else None; ProviderError for a body of any other shape."""

    def answer(self, stage, request, check, pictures=()):
        max_retries = self.config.max_retries
        pictures = tuple(pictures) if self.sees_pictures else ()
        request_json = request.model_dump(mode="json")

        def keyed() -> dict[str, Any]:  # what the cache keys the request by: with its pictures, what they draw
            return {**request_json, "pictures": pictures_key(pictures)} if pictures else request_json

        key = cache_key(self.name, self.model, stage.version, stage.name, keyed())
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
        messages: list[dict[str, Any]] = [{"role": "user", "content": self._content(user_prompt(request), pictures)}]
        system = system_prompt(stage)
        problem = ""
        for attempt in range(max_retries + 1):
            (self.repairs if attempt else self.calls)[stage.name] += 1
            try:
                body = self._call(stage, system, messages)
            except ProviderError as exc:
                if not pictures or attempt:
                    raise
                # a model that takes no pictures (its server refuses them with an HTTP 400, or fails on them with
                # another error): the same request as text, and no pictures from now on
                self.pictures_refused = str(exc)
                pictures = ()
                key = cache_key(self.name, self.model, stage.version, stage.name, keyed())
                messages[0] = {"role": "user", "content": user_prompt(request)}
                body = self._call(stage, system, messages)
            try:
                text, cut_reason = self._read_reply(body)
            except ProviderError as exc:  # an HTTP 200 that is no usable reply: a failed attempt
                problem = str(exc)
                messages.append({"role": "user", "content": repair_prompt(problem)})
                continue
            turn = [{"role": "assistant", "content": text}] if text.strip() else []
            try:
                result = stage.output_type.model_validate_json(text)
            except pydantic.ValidationError as exc:
                cut = (f"the answer was cut off at max_tokens={self.config.max_tokens} ({cut_reason}); "
                       "give a complete, shorter answer; " if cut_reason else "")
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
                        "stage": stage.name, "request": keyed()}
                self._responses.put(key, result.model_dump_json(), meta)
            return result
        raise StageError(
            f"stage {stage.name!r} gave no valid answer in {max_retries + 1} attempts "
            f"(model {self.model}); last problem: {problem}"
        )


_JSON_TYPES = {list: "array", str: "string", int: "number", float: "number", bool: "boolean", type(None): "null"}


def shown_body(body: str) -> str:
    """The start of an untrusted reply body, quoted, for an error message."""
    return repr(body[:300]) + (f" (+{len(body) - 300} characters)" if len(body) > 300 else "")


def json_body(body: str) -> Any:
    """An HTTP 200 body as JSON; ProviderError naming its start when it is not JSON."""
    try:
        return json.loads(body)
    except ValueError:
        raise ProviderError(f"the API's HTTP 200 reply is not JSON: {shown_body(body)}") from None


def json_kind(value: Any) -> str:
    """``a JSON array`` / ``a JSON null`` ...: what a JSON value that is no object is."""
    return f"a JSON {_JSON_TYPES[type(value)]}"
