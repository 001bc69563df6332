"""One file per kind of imagined physics, each a :class:`~rail_mj.affordances.kinds.base.Kind`.

``KINDS`` maps every :data:`~rail_mj.affordances.registry.KindName` to its one
instance; :func:`kind_of` resolves a registry row's kind.
"""

from __future__ import annotations

from rail_mj.affordances.kinds.base import AgentShape, Kind, judge_unregistered
from rail_mj.affordances.kinds.container import Container
from rail_mj.affordances.kinds.dish import Dish
from rail_mj.affordances.kinds.lie import Lie
from rail_mj.affordances.kinds.seat import Seat
from rail_mj.affordances.kinds.storage import Storage
from rail_mj.affordances.kinds.surface import Surface
from rail_mj.affordances.registry import Affordance

__all__ = ["AgentShape", "Kind", "KINDS", "kind_of", "judge_unregistered"]

KINDS: dict[str, Kind] = {k.name: k for k in (Container(), Seat(), Lie(), Surface(), Dish(), Storage())}


def kind_of(aff: Affordance) -> Kind:
    """The kind that imagines a registry row."""
    return KINDS[aff.kind]
