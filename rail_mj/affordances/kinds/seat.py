"""``seat``: a box "pelvis" lowered onto the object from above, or arriving from a side above seat height.

Success: the pelvis rests upright on the object alone at seat height.
"""

from __future__ import annotations

from collections.abc import Sequence

from rail_mj.affordances.kinds.base import (
    SIDES,
    AgentShape,
    Kind,
    box_agent,
    clearance,
    rest_accept,
    rest_bounds,
    rest_scoring,
    rest_window,
    rest_words,
    side_offset,
    via,
)
from rail_mj.affordances.registry import Affordance
from rail_mj.llm.schemas import AgentLayout, CandidateInteraction, MotionPlan, ScoringCode, ViaPose

__all__ = ["Seat"]

#: The contact patch of a sitting pelvis, 0.2 m across: fits the narrowest seat (0.3 m) and the gap between
#: armrests as the object's convex hulls render it (a 0.28 m box lands on the armrests of a dataset chair).
_HALF = (0.1, 0.1, 0.05)
#: Seat height (m) the side plans arrive above: higher than any seat.
_ABOVE_SEAT = 0.65


class Seat(Kind):
    name = "seat"
    agent_description = "One box standing for a sitting person's pelvis's contact patch, 0.2 x 0.2 x 0.1 m."
    interaction_description = ("The pelvis is lowered onto the object from above, or arrives from the front, back, "
                               "left or right above seat height and is then lowered; it is released at the first "
                               "contact.")
    expected_outcome = ("The pelvis rests upright on the {name} at seat height (0.3–0.65 m above the ground), not "
                        "touching the ground, and the {name} does not tip over.")

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        # the sitter's size: a doll's pelvis on a doll's chair (the row's agent scale)
        return box_agent("pelvis", tuple(v * aff.scale for v in _HALF))

    def plans(self, shape: AgentShape) -> list[MotionPlan]:
        plans = [MotionPlan(name="above", description="Start with the pelvis above the object's centre; lower it "
                                                     "straight down onto the seat; release at the first contact.")]
        plans += [MotionPlan(name=side, description=f"Start at the {side} of the object, above seat height; move "
                                                    "horizontally over the object's centre; lower the pelvis "
                                                    "straight down; release at the first contact.")
                  for side, _, _ in SIDES]
        return plans

    def via_poses(self, plan: str, shape: AgentShape, layout: AgentLayout) -> list[ViaPose]:
        gap = clearance(shape)
        scale = shape.half_z / _HALF[2]  # the sitter's size against a person's
        above_seat = scale * _ABOVE_SEAT + shape.radius + 0.05 * scale  # the pelvis included
        bottom = shape.half_z + 0.02
        if plan == "above":
            return [via((0, 0, 1), (0, 0, shape.radius + gap)), via((0, 0, -1), (0, 0, bottom))]
        ux, uy = side_offset(plan, 1.0)
        return [via((ux, uy, -1), (ux * (shape.radius + gap), uy * (shape.radius + gap), above_seat)),
                via((0, 0, -1), (0, 0, above_seat)),
                via((0, 0, -1), (0, 0, bottom))]

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        return rest_scoring(aff, shape, *rest_bounds(aff), 15, 15, f"upright {rest_words(aff)}")

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        return rest_accept(c, h, rest_window(aff, _HALF[2] * aff.scale), 15)
