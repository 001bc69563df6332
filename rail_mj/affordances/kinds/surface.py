"""``surface``: a flat box placed on top. Success: it rests level on top at table height, at the centre and
off centre. A row with ``legroom`` (a table) is used from beside it, so the pose must leave room for a person's
feet under the top's edge somewhere along it (between legs, past a pedestal's foot, into a desk's knee space or a
console's open compartment): a foot gets under the middle of the footprint at toe height
(:func:`rail_mj.stable_poses.legroom.toe_room`), where a closed block, a bathtub on its side or an upturned tub
meets a wall at the edge."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, cast

from rail_mj.affordances.kinds.base import (
    MAX_OBJECT_TILT_DEG,
    SIDES,
    AgentShape,
    box_agent,
    register_kind,
    rest_scoring,
)
from rail_mj.affordances.kinds.lowering import Lowering
from rail_mj.affordances.row import Affordance, KindParams
from rail_mj.core.profile import CandidateInteraction, PoseCandidates, ScoringCode
from rail_mj.mjcf.body import body_size
from rail_mj.stable_poses.legroom import TOE_SLAB

__all__ = ["SurfaceParams", "Surface"]


@dataclass(frozen=True)
class SurfaceParams(KindParams):
    """A surface row's own field: whether it is used from beside it."""

    DOCS: ClassVar[dict[str, str]] = {
        "legroom": "true: used from beside it, so a person's feet must get under its top's edge (a table)"}

    legroom: bool = False  # used from beside it, so a person's feet go under its top's edge

_HALF_Z = 0.015  # the book's half height, m: a 3 cm book
#: How many of the five lowering plans (the centre and one to each side) must succeed: all but one. A top holds
#: the box placed off centre too, a small pedestal foot or a stretcher only at one place.
_MIN_PLANS = len(SIDES)
#: A top has free space above it: the box rests at least this high in the pose's box (its centre, in units of
#: the box's half height; 1 = the box top). Upside down, a console holds the box on its bottom among its legs,
#: which rise 8 cm or more above it (0.8 or lower in its 0.7 m box); a stretcher or a shelf is lower still.
_FREE_ABOVE = 0.9
#: The foot that must get under a table's top: an adult's (Winter Fig. 4.1, 0.055 H), as the slab it is mapped in.
_FOOT = body_size(1.0).foot_breadth


@register_kind
class Surface(Lowering):
    name = "surface"
    params_model = SurfaceParams
    agent_description = "One flat box standing for a book or a dish placed on the object."
    interaction_description = ("The box is lowered onto the object from above at its centre and at offsets to each "
                               "side; released at the first contact.")
    expected_outcome = ("The box rests level on top of the {name}, not touching the ground, and the {name} does "
                        "not tip over.")
    offset = 0.75  # three quarters out to the edge: where a place setting goes, not over it
    target = "the top"
    max_agent_tilt = 10  # a glass stands on a top within 10 deg of level, a book slides at 15 (LEVEL_DEG)

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        # a book or a dish, a quarter of the top across: sized to the top, as a figure's table is to the figure
        # (the top's size prior keeps it a coaster to a tray)
        return box_agent("book", (0.12 * dims[1],) * 2 + (_HALF_Z,))

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        # on top: above the box's middle (in a tall object a board halfway up is no top); how high the top
        # stands is the height's prior, not the physics'
        return rest_scoring(aff, shape, "0.0", "np.inf", self.max_agent_tilt, MAX_OBJECT_TILT_DEG, "level on top")

    def window(self, aff: Affordance) -> tuple[float, float]:
        # a top is where the box rests at the top of the pose's box (the free-space rule below), at any height
        return -math.inf, math.inf

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        ok, why = super().accept(aff, c, h)
        # the item belongs on the top, with free space above it: not on a stretcher, a shelf or among legs
        if ok and c.summary.mean_height < _FREE_ABOVE:
            below = (1.0 - c.summary.mean_height) * h[2]
            return False, (f"the agent rests {below:.2f} m below the object's top: parts of it rise above this "
                           "surface, it is no top with free space above it")
        return ok, why

    def accept_pose(
        self, aff: Affordance, accepted: list[CandidateInteraction], pose: PoseCandidates
    ) -> tuple[list[CandidateInteraction], str]:
        if len(accepted) < _MIN_PLANS:
            return [], (f"only {len(accepted)} of the placements hold the box; a {aff.name} top holds it at the "
                        f"centre and off centre ({_MIN_PLANS} needed)")
        if cast(SurfaceParams, aff.params).legroom and pose.toe_room is not None and pose.toe_room < _FOOT:
            return [], (f"no foot {_FOOT:.3f} m broad gets under the top's middle {TOE_SLAB[0]:g}-{TOE_SLAB[1]:.3f} m "
                        "above the floor from any side: no room for feet under the top, which a "
                        f"{aff.name} is used from beside")
        return accepted, ""

