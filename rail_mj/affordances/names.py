"""Names in one place: how words become registry rows (spelling, plurals, aliases, articles); the request parser.

A requested name becomes a row here (:func:`get`, :func:`normalize`, :func:`label_key`): any case, spaces /
underscores / hyphens, simple plurals, aliases. A request's agent becomes its scale here (:func:`request_scale`:
"put the doll on the chair" asks for a doll's chair). The rows themselves, the figures' heights included, are
:mod:`rail_mj.affordances.registry`'s.

:func:`parse_words` is the offline request parser, of the form "VERB the AGENT in|into|inside|on|onto|on top of
the OBJECT". The object's words are matched against the registry (aliases, plurals, any spelling); words in front
of the name (a toy chair, the red pen holder) are dropped one by one until a registered name is left.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

from rail_mj.affordances.registry import (
    BY_NAME,
    FIGURE_HEIGHTS,
    PERSON_HEIGHT,
    ensure_entry_points,
    known_affordances,
)
from rail_mj.affordances.row import Affordance
from rail_mj.core.errors import ConfigError, UnknownAffordanceError

__all__ = [
    "get",
    "normalize",
    "label_key",
    "request_scale",
    "for_request",
    "singular",
    "REQUEST_FORM",
    "RequestWords",
    "parse_words",
]

def _spelling(name: str) -> str:
    return re.sub(r"[\s_\-]+", " ", name.strip().lower())


def _find(name: str) -> Affordance | None:
    ensure_entry_points()
    key = _spelling(name)
    candidates = [key]  # then simple plurals: shelves, benches, cups
    if key.endswith("ves"):
        candidates.append(key[:-3] + "f")
    if key.endswith("es"):
        candidates.append(key[:-2])
    if key.endswith("s"):
        candidates.append(key[:-1])
    return next((BY_NAME[c] for c in candidates if c in BY_NAME), None)


def get(name: str) -> Affordance:
    """The row of a name in any spelling (case, spaces / underscores / hyphens, simple plurals, aliases).

    Raises UnknownAffordanceError listing the known names when there is none.
    """
    found = _find(name)
    if found is None:
        raise UnknownAffordanceError(
            f"no offline imagination profile for affordance {name!r}; known: {', '.join(known_affordances())}. "
            "An LLM provider imagines novel affordances: use --provider anthropic with ANTHROPIC_API_KEY set, or "
            "--provider openai with OPENAI_BASE_URL (and RAIL_MJ_MODEL) or OPENAI_API_KEY set."
        )
    return found


def normalize(name: str) -> str:
    """The canonical name of a registered affordance (``"Trash_Bins"`` -> ``"trash bin"``); see :func:`get`."""
    return get(name).name


def label_key(name: str) -> str:
    """The identifier form of any affordance name, as label files write it: a registered name's key
    (``"Trash bins"``, ``"garbage can"`` -> ``"trash_bin"``), otherwise the name in lower case with runs of
    spaces, underscores and hyphens as one underscore (labels may name uses outside the registry)."""
    found = _find(name)
    return found.key if found is not None else _spelling(name).replace(" ", "_")


def _figure(agent: str) -> str | None:
    key = _spelling(agent)
    key = re.sub(r"^(the|a|an|my|this|that|some)\s+", "", key)
    candidates = [key, key[:-1] if key.endswith("s") else key, re.sub(r"(wo)?men$", r"\1man", key)]
    if key.endswith("ies"):
        candidates.append(key[:-3] + "y")  # teddies
    if key.endswith("children"):
        candidates.append(key[:-3])
    return next((c for c in candidates if c in FIGURE_HEIGHTS), None)


def request_scale(agent: str | None) -> float:
    """Size of a request's agent relative to a person's: a figure's height / :data:`PERSON_HEIGHT` (a doll
    0.18), 1 for every other agent (an item a person carries) and for none."""
    if agent is None:
        return 1.0
    figure = _figure(agent)
    return 1.0 if figure is None else FIGURE_HEIGHTS[figure] / PERSON_HEIGHT


def for_request(name: str, agent: str | None) -> Affordance:
    """The row of ``name`` (see :func:`get`) scaled to the request's agent (:func:`request_scale`)."""
    return get(name).scaled(request_scale(agent))


_VERBS = ("put", "place", "set", "drop", "pour", "lay", "sit", "seat", "stand", "move", "store", "keep", "hang")
#: Longest first, so "on top of" wins over "on" and "inside of" over "inside" and "in".
_PREPOSITIONS: dict[str, Literal["in", "on"]] = {"on top of": "on", "onto": "on", "upon": "on", "on": "on",
                 "inside of": "in", "inside": "in", "into": "in", "in": "in"}
_ARTICLES = ("the", "a", "an", "some", "this", "that", "these", "those", "my", "your", "its", "his", "her", "our")
_PATTERN = re.compile(
    r"^(?:(?:please|kindly)\s+)?(?:(?:can|could|would|will)\s+you\s+(?:please\s+)?)?"
    rf"(?:(?:{'|'.join(_VERBS)})\s+)?"
    rf"(?P<agent>.+?)\s+(?P<prep>{'|'.join(re.escape(p) for p in _PREPOSITIONS)})\s+(?P<object>.+?)"
    r"(?:\s+(?:please|for me))?$"
)
#: The form the offline parser reads, as its errors name it.
REQUEST_FORM = "'put the AGENT in|into|inside|on|onto|on top of the OBJECT', e.g. 'put the apple in the bowl'"


@dataclass(frozen=True)
class RequestWords:
    """What the offline parser reads in a request: the agent (singular, no article), the affordance (registry
    name) and the preposition (in | on)."""

    agent: str
    affordance: str
    preposition: Literal["in", "on"]


def _words(text: str) -> list[str]:
    return [w for w in re.sub(r"[^\w\s'-]", " ", text.lower()).split() if w]


def _drop_articles(words: list[str]) -> list[str]:
    while words and words[0] in _ARTICLES:
        words = words[1:]
    return words


def singular(word: str) -> str:
    """A simple English singular: teddies -> teddy, boxes -> box, apples -> apple; glass, water stay."""
    if len(word) > len("ies") and word.endswith("ies"):
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


def parse_words(text: str) -> RequestWords:
    """The offline request parser (see the module's doc).

    Raises ConfigError for a sentence not of the form "put the AGENT in/on the OBJECT", and
    UnknownAffordanceError, listing the known names, when the object names no registered affordance.
    """
    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f"a request must be a sentence of the form {REQUEST_FORM}; got {text!r}")
    match = _PATTERN.match(" ".join(_words(text)))
    if match is None:
        raise ConfigError(f"cannot read the request {text!r}: give it the form {REQUEST_FORM}")
    agent = _drop_articles(match["agent"].split())
    obj = _drop_articles(match["object"].split())
    if not agent or not obj:
        raise ConfigError(f"cannot read the request {text!r}: it names no agent or no object; give it the form "
                          f"{REQUEST_FORM}")
    agent[-1] = singular(agent[-1])
    return RequestWords(agent=" ".join(agent), affordance=_affordance(obj, text),
                        preposition=_PREPOSITIONS[match["prep"]])


