"""The provider interface every provider implements, apart from the providers themselves.

:mod:`rail_mj.llm.providers` (offline library, :func:`get_provider`) imports the
Anthropic provider only when it is asked for, and the Anthropic provider imports
this module, so neither imports the other at load time and the SDK stays unloaded.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

from pydantic import BaseModel

from rail_mj.errors import FragmentError, UnsafeCodeError
from rail_mj.llm.checks import InvalidAnswerError
from rail_mj.llm.prompts import StageSpec

__all__ = ["Provider", "REJECTIONS"]

#: Errors a check raises for an answer that parsed but is wrong (repairable by an LLM).
REJECTIONS: tuple[type[Exception], ...] = (InvalidAnswerError, FragmentError, UnsafeCodeError)


class Provider(ABC):
    """Answers stage requests; ``check`` raises one of ``REJECTIONS`` for an unacceptable answer."""

    name: str
    model: str

    @abstractmethod
    def answer(
        self,
        stage: StageSpec,
        request: BaseModel,
        check: Callable[[Any], None],
        *,
        max_retries: int = 2,
        cache: bool = True,
    ) -> Any:
        """A validated answer of type ``stage.output_type``; StageError when none is found."""
