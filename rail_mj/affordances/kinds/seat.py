"""``seat``: a box "pelvis" lowered onto the object from above, or arriving from a side above seat height.

Success: the pelvis rests upright on the object alone at seat height. The verdict rests on where the pelvis
comes to rest, not on the object's box: a seat is where the pelvis rests level at the centre; a seat has an
area (the pelvis also rests a little off the centre, not only on a post or a ridge); and a
seat for one is not a seat for two (a second pelvis lowered beside it along the object's length does not rest
on its level, as it does on a bench or a sofa).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import cast

from rail_mj.affordances.kinds.base import (
    SIDES,
    AgentShape,
    Kind,
    box_agent,
    clearance,
    register_kind,
    rest_accept,
    rest_bounds,
    rest_scoring,
    rest_window,
    rest_words,
    side_offset,
    via,
)
from rail_mj.affordances.row import Affordance, KindParams
from rail_mj.core.profile import AgentLayout, CandidateInteraction, MotionPlan, PoseCandidates, ScoringCode, ViaPose

__all__ = ["SeatParams", "Seat"]


@dataclass(frozen=True)
class SeatParams(KindParams):
    """A seat row's own fields: how many sit on it, and the height above which it has a back."""

    persons: int = 1  # people who sit on it side by side (1: a seat for one)
    #: a seat higher than this (m, the sitter's bottom) has a back rising behind the sitter (a bar chair; a high
    #: seat without one is a stool, or a table's top)
    perch: float = math.inf

    def scaled(self, factor: float) -> SeatParams:
        """The perch height scales; the number of sitters does not."""
        return replace(self, perch=self.perch * factor)

#: The contact patch of a sitting pelvis, 0.2 m across: fits the narrowest seat (0.3 m) and the gap between
#: armrests as the object's convex hulls render it (a 0.28 m box lands on the armrests of a dataset chair).
_HALF = (0.1, 0.1, 0.05)
#: Seat height (m) the side plans arrive above: higher than any seat.
_ABOVE_SEAT = 0.65
#: Off-centre placements (m, a person's) that probe the seat's area: a sitter shifts this much on a seat, and
#: the pelvis still clears armrests 0.31 m apart. On a ridge (a pouf or a stool lying on its side) the pelvis
#: placed this far across it tips off.
_AREA = 0.06
#: A back behind the seat: the pose's box rises at least this far above the seated pelvis's centre (units of
#: the box's half height; the pelvis rests at mean height 1 + its half height when nothing rises above it). A
#: chair's back rises 0.3-0.5 m above its seat, a chair lying on its back has nothing above the pelvis.
_BACK = 0.5
#: A back behind a high seat rises at least this far (m, a person's) above the seated pelvis's centre: a bar chair's
#: back rises 0.25-0.35 m, a small table's top has nothing above it.
_PERCH_BACK = 0.2
#: A seat is the object's top when the pelvis rests at most this far (m, a person's) below the top of the pose's
#: box: a cushion's seams and an uneven scan stay within it, a pouf's feet rise 3-6 cm round it upside down.
_ON_TOP = 0.015
#: Where a second sitter sits (m from the centre along the object's length, a person's): a pelvis resting
#: there is supported only by a seat over 0.7 m long, the widest seat for one (0.9 m make a bench for two).
_BESIDE = 0.35
#: Plans that lower the pelvis onto the centre of the object's box.
_CENTRE = ("above",) + tuple(side for side, _, _ in SIDES)
_AREA_PLANS = tuple(f"above_{side}" for side, _, _ in SIDES)
#: The off-centre placements along each horizontal axis of the task frame.
_AXES = (("front", "back"), ("left", "right"))
#: A second pelvis sits on the same seat when it rests at the seat's level: within this fraction of the pose's
#: half height (an armchair's rolled arms bear it 0.1-0.2 m above its cushion, a third of its half height).
_SAME_LEVEL = 0.15
#: A second pelvis at either end of the length (task-frame x, the footprint's long side).
_BESIDE_PLANS = (("beside_front", 1.0), ("beside_back", -1.0))


