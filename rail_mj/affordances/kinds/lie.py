"""``lie``: an articulated human body lying on its back, lowered onto the object along each way.

Success: the body comes to rest lying on the object (torso and thighs near level), carried by it (pelvis and torso
on it, no part of the body on the ground) at bed height, and the object does not tip.
"""

from __future__ import annotations

from collections.abc import Sequence

from rail_mj.affordances.kinds.base import (
    MAX_OBJECT_TILT_DEG,
    AgentShape,
    Kind,
    register_kind,
    rest_bounds,
    rest_scoring,
    rest_window,
    rest_words,
)
from rail_mj.affordances.kinds.body import (
    HEADINGS,
    LEGS,
    ROOT,
    agents_segments,
    body_agent,
    heading_axes,
    heading_vias,
    level,
)
from rail_mj.affordances.row import Affordance
from rail_mj.core.profile import AgentLayout, CandidateInteraction, MotionPlan, ScoringCode, ViaPose

__all__ = ["Lie"]

#: Torso and thighs within this of level (deg): lying, not sitting up (a reading pillow or a bathtub's sloped
#: back raises the trunk 20-30°; 45° is half-way to sitting).
_LEVEL_DEG = 45
#: The pelvis (the scoring's agent) within this of its posture (deg): half-way to lying on its side.
_PELVIS_DEG = 45
#: The plans put the hip joints at the box's centre and a quarter of the half width to the body's left.
_PLACES = (("", 0.0), ("_aside", 0.25))


@register_kind
class Lie(Kind):
    name = "lie"
    rules_read_agent_size = True
    sized_by_owner_body = True
    agent_description = ("An articulated human body (pelvis, torso, head, thighs, shanks, feet; Winter's "
                         "anthropometry, 1.75 m and 75 kg for a person) lying on its back, its joints held by "
                         "posture springs.")
    interaction_description = ("The lying body is lowered straight down onto the object, head towards each side in "
                               "turn, at the centre and off it; released at the first contact and left to settle.")
    expected_outcome = ("The body comes to rest lying on the {name}, carried by it 0.15–0.9 m above the ground with "
                        "no part on the ground, and the {name} does not tip over.")

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        return body_agent("lie", aff.scale)

    def _plans(self) -> list[tuple[str, str, float]]:
        return [(f"head_{heading}{suffix}", heading, place) for heading, _ in HEADINGS for suffix, place in _PLACES]

    def plans(self, shape: AgentShape) -> list[MotionPlan]:
        return [MotionPlan(name=name, description=f"Start with the {shape.label} lying on its back above the object, "
                                                  f"its feet towards the {heading}"
                                                  f"{', off the centre to its left' if place else ''}; lower it "
                                                  "straight down; release it at the first contact.")
                for name, heading, place in self._plans()]

    def via_poses(self, plan: str, shape: AgentShape, layout: AgentLayout) -> list[ViaPose]:
        # the body's +x points to its feet; its left is +y turned with it
        _, heading, place = next(p for p in self._plans() if p[0] == plan)
        _, left = heading_axes(heading)
        return heading_vias(shape, heading, (place * left[0], place * left[1]))

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        return rest_scoring(aff, shape, *rest_bounds(aff), _PELVIS_DEG, MAX_OBJECT_TILT_DEG, f"lying {rest_words(aff)}")

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        shape = self.agent(aff, h)
        lo, hi = rest_window(aff, shape.half_z)
        bodies = agents_segments(c)
        if not bodies:
            return False, "no body segments were reported: the lie kind needs its articulated body"
        seg = bodies[0]
        pelvis = seg[ROOT]
        if not lo <= pelvis.height <= hi:
            return False, (f"the hips rest {pelvis.height - shape.half_z:.2f} m above the ground; lying "
                           f"{rest_words(aff)}")
        if not (pelvis.touching_object and seg["torso"].touching_object):
            return False, "the pelvis and torso do not both rest on the object"
        grounded = [name for name, s in seg.items() if s.on_ground]
        if grounded:
            return False, f"the {grounded[0]} touches the ground"
        why = level(seg, ("torso", *LEGS), _LEVEL_DEG)
        if why:
            return False, why
        return True, f"the body lies on the object, hips {pelvis.height:.2f} m above the ground"

    def rest_height(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> float | None:
        """The back's underside above the ground (the height the sleeper lies at)."""
        bodies = agents_segments(c)
        return bodies[0][ROOT].height - self.agent(aff, h).half_z if bodies else None
