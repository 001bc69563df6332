"""The provider interface every provider implements, apart from the providers themselves.

:mod:`rail_mj.llm.providers` (offline library, :func:`get_provider`) imports the
Anthropic provider only when it is asked for, and the Anthropic provider imports
this module, so neither imports the other at load time and the SDK stays unloaded.

A provider is configured once, at construction, with a frozen config (like
mujoco_playground's ``MjxEnv`` locking its config); the stage functions then
take only a request and the provider.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

from pydantic import BaseModel

from rail_mj.affordances import normalize
from rail_mj.core.errors import ConfigError, FragmentError, UnknownAffordanceError, UnsafeCodeError
from rail_mj.llm.checks import InvalidAnswerError
from rail_mj.llm.prompts import StageSpec

__all__ = ["Provider", "ProviderConfig", "REJECTIONS"]

#: Errors a check raises for an answer that parsed but is wrong (repairable by an LLM).
REJECTIONS: tuple[type[Exception], ...] = (InvalidAnswerError, FragmentError, UnsafeCodeError)


@dataclass(frozen=True)
class ProviderConfig:
    """Settings every provider takes, fixed for its life."""

    max_retries: int = 2  # repair rounds per stage after a rejected answer
    cache: bool = True  # read and write the on-disk answer cache (RAIL_MJ_NO_CACHE=1 still turns it off)

    def __post_init__(self) -> None:
        if isinstance(self.max_retries, bool) or not isinstance(self.max_retries, int) or self.max_retries < 0:
            raise ConfigError(f"max_retries must be an integer >= 0; got {self.max_retries!r}")
        if not isinstance(self.cache, bool):
            raise ConfigError(f"cache must be True or False; got {self.cache!r}")


class Provider(ABC):
    """Answers stage requests; ``check`` raises one of ``REJECTIONS`` for an unacceptable answer."""

    name: ClassVar[str]
    #: Whether the provider imagines affordances outside the registry (an LLM can; the offline library cannot).
    novel_affordances: ClassVar[bool]

    def __init__(self, config: ProviderConfig) -> None:
        self._config = config

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

    @abstractmethod
    def answer(self, stage: StageSpec, request: BaseModel, check: Callable[[Any], object]) -> Any:
        """A validated answer of type ``stage.output_type``; StageError when none is found."""
