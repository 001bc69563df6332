"""One file per kind of imagined physics, each a :class:`~rail_mj.affordances.kinds.base.Kind` registered by
:func:`~rail_mj.affordances.kinds.base.register_kind`.

Importing this package imports every built-in kind's file, which registers it:
``KINDS`` maps each kind's name to its one instance; :func:`kind_of` resolves a
registry row's kind. A new built-in kind is a new file here plus its import below
(docs/new_affordance.md).
"""

from __future__ import annotations

from rail_mj.affordances.kinds.base import KINDS, AgentShape, Kind, judge_unregistered, kind_of, register_kind
from rail_mj.affordances.kinds.container import Container, ContainerParams, Droplets
from rail_mj.affordances.kinds.dish import Dish
from rail_mj.affordances.kinds.lie import Lie
from rail_mj.affordances.kinds.seat import Seat, SeatParams
from rail_mj.affordances.kinds.storage import Storage
from rail_mj.affordances.kinds.surface import Surface, SurfaceParams

__all__ = [
    "AgentShape",
    "Kind",
    "KINDS",
    "kind_of",
    "register_kind",
    "judge_unregistered",
    "Container",
    "ContainerParams",
    "Droplets",
    "Dish",
    "Lie",
    "Seat",
    "SeatParams",
    "Storage",
    "Surface",
    "SurfaceParams",
]
