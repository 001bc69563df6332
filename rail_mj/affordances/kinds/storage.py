"""``storage``: a small box pushed in horizontally. Success: it ends inside the box, resting on the object."""

from __future__ import annotations

from collections.abc import Sequence

from rail_mj.affordances.kinds.base import (
    GAP,
    MAX_OBJECT_TILT_DEG,
    MOST,
    SIDES,
    AgentShape,
    Kind,
    box_agent,
    clearance,
    register_kind,
    rest_scoring,
    side_offset,
    via,
)
from rail_mj.affordances.row import Affordance
from rail_mj.core.profile import AgentLayout, CandidateInteraction, MotionPlan, ScoringCode, ViaPose

__all__ = ["Storage"]

#: Height (units of h_z) of the side plans; off-centre so a middle board does not stop them all.
#: front_high / front_low run one agent size below the top / above the ground instead.
_MID_Z = 0.15


@register_kind
class Storage(Kind):
    name = "storage"
    decomposition_matters = True
    agent_description = "One small box standing for a stored item, sized to the object's depth."
    interaction_description = ("The box is pushed in horizontally from the front, back, left and right at mid "
                               "height, and from the front higher and lower; released at the first contact or at "
                               "the end.")
    expected_outcome = ("The box ends inside the {name}'s bounding box, resting on it, not on the ground, upright, "
                        "and the {name} does not tip over.")

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        # a book or a jar, a fifth of the thinnest side (never taller than a shelf allows): sized to the furniture,
        # whose size prior keeps it a book's size
        side = 0.2 * dims[2]
        return box_agent("item", (side, side, side))

    def plans(self, shape: AgentShape) -> list[MotionPlan]:
        plans = [MotionPlan(name=side, description=f"Start at the {side} of the object at mid height; push the "
                                                   "item horizontally to the object's centre; release at the "
                                                   "first contact or at the end.")
                 for side, _, _ in SIDES]
        plans += [MotionPlan(name=f"front_{level}", description=f"Start at the front of the object at {level} "
                                                                "height; push the item horizontally to the centre; "
                                                                "release at the first contact or at the end.")
                  for level in ("high", "low")]
        return plans

    def via_poses(self, plan: str, shape: AgentShape, layout: AgentLayout) -> list[ViaPose]:
        ux, uy = side_offset(plan, 1.0)
        rz, dz = {"front_high": (1.0, -shape.radius - GAP), "front_low": (-1.0, shape.radius + GAP)}.get(
            plan, (_MID_Z, 0.0))
        out = shape.radius + clearance(shape)
        return [via((ux, uy, rz), (ux * out, uy * out, dz)), via((0, 0, rz), (0, 0, dz))]

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        # a pushed item may come to rest leaning on a board's lip or the back wall, 20 deg at most
        return rest_scoring(aff, shape, "-h[:, :, 2]", "h[:, :, 2] - " + f"{2 * shape.half_z:.4f}", 20,
                            MAX_OBJECT_TILT_DEG, "inside, on a board")

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        hx, hy, hz = h
        start, s = c.via_poses[0], c.summary
        if abs(start[2]) >= hz or (abs(start[0]) <= hx and abs(start[1]) <= hy):
            return False, "the item did not come in horizontally from a side"
        if s.frac_inside_bbox < MOST or s.frac_touching_object < 1.0 or s.frac_on_ground > 0.0:
            return False, "the item does not rest inside on the object"
        return True, "the item pushed in from the side rests inside on the object"
