"""``lie``: a "torso" box lowered onto the object. Success: it rests level at bed height."""

from __future__ import annotations

from collections.abc import Sequence

from rail_mj.affordances.kinds.base import (
    AgentShape,
    box_agent,
    register_kind,
    rest_bounds,
    rest_scoring,
    rest_window,
    rest_words,
)
from rail_mj.affordances.kinds.lowering import Lowering
from rail_mj.affordances.row import Affordance
from rail_mj.core.profile import ScoringCode

__all__ = ["Lie"]

_HALF_Z = 0.075  # the torso's half height, m


@register_kind
class Lie(Lowering):
    name = "lie"
    agent_description = "One box standing for a lying person's torso, about 0.5 x 0.35 x 0.15 m."
    interaction_description = ("The torso is lowered onto the object from above at its centre and at offsets; "
                               "released at contact.")
    expected_outcome = ("The torso rests level on the {name} 0.15–0.9 m above the ground, not touching the ground, "
                        "and the {name} does not tip over.")
    offset = 0.3
    target = "the lying surface"

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        # the lying figure's size (the row's agent scale: a doll's torso on a doll's bed)
        k = min(1.2, max(0.7, dims[0] / (2.0 * aff.scale))) * aff.scale
        return box_agent("torso", (0.25 * k, 0.175 * k, _HALF_Z * aff.scale))

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        return rest_scoring(aff, shape, *rest_bounds(aff), 15, 15, f"level {rest_words(aff)}")

    def window(self, aff: Affordance) -> tuple[float, float]:
        return rest_window(aff, _HALF_Z * aff.scale)
