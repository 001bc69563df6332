"""Requests in words for the robot: "put the apple in the bowl" -> the agent, the affordance, the preposition.

:func:`parse_request` is a typed stage (:func:`rail_mj.llm.parse_request_text`): an LLM provider reads the
sentence, the offline provider answers with :func:`rail_mj.affordances.names.parse_words`. The request's agent
sets the scale of the imagination (:func:`rail_mj.affordances.request_scale`: "put the doll on the chair" asks for
a doll's chair).
"""

from __future__ import annotations

from rail_mj.affordances.names import REQUEST_FORM
from rail_mj.core.errors import ConfigError
from rail_mj.llm import parse_request_text
from rail_mj.llm.schemas import Request, RequestText
from rail_mj.llm.stages import ProviderLike

__all__ = ["parse_request"]


def parse_request(text: str, provider: ProviderLike = "offline") -> Request:
    """The agent, affordance (registry name) and preposition of a request, as the request-parser stage
    answers it with ``provider`` (a name or a configured provider; ``offline``:
    :func:`rail_mj.affordances.names.parse_words`; ``anthropic`` / ``openai`` / ``auto``: an LLM, checked)."""
    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f"a request must be a sentence of the form {REQUEST_FORM}; got {text!r}")
    return parse_request_text(RequestText(text=text), provider)