@register_kind
class Seat(Kind):
    name = "seat"
    params_model = SeatParams
    agent_description = "One box standing for a sitting person's pelvis's contact patch, 0.2 x 0.2 x 0.1 m."
    interaction_description = ("The pelvis is lowered onto the object from above, or arrives from the front, back, "
                               "left or right above seat height and is then lowered; it is also lowered a little "
                               "off the centre to each side, and 0.35 m to either end of the object's length where "
                               "a second person would sit; it is released at the first contact.")
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
        plans += [MotionPlan(name=f"above_{side}", description=f"Start with the pelvis above the object, "
                                                               f"{_AREA:g} m to the {side} of its centre; lower it "
                                                               "straight down; release at the first contact.")
                  for side, _, _ in SIDES]
        plans += [MotionPlan(name=name, description=f"Where a second person would sit: start with the pelvis above "
                                                    f"the object, {_BESIDE:g} m to the {name.split('_')[1]} of its "
                                                    "centre along its length; lower it straight down; release at "
                                                    "the first contact.")
                  for name, _ in _BESIDE_PLANS]
        return plans

    def via_poses(self, plan: str, shape: AgentShape, layout: AgentLayout) -> list[ViaPose]:
        gap = clearance(shape)
        scale = shape.half_z / _HALF[2]  # the sitter's size against a person's
        above_seat = scale * _ABOVE_SEAT + shape.radius + 0.05 * scale  # the pelvis included
        bottom = shape.half_z + 0.02
        beside = dict(_BESIDE_PLANS)
        if plan == "above" or plan in _AREA_PLANS or plan in beside:
            if plan in beside:
                ox, oy = beside[plan] * _BESIDE * scale, 0.0
            else:
                ox, oy = side_offset(plan, _AREA * scale)
            return [via((0, 0, 1), (ox, oy, shape.radius + gap)), via((0, 0, -1), (ox, oy, bottom))]
        ux, uy = side_offset(plan, 1.0)
        return [via((ux, uy, -1), (ux * (shape.radius + gap), uy * (shape.radius + gap), above_seat)),
                via((0, 0, -1), (0, 0, above_seat)),
                via((0, 0, -1), (0, 0, bottom))]

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        return rest_scoring(aff, shape, *rest_bounds(aff), 15, 15, f"upright {rest_words(aff)}")

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        ok, why = rest_accept(c, h, rest_window(aff, _HALF[2] * aff.scale), 15)
        bottom = (c.summary.mean_height + 1.0) * h[2] - _HALF[2] * aff.scale
        rise = (1.0 - c.summary.mean_height) * h[2]  # of the object above the pelvis's centre
        perch = cast(SeatParams, aff.params).perch
        if ok and bottom > perch and rise < _PERCH_BACK * aff.scale:
            return False, (f"the seat is {bottom:.2f} m high, above a sitter's knees ({perch:g} m), and nothing "
                           f"rises {_PERCH_BACK * aff.scale:g} m behind the sitter: a {aff.name} that high has a back")
        return ok, why

    def accept_pose(
        self, aff: Affordance, accepted: list[CandidateInteraction], pose: PoseCandidates
    ) -> tuple[list[CandidateInteraction], str]:
        centre = [c for c in accepted if c.plan in _CENTRE]
        area = [c for c in accepted if c.plan in _AREA_PLANS]
        if not centre:
            return [], "the pelvis rests at seat height only off the centre: no seat at the object's centre"
        if not area:
            return [], (f"the pelvis rests only where it is placed at the centre, not {_AREA * aff.scale:g} m off it "
                        "to any side: a post or a ridge, no seat area")
        placed = {c.plan for c in area}
        along = [pair for pair in _AXES if not any(f"above_{side}" in placed for side in pair)]
        if along:
            return [], (f"the pelvis rests {_AREA * aff.scale:g} m off the centre only along one axis, not to the "
                        f"{' or '.join(along[0])}: a ridge (a divider's edge, a pouf on its side), no seat area")
        level = sorted(c.summary.mean_height for c in centre)[len(centre) // 2]
        beside = {c.plan for c in accepted
                  if c.plan in dict(_BESIDE_PLANS) and abs(c.summary.mean_height - level) <= _SAME_LEVEL}
        both = len(beside) == len(_BESIDE_PLANS)
        persons = cast(SeatParams, aff.params).persons
        if persons == 1 and both:
            return [], (f"a second pelvis also rests on the seat's level {_BESIDE * aff.scale:g} m to either side "
                        f"along its length: a seat for more than one, not a {aff.name}")
        if persons > 1 and not both:
            return [], (f"a second pelvis does not rest on the seat's level {_BESIDE * aff.scale:g} m to either side "
                        f"along its length: a {aff.name} seats people side by side")
        return centre + area, ""

    def rank(self, aff: Affordance, accepted: list[CandidateInteraction], h: Sequence[float]) -> int:
        """A seat with a back first, then one with an area both ways, then one on top: of two poses that seat the
        pelvis, the one where the object rises behind it (a chair standing, not lying on its back or side, whose
        box is the longer for it), then the one that bears it off the centre along both horizontal axes (a pouf
        standing, not rolled on its side, whose ridge bears it only along its axis), then the one whose seat is
        the object's top (a pouf on its feet, not upside down with its feet rising round the sitter).
        6 x back (0 or 1) + 2 x axes (0-2) + top (0 or 1)."""
        centre = [c for c in accepted if c.plan in _CENTRE]
        if not centre:
            return 0
        level = sorted(c.summary.mean_height for c in centre)[len(centre) // 2]
        plans = {c.plan for c in accepted}
        axes = sum(any(f"above_{side}" in plans for side in pair) for pair in _AXES)
        seat = (level - 1.0) * h[2] - _HALF[2] * aff.scale  # of the pelvis's bottom above the object's top
        return 6 * int(level <= 1.0 - _BACK) + 2 * axes + int(seat > -_ON_TOP * aff.scale)

