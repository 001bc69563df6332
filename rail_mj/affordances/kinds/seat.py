"""``seat``: an articulated human body, hips at 90° and knees at 105°, lowered onto the object facing each way.

Success: the body comes to rest carried by the object: its pelvis level, or tilted back with an easy chair's seat
(or no further than its trunk) against its back, on the object with a seat under both sitting bones, and with its
thighs (a seat pan bears the thighs, or lies under them where the feet lift the knees off a low seat; an edge or a
rail bears the pelvis alone) at seat height, its thighs near level, its torso upright or leaning on a back, its feet
on the floor or on the object, or within a relaxed toe's reach of the floor or of a rung as the knees bend (a bar
stool's sitter), nothing but its shanks and feet on the ground, and the object not tipped. A seat for more than one
(a bench) seats the body at two places side by side along its length, half a shoulder breadth either side of its
centre.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, cast

from rail_mj.affordances.kinds.base import (
    LEVEL_DEG,
    MAX_OBJECT_TILT_DEG,
    NEAR_AXIS_DEG,
    AgentShape,
    Kind,
    register_kind,
    rest_bounds,
    rest_scoring,
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
    knees_raised,
    leans_back,
    level,
    tilt,
    upright,
)
from rail_mj.affordances.row import Affordance, KindParams
from rail_mj.core.profile import (
    AgentLayout,
    CandidateInteraction,
    MotionPlan,
    PoseCandidates,
    ScoringCode,
    SegmentState,
    ViaPose,
)
from rail_mj.mjcf.body import EASY_SEAT_DEG, FEET, SAG_DEG, SIT_KNEE, TRUNK_THIGH_DEG

__all__ = ["SeatParams", "Seat"]


@dataclass(frozen=True)
class SeatParams(KindParams):
    """A seat row's own field: how many sit on it side by side."""

    DOCS: ClassVar[dict[str, str]] = {
        "persons": "people who sit on it side by side (1: a seat for one, refused where a second sitter fits)"}

    persons: int = 1  # people who sit on it side by side (1: a seat for one)


#: Thighs within this of level (deg): sitting bears the thighs on the seat with a trunk-thigh angle of 90-135°
#: (Keegan 1953, the relaxed sitting range); a thigh steeper than a third of a right angle slides off the seat.
_THIGH_DEG = NEAR_AXIS_DEG
#: The torso within this of upright (deg): Keegan's relaxed 135° trunk-thigh angle with level thighs; as much further
#: as a reclined seat raises the knees above the hips (:func:`knees_raised`), the trunk-thigh angle the same.
_TORSO_DEG = TRUNK_THIGH_DEG - 90
#: The pelvis (the scoring's agent) within this of its posture (deg), the same relaxed limit.
_PELVIS_DEG = 45
#: The pelvis resting within this of upright (deg) with its torso leaning on a back: an easy chair's seat
#: (EASY_SEAT_DEG: Grandjean's easy chairs tilt back 14-24°, their back bearing the reclined trunk; steeper, the
#: sitter slides or lies), or as far as the thighs it sits with rise where the feet hold the knees above a low reclined
#: seat (the thighs themselves within _THIGH_DEG of level), and the pelvis rolled back on it by the hips' give under
#: the reclined trunk's weight (SAG_DEG, the posture spring's sag: on lounge chairs reclined 10-19° the body's pelvis
#: lies 2-10° past its thighs), or as far as the trunk it carries leans on the back: in reclined sitting the lumbar
#: spine flattens or flexes, it does not arch back, so the pelvis rolls back no further than the trunk (the torso's
#: own limit, Keegan's 135° trunk-thigh angle, keeps the hips from opening into lying). The spring's sag bounds a
#: joint under its own segment's weight, not under a back's push on the trunk: in a lounge chair whose back leans
#: 45-55° the pelvis rolls 10-11° past the thighs. Without a back, LEVEL_DEG (15°), the level every kind's resting
#: agent keeps (a work chair's seat tilts 0-10°, ISO 9241-5).
_RECLINED_PAN_DEG = EASY_SEAT_DEG
#: The shanks, whose origins are the knees.
_SHANKS = ("shank_l", "shank_r")
#: Of the body, only these may touch the ground: a sitter's feet stand on the floor.
_ON_FLOOR = ("shank_l", "foot_l", "shank_r", "foot_r")
#: Where the hip joints are put down along the heading (units of h): the box's centre, a quarter of the way to its
#: back (a sitter sits back towards a backrest; half-way, a seat 0.45 m deep puts the back inside the sitter), and a
#: quarter of the way to its front: where a chair's back, rear legs or fittings reach behind the seat, the box's
#: centre lies at the back's face and the buttocks, 10 cm behind the hips, land on the back (FurnitureBench's chair:
#: its centre 2.5 cm before the back, the body pushed off the seat's front edge).
_PLACES = (("", 0.0), ("_back", -0.25), ("_front", 0.25))
#: A seat for more: the body faces across the object's length (task-frame x, its longer side) and sits at two places
#: side by side along it, half a shoulder breadth (Winter Fig. 4.1, 0.259 H) to either side of the centre: two
#: sitters shoulder to shoulder.
_MANY_HEADINGS = ("left", "right")
_BESIDE = (("_beside_front", 1.0), ("_beside_back", -1.0))
#: A seat for one has no room for a second sitter beside the first: the body put down facing across the object's
#: length one hip breadth (Winter Fig. 4.1, 0.191 H: a sitter's width) to either side of the centre is carried as a
#: sitter at both places on a bench or a bed (its feet aside, which a sitter finds a rest for), and falls off or meets
#: an armrest or a back on a chair or a stool. Facing both ways across the length: a sofa's or a bench's back may be
#: on either side, and the body facing it sits nowhere.
_ASIDE = (("_aside_front", 1.0), ("_aside_back", -1.0))
_ASIDE_HEADINGS = ("left", "right")


