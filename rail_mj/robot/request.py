"""Requests in words: "put the apple in the bowl" -> the agent, the affordance asked of the object, the preposition.

:func:`parse_request` is a typed stage (:func:`rail_mj.llm.parse_request_text`): an LLM provider reads the
sentence, the offline provider answers with :func:`parse_words`, a small parser of the form "VERB the AGENT
in|into|inside|on|onto|on top of the OBJECT". The object's words are matched against the affordance registry
(aliases, plurals, any spelling); words in front of the name (a toy chair, the red pen holder) are dropped one
by one until a registered name is left. The request's agent sets the scale of the imagination
(:func:`rail_mj.affordances.request_scale`: "put the doll on the chair" asks for a doll's chair).
"""

from __future__ import annotations

import re

from rail_mj.affordances import known_affordances, normalize
from rail_mj.core.errors import ConfigError, UnknownAffordanceError
from rail_mj.llm.schemas import Request, RequestText

__all__ = ["Request", "parse_request", "parse_words", "singular"]

_VERBS = ("put", "place", "set", "drop", "pour", "lay", "sit", "seat", "stand", "move", "store", "keep", "hang")
#: Longest first, so "on top of" wins over "on" and "inside of" over "inside" and "in".
_PREPOSITIONS = {"on top of": "on", "onto": "on", "upon": "on", "on": "on",
                 "inside of": "in", "inside": "in", "into": "in", "in": "in"}
_ARTICLES = ("the", "a", "an", "some", "this", "that", "these", "those", "my", "your", "its", "his", "her", "our")
_PATTERN = re.compile(
    r"^(?:(?:please|kindly)\s+)?(?:(?:can|could|would|will)\s+you\s+(?:please\s+)?)?"
    rf"(?:(?:{'|'.join(_VERBS)})\s+)?"
    rf"(?P<agent>.+?)\s+(?P<prep>{'|'.join(re.escape(p) for p in _PREPOSITIONS)})\s+(?P<object>.+?)"
    r"(?:\s+(?:please|for me))?$"
)
_FORM = "'put the AGENT in|into|inside|on|onto|on top of the OBJECT', e.g. 'put the apple in the bowl'"


def _words(text: str) -> list[str]:
    return [w for w in re.sub(r"[^\w\s'-]", " ", text.lower()).split() if w]


def _drop_articles(words: list[str]) -> list[str]:
    while words and words[0] in _ARTICLES:
        words = words[1:]
    return words


def singular(word: str) -> str:
    """A simple English singular: teddies -> teddy, boxes -> box, apples -> apple; glass, water stay."""
    if len(word) > 3 and word.endswith("ies"):
        return word[:-3] + "y"
    if re.search(r"(ss|x|ch|sh)es$", word):
        return word[:-2]
    if len(word) > 2 and word.endswith("s") and not word.endswith(("ss", "us", "is")):
        return word[:-1]
    return word


def _affordance(words: list[str], text: str) -> str:
    """The registered name the object's words end with (the longest such tail)."""
    for start in range(len(words)):
        try:
            return normalize(" ".join(words[start:]))
        except UnknownAffordanceError:
            continue
    raise UnknownAffordanceError(
        f"no registered affordance in {' '.join(words)!r} (from {text!r}); known: {', '.join(known_affordances())}"
    )


def parse_words(text: str) -> Request:
    """The offline request parser (see the module's doc).

    Raises ConfigError for a sentence not of the form "put the AGENT in/on the OBJECT", and
    UnknownAffordanceError, listing the known names, when the object names no registered affordance.
    """
    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f"a request must be a sentence of the form {_FORM}; got {text!r}")
    match = _PATTERN.match(" ".join(_words(text)))
    if match is None:
        raise ConfigError(f"cannot read the request {text!r}: give it the form {_FORM}")
    agent = _drop_articles(match["agent"].split())
    obj = _drop_articles(match["object"].split())
    if not agent or not obj:
        raise ConfigError(f"cannot read the request {text!r}: it names no agent or no object; give it the form "
                          f"{_FORM}")
    agent[-1] = singular(agent[-1])
    return Request(text=text, agent=" ".join(agent), affordance=_affordance(obj, text),
                   preposition=_PREPOSITIONS[match["prep"]])


def parse_request(text: str, provider: str = "offline") -> Request:
    """The agent, affordance (registry name) and preposition of a request, as the request-parser stage
    answers it with ``provider`` (``offline``: :func:`parse_words`; ``anthropic`` / ``auto``: an LLM, checked)."""
    from rail_mj.llm import parse_request_text

    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f"a request must be a sentence of the form {_FORM}; got {text!r}")
    return parse_request_text(RequestText(text=text), provider)
