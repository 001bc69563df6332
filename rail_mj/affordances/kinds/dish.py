"""``dish``: a flat disc of "food" lowered onto the object. Success: it rests level on the object, which is low
(the size envelope), and stays when placed at the centre, below the top of the object's box (a rim around it)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from rail_mj.affordances.kinds.base import MAX_OBJECT_TILT_DEG, WATER_DENSITY, AgentShape, register_kind, rest_scoring
from rail_mj.affordances.kinds.lowering import Lowering
from rail_mj.affordances.row import Affordance
from rail_mj.core.profile import CandidateInteraction, PoseCandidates, ScoringCode

__all__ = ["Dish"]


@register_kind
class Dish(Lowering):
    name = "dish"
    decomposition_matters = True
    agent_description = "One flat disc standing for a portion of food, sized to the object."
    interaction_description = ("The disc is lowered onto the object from above at its centre and at offsets; "
                               "released at contact.")
    expected_outcome = ("The disc rests level on the {name}, touching it and not the ground, the {name} is low and "
                        "does not tip over.")
    offset = 0.4  # the food placed 40% out from the centre: inside a plate's well, which a rim bounds
    target = "the dish"

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        # a portion half the dish across (radius a quarter of it): sized to the dish, as a figure's dish is to
        # the figure (the dish's size prior keeps it a biscuit to a pizza)
        a = 0.25 * dims[1]
        # a tenth of its radius thick: a slice of bread on a side plate, a steak on a charger
        c = 0.1 * a
        mass = WATER_DENSITY * math.pi * a * a * 2 * c  # food is mostly water
        return AgentShape(f'type="cylinder" size="{a:.4f} {c:.4f}"', math.hypot(a, c), c, mass, "food")

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        # the food's bottom within the dish's box, give or take its own thickness
        c = shape.half_z
        return rest_scoring(aff, shape, f"-h[:, :, 2] - {c:.4f}", f"h[:, :, 2] + {2 * c:.4f}", self.max_agent_tilt,
                            MAX_OBJECT_TILT_DEG, "level on the dish")

    def window(self, aff: Affordance) -> tuple[float, float]:
        # food resting low inside a plate's rim is the point: any height on the object will do
        return -math.inf, math.inf

    def evidence_plans(self, aff: Affordance, plans: Sequence[str]) -> set[str]:
        """The food put down at the centre: the pose rules need it accepted in each world."""
        return {p for p in plans if p == "above"}

    def accept_pose(
        self, aff: Affordance, accepted: list[CandidateInteraction], pose: PoseCandidates
    ) -> tuple[list[CandidateInteraction], str]:
        centre = next((c for c in accepted if c.plan == "above"), None)
        if centre is None:
            return [], f"the food placed at the centre does not stay; a {aff.name} has a solid centre"
        if centre.summary.mean_height >= 1.0:
            # a closed flat box, or an upturned plate whose foot ring is shallower than the food, holds the food
            # on its top: nothing rises around it, so it slides off at the first nudge
            return [], (f"the food at the centre rests on top of the object ({centre.summary.mean_height:.2f} of "
                        f"the half height), not below a rim; a {aff.name} holds food below its rim")
        return accepted, ""

    def rank(self, aff: Affordance, accepted: list[CandidateInteraction], h: Sequence[float]) -> int:
        """Plans whose food stayed below the top of the box: held by a rim. An upturned plate's flat bottom also
        holds a disc, but nothing keeps it there."""
        return sum(c.summary.mean_height < 1.0 for c in accepted)