def seat_height(segments: dict[str, SegmentState], thigh_radius: float) -> float:
    """The seat height (m) a sitting body found: the thighs' undersides at the hips, or, leaning back
    (:func:`leans_back`), at the knees. A seat's height is its front edge's, under the knees (the popliteal height,
    Pheasant, Bodyspace); on a level seat the hips are as high, on a reclined one (an easy chair's, a lounge
    chair's) they sink below it by the thighs' rise."""
    if leans_back(segments):
        return sum(segments[s].height for s in _SHANKS) / len(_SHANKS) - thigh_radius
    return segments[ROOT].height - thigh_radius


@register_kind
class Seat(Kind):
    name = "seat"
    rules_read_agent_size = True
    sized_by_owner_body = True
    params_model = SeatParams
    agent_description = ("An articulated human body (pelvis, torso, head, thighs, shanks, feet; Winter's "
                         f"anthropometry, 1.75 m and 75 kg for a person) with hips at 90° and knees at {SIT_KNEE:g}°, "
                         "its joints held by posture springs.")
    interaction_description = ("The sitting body is lowered straight down onto the object facing each way, with its "
                               "hips over the object's centre and a quarter of the way to its back and to its front; "
                               "it is released at "
                               "the first contact and left to settle. On a seat for more, it is lowered at two "
                               "places side by side along its length, half a shoulder breadth either side of the "
                               "centre.")
    expected_outcome = ("The body comes to rest sitting on the {name}: pelvis on it at seat height, thighs near level, "
                        "torso upright or leaning on a back, feet on the floor or on the {name}, and the {name} does "
                        "not tip over.")

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        return body_agent("sit", aff.scale, cast(SeatParams, aff.params).persons)

    def _plans(self, shape: AgentShape) -> list[tuple[str, str, float, float]]:
        """(plan name, heading, place along it in units of h, shift along x in m)."""
        body = shape.body
        if body is None:
            return []
        if shape.count == 1:
            return ([(f"facing_{h}{suffix}", h, place, 0.0) for h, _ in HEADINGS for suffix, place in _PLACES]
                    + [(f"facing_{h}{side}", h, 0.0, sign * body.hip_breadth) for h in _ASIDE_HEADINGS
                       for side, sign in _ASIDE])
        return [(f"facing_{h}{suffix}{side}", h, place, sign * body.shoulder_breadth / 2) for h in _MANY_HEADINGS
                for suffix, place in _PLACES for side, sign in _BESIDE]

    def plans(self, shape: AgentShape) -> list[MotionPlan]:
        where = {0.0: "over the object's centre",
                 -0.25: "a quarter of the way to the object's back (as seen facing that way)",
                 0.25: "a quarter of the way to the object's front (as seen facing that way)"}

        def shifted(name: str, shift: float) -> str:
            """Where a plan's hips are shifted along the object's length, in words."""
            if not shift:
                return ""
            end = "front" if shift > 0 else "back"
            if "_aside" in name:
                return (f", one hip breadth towards the object's {end} end (where a second sitter beside it would "
                        "sit: a seat for one has no room there)")
            return (f", half a shoulder breadth towards the object's {end} end (where one of two people side by side "
                    "sits)")

        return [MotionPlan(name=name, description=f"Start with the sitting {shape.label} above the object, facing "
                                                  f"{heading}, its hips {where[place]}" + shifted(name, shift)
                                                  + "; lower it straight down; release it at the first contact.")
                for name, heading, place, shift in self._plans(shape)]

    def via_poses(self, plan: str, shape: AgentShape, layout: AgentLayout) -> list[ViaPose]:
        _, heading, place, shift = next(p for p in self._plans(shape) if p[0] == plan)
        (ux, uy), _ = heading_axes(heading)
        return heading_vias(shape, heading, (place * ux, place * uy), (shift, 0.0))

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        # the scoring sees the pelvis alone: its lower bound lets through hips as far below the seat's front as an
        # easy chair's reclined seat sets them, and the rules then judge the seat at the knees (seat_height)
        lo, hi = rest_bounds(aff)
        drop = shape.body.thigh * math.sin(math.radians(EASY_SEAT_DEG)) if shape.body is not None else 0.0
        return rest_scoring(aff, shape, f"{lo} - {drop:.4f}", hi, _PELVIS_DEG, MAX_OBJECT_TILT_DEG,
                            f"sitting {rest_words(aff)}", ground=False)

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        shape, bodies = self.agent(aff, h), agents_segments(c)
        why = self._unseated(aff, shape, bodies)
        if why:
            return False, why
        assert shape.body is not None  # _unseated refuses a row without its body
        reach = shape.body.toes_down
        for i, seg in enumerate(bodies):
            who = f"body {i + 1}: " if len(bodies) > 1 else ""
            dangling = [f for f in FEET if not (seg[f].on_ground or seg[f].touching_object or seg[f].height <= reach
                                                or seg[f].reaches_object)]
            if dangling:
                return False, (f"{who}the feet hang {seg[dangling[0]].height:.2f} m up, touching nothing (a sitter's "
                               f"toes reach the floor from {reach:.2f} m) and finding no rung or floor as the knees "
                               "bend: a seat too high for the feet")
        torso = all(leans_back(seg) for seg in bodies)
        return True, (f"the body sits {bodies[0][ROOT].height:.2f} m up, thighs level, torso upright"
                      + (", leaning on a back" if torso else ""))

    def _unseated(self, aff: Affordance, shape: AgentShape, bodies: list[dict[str, SegmentState]]) -> str:
        """Why the object does not carry the sitting ``bodies`` (a candidate's :func:`agents_segments`) as a seat does
        (pelvis, thighs and torso; not the feet), or "" where it does."""
        lo, hi = aff.rest_limits()
        if not bodies or shape.body is None:
            return "no body segments were reported: the seat kind needs its articulated body"
        for i, seg in enumerate(bodies):
            who = f"body {i + 1}: " if len(bodies) > 1 else ""
            pelvis = seg[ROOT]
            height = seat_height(seg, shape.half_z)
            if not lo <= height <= hi:
                where = "under the knees, leaning back," if leans_back(seg) else "at the hips"
                return f"{who}the seat is {height:.2f} m above the ground {where}; sitting {rest_words(aff)}"
            if not pelvis.touching_object:
                return f"{who}the pelvis does not rest on the object"
            if not pelvis.reaches_object:
                return (f"{who}the sitting bones are not both over a seat: the pelvis rests on posts, an edge or a "
                        "rail")
            # both level with the buttocks: either may bear; on a seat lower than the knees the feet hold the knees
            # up and the thighs rise off the seat's front, the seat still under them
            if not any(seg[t].touching_object or seg[t].reaches_object for t in LEGS):
                return f"{who}the object does not carry the thighs: the pelvis rests on an edge or a rail, not a seat"
            grounded = [name for name, s in seg.items() if s.on_ground and name not in _ON_FLOOR]
            if grounded:
                return f"{who}the {grounded[0]} touches the ground: the body fell"
            raised = knees_raised(seg)
            pan = (max(max(_RECLINED_PAN_DEG, raised) + SAG_DEG, tilt(seg["torso"])) if leans_back(seg)
                   else LEVEL_DEG)
            why = (upright(pelvis, pan) or level(seg, LEGS, _THIGH_DEG)
                   or upright(seg["torso"], _TORSO_DEG + raised))
            if why:
                return f"{who}{why}"
        return ""

    def rest_height(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> float | None:
        """The seat height the sitter found (:func:`seat_height`), over the bodies."""
        bodies = agents_segments(c)
        if not bodies:
            return None
        half_z = self.agent(aff, h).half_z
        return sum(seat_height(seg, half_z) for seg in bodies) / len(bodies)

    def evidence_plans(self, aff: Affordance, plans: Sequence[str]) -> set[str]:
        """A seat for more: every place side by side (the pose needs both of a heading's). A seat for one: none; the
        body put down to either side refuses the pose where it sits at both places, and a place where it did not sit
        in the nominal world counts as failed in each perturbed one, as every failed plan does."""
        return set(plans) if cast(SeatParams, aff.params).persons > 1 else set()

    def accept_pose(
        self, aff: Affordance, accepted: list[CandidateInteraction], pose: PoseCandidates
    ) -> tuple[list[CandidateInteraction], str]:
        """A seat for more seats the body at both places side by side, facing the same way; a seat for one does not
        carry it one hip breadth to either side of the centre, facing the same way (room for a second sitter), its
        pelvis, thighs and torso judged as in :meth:`accept` and its feet not."""
        if cast(SeatParams, aff.params).persons == 1:
            # room is the seat's: a second sitter's feet find their own rest, so a place where only the feet hang
            # still seats one (a counter 1.3 m long with a footrest under its middle seats two)
            shape = self.agent(aff, list(pose.half_extents))
            plans = {c.plan for c in pose.candidates
                     if "_aside" in c.plan and not self._unseated(aff, shape, agents_segments(c))}
            if any(all(f"facing_{h}{side}" in plans for side, _ in _ASIDE) for h in _ASIDE_HEADINGS):
                return [], ("the seat also carries the body one hip breadth to either side of the centre: room for a "
                            f"second sitter beside the first, a seat for more than one, not a {aff.name}")
            return accepted, ""
        plans = {c.plan for c in accepted}
        both = [h for h in _MANY_HEADINGS
                if any(all(f"facing_{h}{suffix}{side}" in plans for side, _ in _BESIDE) for suffix, _ in _PLACES)]
        if not both:
            return [], ("the body does not sit at both places side by side (half a shoulder breadth either side of "
                        f"the centre, facing the same way): a seat for one, not a {aff.name}")
        return accepted, ""

    def rank(self, aff: Affordance, accepted: list[CandidateInteraction], h: Sequence[float]) -> int:
        """A seat with a back first: of two poses that seat the body, the one where its torso leans on the object
        (a chair standing, not lying on its side or back)."""
        return int(any(all(leans_back(seg) for seg in agents_segments(c)) for c in accepted))

    def tie_rank(self, aff: Affordance, accepted: list[CandidateInteraction], h: Sequence[float]) -> int:
        """Of two poses that seat the body from as many approaches, the one whose sitter's feet reach the floor: a
        chair is made for the feet to be put down (its seat at the lower leg's height); feet resting on the object
        alone, on a rung or a ledge, are a perch's, which a tall chair lying on its back also gives. After the number
        of approaches: a bar chair standing seats the body from more of them than lying on its back does."""
        body = self.agent(aff, h).body
        if body is None:
            return 0
        return int(any(all(seg[f].on_ground or seg[f].height <= body.toes_down
                           for seg in agents_segments(c) for f in FEET) for c in accepted))
