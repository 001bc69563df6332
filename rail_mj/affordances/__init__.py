"""What each affordance is: the registry (names, aliases, kind, definition, sizes, pose envelope, paper flag).

The rows live in :mod:`rail_mj.affordances.registry`; how a name in words becomes a row (spelling, plurals,
aliases, a request's agent and its scale, the offline request parser) lives in :mod:`rail_mj.affordances.names`.

Rows beyond the built-in ones come from affordance files (TOML; :mod:`rail_mj.affordances.files` parses them,
:func:`load` registers them) and from installed packages' ``rail_mj.affordances`` entry points.

The kinds of physics that imagine them live in :mod:`rail_mj.affordances.kinds`,
which register themselves and their rows' parameter models; the registry imports
them for those models. This package needs no LLM or simulator module, so the
dataset's ground truth can read the names without them.
"""

from __future__ import annotations

from rail_mj.affordances.envelope import ANY, Envelope, Range
from rail_mj.affordances.names import for_request, get, label_key, normalize, request_scale
from rail_mj.affordances.registry import (
    FIGURE_HEIGHTS,
    LIQUID_RADIUS,
    PAPER_AFFORDANCES,
    PERSON_HEIGHT,
    REGISTRY,
    known_affordances,
    load,
    load_files,
    unload_all,
)
from rail_mj.affordances.row import Affordance, KindParams

__all__ = [
    "ANY",
    "FIGURE_HEIGHTS",
    "PERSON_HEIGHT",
    "Envelope",
    "Range",
    "LIQUID_RADIUS",
    "PAPER_AFFORDANCES",
    "REGISTRY",
    "Affordance",
    "KindParams",
    "get",
    "known_affordances",
    "load",
    "load_files",
    "unload_all",
    "label_key",
    "normalize",
    "for_request",
    "request_scale",
]
