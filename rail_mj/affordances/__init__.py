"""What each affordance is: the registry (names, aliases, kind, definition, sizes, pose envelope, paper flag).

The kinds of physics that imagine them live in :mod:`rail_mj.affordances.kinds`,
which the offline provider imports; this package itself needs no LLM or physics
module, so the dataset's ground truth can read the names without them.
"""

from __future__ import annotations

from rail_mj.affordances.envelope import ANY, Envelope, Range
from rail_mj.affordances.registry import (
    LIQUID_RADIUS,
    PAPER_AFFORDANCES,
    REGISTRY,
    Affordance,
    Droplets,
    KindName,
    get,
    known_affordances,
    label_key,
    normalize,
)

__all__ = [
    "ANY",
    "Envelope",
    "Range",
    "LIQUID_RADIUS",
    "PAPER_AFFORDANCES",
    "REGISTRY",
    "Affordance",
    "Droplets",
    "KindName",
    "get",
    "known_affordances",
    "label_key",
    "normalize",
]
