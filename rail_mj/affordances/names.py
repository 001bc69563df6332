"""Names in one place: how words become registry rows (spelling, plurals, aliases, articles); the request parser.

A requested name becomes a row here (:func:`get`, :func:`normalize`, :func:`label_key`): any case, spaces /
underscores / hyphens, simple plurals, aliases. A request's agent, or the owner its object's name gives, becomes
its scale here (:func:`request_scale`: "put the doll on the chair" and "put the cup on the doll's table" ask for a
doll's furniture). The rows themselves, the figures' heights included, are :mod:`rail_mj.affordances.registry`'s.

:func:`parse_words` is the offline request parser, of the form "VERB the AGENT in|into|inside|on|onto|on top of
the OBJECT". The object's words keep their meaning (:func:`object_name`): the whole name is matched first
(registry names, aliases, rows of loaded affordance files: "dog bed", "bedside table"), then without the words
that say nothing of its use or size (colours, materials, size words, "toy"), then its head noun, where the words
in front name whose it is (a doll's chair, a dog bed: :data:`ANIMAL_LENGTHS`). Any other word in front of a
name may make it another thing (a soap dish is no dinner plate), so such a name is refused, naming the closest
known names.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from rail_mj.affordances.kinds.base import kind_of
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
    "owner_scale",
    "for_request",
    "closest_names",
    "ANIMAL_LENGTHS",
    "ObjectName",
    "object_name",
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


def closest_names(name: str) -> list[str]:
    """The registered names and aliases spelt most like ``name`` (difflib's defaults: its three closest, at
    least 0.6 alike), best first; an alias as ``"alias (name)"``."""
    index = dict(BY_NAME)
    close = difflib.get_close_matches(_spelling(name), list(index))
    return [c if index[c].name == c else f"{c} ({index[c].name})" for c in close]


def _closest_text(name: str, head: str | None = None) -> str:
    """``closest: ...; `` for an error message: the row a head noun names first, when there is one."""
    close = [head] if head is not None else []
    close += [c for c in closest_names(name) if c != head]
    return f"closest: {', '.join(close)}; " if close else ""


def get(name: str) -> Affordance:
    """The row of a name in any spelling (case, spaces / underscores / hyphens, simple plurals, aliases).

    Raises UnknownAffordanceError naming the closest and the known names when there is none.
    """
    found = _find(name)
    if found is None:
        raise UnknownAffordanceError(
            f"no offline imagination profile for affordance {name!r}; {_closest_text(name)}"
            f"known: {', '.join(known_affordances())}. "
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


#: Body lengths (m) of the animals an object's name may say it is for ("dog bed"), nose to base of tail: an animal
#: lies along its body as a person along its height, so its bed is a person's scaled by length / PERSON_HEIGHT.
ANIMAL_LENGTHS: dict[str, float] = {
    # a medium dog (a ~20 kg border collie) is about 0.65 m nose to tail base; makers size a medium dog bed
    # 76-91 cm, that length plus room to stretch (0.65 / 1.7 makes a person's 1.6-2.6 m bed 0.61-0.99 m)
    "dog": 0.65,
}


def _animal(word: str) -> str | None:
    key = singular(_spelling(word))
    return key if key in ANIMAL_LENGTHS else None


def _owner(words: Sequence[str]) -> str | None:
    """The figure or animal that words in front of a name make it for (``doll's``, ``dolls'``, ``teddy bear``,
    ``dog``), else None."""
    text = re.sub(r"'s?$", "", " ".join(words))
    return _figure(text) or _animal(text)


def owner_scale(owner: str) -> float:
    """Size of the figure or animal an object is for relative to a person (:func:`request_scale`'s owner).

    Raises ConfigError naming the valid owners for any other."""
    figure, animal = _figure(owner), _animal(owner)
    if figure is not None:
        return FIGURE_HEIGHTS[figure] / PERSON_HEIGHT
    if animal is not None:
        return ANIMAL_LENGTHS[animal] / PERSON_HEIGHT
    raise ConfigError(f"no figure or animal {owner!r} sets the scale of an object; valid owners: "
                      f"{', '.join(sorted([*FIGURE_HEIGHTS, *ANIMAL_LENGTHS]))}")


def request_scale(agent: str | None, owner: str | None = None) -> float:
    """Size of what a request's object is for relative to a person: its ``owner``'s when its name gives one
    (:func:`owner_scale`: a doll's table, a dog bed), else its agent's: a figure's height /
    :data:`PERSON_HEIGHT` (a doll 0.18), 1 for every other agent (an item a person carries; an animal, which
    may be put on a person's bed or in a person's bathtub) and for none."""
    if owner is not None:
        return owner_scale(owner)
    if agent is None:
        return 1.0
    figure = _figure(agent)
    return 1.0 if figure is None else FIGURE_HEIGHTS[figure] / PERSON_HEIGHT


def for_request(name: str, agent: str | None, owner: str | None = None) -> Affordance:
    """The row of ``name`` (see :func:`get`) scaled to the request (:func:`request_scale`)."""
    return get(name).scaled(request_scale(agent, owner))


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


#: Words in front of a name that say nothing of its use or size (the dimension check judges the size): colours,
#: materials, size words and "toy" (a toy chair is a chair at its agent's scale).
_NEUTRAL = frozenset((
    "toy", "red", "blue", "green", "yellow", "white", "black", "brown", "grey", "gray", "pink", "orange", "purple",
    "wooden", "plastic", "metal", "glass", "ceramic", "porcelain", "clay", "stone", "wicker",
    "small", "little", "big", "large", "empty", "clean", "old", "new",
))


@dataclass(frozen=True)
class RequestWords:
    """What the offline parser reads in a request: the agent (singular, no article), the affordance (registry
    name), the preposition (in | on) and the owner the object's name gives (a doll's chair: ``doll``), if any."""

    agent: str
    affordance: str
    preposition: Literal["in", "on"]
    owner: str | None = None


@dataclass(frozen=True)
class ObjectName:
    """An object's name read whole: the registered affordance and whose it is (``doll`` in "doll's chair")."""

    affordance: str
    owner: str | None = None


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


def object_name(words: Sequence[str], text: str | None = None) -> ObjectName:
    """The affordance an object's words name, keeping every word's meaning (see the module's doc): the whole
    name, then without neutral words, then the head noun with its owner in front ("doll's chair": chair for a
    doll; "dog bed": bed for a dog, which sets only what an animal lies or sits on).

    Raises UnknownAffordanceError, naming the closest known names, for a name with any other word in front of a
    registered one, or with none (``text``, the request, is named in the message).
    """
    words = _drop_articles([w for w in (_spelling(w) for w in words) if w])
    phrase = " ".join(words)
    source = f" (from {text!r})" if text is not None else ""
    if not words:
        raise ConfigError(f"an object's name must have a word{source}")
    core = [w for w in words[:-1] if w not in _NEUTRAL] + words[-1:]
    for candidate in (words, core):
        found = _find(" ".join(candidate))
        if found is not None:
            return ObjectName(found.name)
    for start in range(1, len(core)):
        head = _find(" ".join(core[start:]))
        if head is None:
            continue
        front = core[:start]
        owner = _owner(front)
        if owner is not None and (owner in FIGURE_HEIGHTS or kind_of(head).sized_by_owner_body):
            return ObjectName(head.name, owner)
        why = (f"a {owner}'s body sets the size of what it lies or sits on, not of a {head.name} (a {head.kind}: "
               "sized by what it holds)" if owner is not None else
               f"{' '.join(front)!r} in front of {' '.join(core[start:])!r} ({head.name}) is no figure or animal "
               f"whose it is ({', '.join(sorted([*FIGURE_HEIGHTS, *ANIMAL_LENGTHS]))}) nor a colour, material or "
               "size word, so it may name another thing")
        raise UnknownAffordanceError(
            f"{phrase!r}{source} is no registered affordance: {why}; {_closest_text(phrase, head.name)}known: "
            f"{', '.join(known_affordances())}; an affordance file (--affordances-file) or an LLM provider "
            "adds a new one")
    raise UnknownAffordanceError(
        f"no registered affordance in {phrase!r}{source}; {_closest_text(phrase)}known: "
        f"{', '.join(known_affordances())}")


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
    name = object_name(obj, text)
    return RequestWords(agent=" ".join(agent), affordance=name.affordance, preposition=_PREPOSITIONS[match["prep"]],
                        owner=name.owner)


