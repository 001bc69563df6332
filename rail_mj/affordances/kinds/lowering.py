"""What the kinds whose one agent is lowered onto the object from above share: ``surface``, ``dish``.

The plans lower the agent at the centre and offset towards each side; the
agent must come to rest level on the object alone.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Sequence
from typing import ClassVar

from rail_mj.affordances.kinds.base import (
    GAP,
    LEVEL_DEG,
    SIDES,
    AgentShape,
    Kind,
    clearance,
    rest_accept,
    side_offset,
    via,
)
from rail_mj.affordances.row import Affordance
from rail_mj.core.profile import AgentLayout, CandidateInteraction, MotionPlan, ViaPose

__all__ = ["Lowering"]


class Lowering(Kind):
    """A kind that lowers one agent straight down onto the object."""

    #: Horizontal offset (units of h) of the above_<side> plans.
    offset: ClassVar[float]
    #: What the agent is lowered onto, in the plans' words.
    target: ClassVar[str]
    #: The agent's largest tilt (deg) at rest that still counts as level.
    max_agent_tilt: ClassVar[float] = LEVEL_DEG

    def plans(self, shape: AgentShape) -> list[MotionPlan]:
        label = shape.label
        plans = [MotionPlan(name="above", description=f"Start with the {label} above the object's centre; lower it "
                                                      f"straight down onto {self.target}; release it at the first "
                                                      "contact.")]
        plans += [
            MotionPlan(name=f"above_{side}", description=f"Start with the {label} above the object, offset to the "
                                                          f"{side} by {self.offset:g} of its half size; lower it "
                                                          "straight down; release it at the first contact.")
            for side, _, _ in SIDES
        ]
        return plans

    def via_poses(self, plan: str, shape: AgentShape, layout: AgentLayout) -> list[ViaPose]:
        ox, oy = side_offset(plan, self.offset)
        return [via((ox, oy, 1), (0, 0, shape.radius + clearance(shape))),
                via((ox, oy, -1), (0, 0, shape.half_z + GAP / 2))]  # down to just over the bottom

    @abstractmethod
    def window(self, aff: Affordance) -> tuple[float, float]:
        """Plausible height (m) of the resting agent's centre above the ground."""

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        return rest_accept(c, h, self.window(aff), self.max_agent_tilt)
