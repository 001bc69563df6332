"""``surface``: a flat box placed on top. Success: it rests level on top at table height, at the centre and
off centre."""

from __future__ import annotations

from collections.abc import Sequence

from rail_mj.affordances.kinds.base import AgentShape, box_agent, rest_bounds, rest_scoring, rest_window, rest_words
from rail_mj.affordances.kinds.lowering import Lowering
from rail_mj.affordances.registry import Affordance
from rail_mj.llm.schemas import CandidateInteraction, ScoringCode

__all__ = ["Surface"]

_HALF_Z = 0.015  # the book's half height, m
#: How many of the five lowering plans must succeed: a top at least half a metre across holds the box placed
#: off centre too, a small pedestal foot or a stretcher only at one place.
_MIN_PLANS = 4
#: A top has free space above it: the box rests at least this high in the pose's box (its centre, in units of
#: the box's half height; 1 = the box top). Upside down, a console holds the box on its bottom among its legs,
#: which rise 8 cm or more above it (0.8 or lower in its 0.7 m box); a stretcher or a shelf is lower still.
_FREE_ABOVE = 0.9


class Surface(Lowering):
    name = "surface"
    agent_description = "One flat box standing for a book or a dish placed on the object."
    interaction_description = ("The box is lowered onto the object from above at its centre and at offsets to each "
                               "side; released at the first contact.")
    expected_outcome = ("The box rests level on top of the {name} 0.4–1.1 m above the ground, not touching the "
                        "ground, and the {name} does not tip over.")
    offset = 0.75
    target = "the top"
    max_agent_tilt = 10

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        return box_agent("book", (min(0.15, max(0.04, 0.12 * dims[1])),) * 2 + (_HALF_Z,))

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        lo, hi = rest_bounds(aff)
        # on top: never below the box's middle either (in a tall object a board at table height is no top)
        return rest_scoring(aff, shape, f"np.maximum({lo}, 0.0)", hi, 10, 10, f"level on top {rest_words(aff)}")

    def window(self, aff: Affordance) -> tuple[float, float]:
        return rest_window(aff, _HALF_Z)

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        ok, why = super().accept(aff, c, h)
        # the item belongs on the top, with free space above it: not on a stretcher, a shelf or among legs
        if ok and c.summary.mean_height < _FREE_ABOVE:
            below = (1.0 - c.summary.mean_height) * h[2]
            return False, (f"the agent rests {below:.2f} m below the object's top: parts of it rise above this "
                           "surface, it is no top with free space above it")
        return ok, why

    def accept_pose(
        self, aff: Affordance, accepted: list[CandidateInteraction], tried: list[CandidateInteraction]
    ) -> tuple[list[CandidateInteraction], str]:
        if len(accepted) < _MIN_PLANS:
            return [], (f"only {len(accepted)} of the placements hold the box; a {aff.name} top holds it at the "
                        f"centre and off centre ({_MIN_PLANS} needed)")
        return accepted, ""

