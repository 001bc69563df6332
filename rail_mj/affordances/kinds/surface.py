"""``surface``: a flat box placed on top. Success: it rests level on top at table height, at the centre and
off centre. For a row with ``legroom`` (a table) the box also slides in just above the floor from each side: a
table is used from beside it, so from some side it gets under the top's edge (between legs, past a pedestal's
foot, into a desk's knee space), where a person's feet go; a closed block, a bathtub on its side or an
upturned tub meets a wall at the edge."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

from rail_mj.affordances.kinds.base import (
    GAP,
    MAX_OBJECT_TILT_DEG,
    SIDES,
    AgentShape,
    box_agent,
    clearance,
    register_kind,
    rest_scoring,
    side_offset,
    via,
)
from rail_mj.affordances.kinds.lowering import Lowering
from rail_mj.affordances.row import Affordance, KindParams
from rail_mj.core.profile import AgentLayout, CandidateInteraction, MotionPlan, PoseCandidates, ScoringCode, ViaPose

__all__ = ["SurfaceParams", "Surface"]


@dataclass(frozen=True)
class SurfaceParams(KindParams):
    """A surface row's own field: whether it is used from beside it."""

    legroom: bool = False  # used from beside it, so a person's feet go under its top's edge

_HALF_Z = 0.015  # the book's half height, m: a 3 cm book
#: How many of the five lowering plans (the centre and one to each side) must succeed: all but one. A top holds
#: the box placed off centre too, a small pedestal foot or a stretcher only at one place.
_MIN_PLANS = len(SIDES)
#: A top has free space above it: the box rests at least this high in the pose's box (its centre, in units of
#: the box's half height; 1 = the box top). Upside down, a console holds the box on its bottom among its legs,
#: which rise 8 cm or more above it (0.8 or lower in its 0.7 m box); a stretcher or a shelf is lower still.
_FREE_ABOVE = 0.9
#: Gap (m) between the floor and the sliding box's bottom: it slides without touching the floor (a touch releases
#: it) and over a pedestal's foot plate (3 cm), as feet do, under anything that leaves them room (a console's
#: 8 cm legs).
_SLIDE_LIFT = 0.035
#: Plans that slide the box in just above the floor from each side towards the middle.
_SLIDES = tuple(f"under_{side}" for side, _, _ in SIDES)


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

    def plans(self, shape: AgentShape) -> list[MotionPlan]:
        return super().plans(shape) + [
            MotionPlan(name=f"under_{side}", description=f"Start with the {shape.label} on the {side} of the object, "
                                                         f"{_SLIDE_LIFT:g} m above the floor; slide it horizontally "
                                                         "towards the middle under the object; release it at the "
                                                         "first contact (room for feet under the top's edge).")
            for side, _, _ in SIDES]

    def via_poses(self, plan: str, shape: AgentShape, layout: AgentLayout) -> list[ViaPose]:
        if plan not in _SLIDES:
            return super().via_poses(plan, shape, layout)
        ux, uy = side_offset(plan.removeprefix("under_"), 1.0)
        out, z = shape.radius + clearance(shape), shape.half_z + _SLIDE_LIFT
        # down beside the object's box from where the whole box clears the floor, then in
        return [via((ux, uy, -1), (ux * out, uy * out, shape.radius + GAP)),
                via((ux, uy, -1), (ux * out, uy * out, z)), via((0, 0, -1), (0, 0, z))]

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        # on top: above the box's middle (in a tall object a board halfway up is no top); how high the top
        # stands is the height's prior, not the physics'
        return rest_scoring(aff, shape, "0.0", "np.inf", self.max_agent_tilt, MAX_OBJECT_TILT_DEG, "level on top")

    def window(self, aff: Affordance) -> tuple[float, float]:
        # a top is where the box rests at the top of the pose's box (the free-space rule below), at any height
        return -math.inf, math.inf

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        if c.plan in _SLIDES:  # evidence of room under the top; where it comes to rest is no placement
            return False, "the box slid in above the floor probes the room under the top; it places nothing"
        ok, why = super().accept(aff, c, h)
        # the item belongs on the top, with free space above it: not on a stretcher, a shelf or among legs
        if ok and c.summary.mean_height < _FREE_ABOVE:
            below = (1.0 - c.summary.mean_height) * h[2]
            return False, (f"the agent rests {below:.2f} m below the object's top: parts of it rise above this "
                           "surface, it is no top with free space above it")
        return ok, why

    def evidence_plans(self, aff: Affordance, plans: Sequence[str]) -> set[str]:
        """The boxes slid in above the floor: where they stop, failed or not, is the room under the top."""
        return {p for p in plans if p in _SLIDES} if cast(SurfaceParams, aff.params).legroom else set()

    def accept_pose(
        self, aff: Affordance, accepted: list[CandidateInteraction], pose: PoseCandidates
    ) -> tuple[list[CandidateInteraction], str]:
        if len(accepted) < _MIN_PLANS:
            return [], (f"only {len(accepted)} of the placements hold the box; a {aff.name} top holds it at the "
                        f"centre and off centre ({_MIN_PLANS} needed)")
        # under the top: the slid box ends under the middle of the footprint, not in a recess at its edge (a
        # bathtub on its side, whose feet stick out sideways, leaves 10 cm between them)
        if cast(SurfaceParams, aff.params).legroom and not any(c.plan in _SLIDES and c.summary.frac_beneath_middle > 0
                                   for c in pose.candidates + pose.failed):
            return [], (f"the box slid in {_SLIDE_LIFT:g} m above the floor from every side stops at the object's "
                        f"edge: no room for feet under the top, which a {aff.name} is used from beside")
        return accepted, ""

