"""What the seat and lie kinds share: an articulated human body (:mod:`rail_mj.mjcf.body`) as their agent, the
headings it is lowered in, and its segments where it came to rest."""

from __future__ import annotations

import math
from collections.abc import Sequence

from rail_mj.affordances.kinds.base import GAP, AgentShape
from rail_mj.core.profile import CandidateInteraction, SegmentState, ViaPose
from rail_mj.mjcf.body import THIGHS, Posture, body_fragment, body_size

__all__ = ["HEADINGS", "ROOT", "LEGS", "body_agent", "heading_axes", "heading_vias", "agents_segments", "level",
           "upright", "leans_back", "knees_raised"]

#: Which way the body faces (its +x) when it is lowered, and the yaw (deg) that turns it so.
HEADINGS = (("front", 0.0), ("left", 90.0), ("back", 180.0), ("right", 270.0))
#: The body's root segment (the pelvis) as the fragment names it.
ROOT = "pelvis"
LEGS = THIGHS


def body_agent(posture: Posture, scale: float, count: int = 1) -> AgentShape:
    """The body in ``posture`` at the row's agent scale (a doll's body on a doll's chair); ``count``: the people
    the object is for, side by side."""
    b = body_size(scale)
    reach = max(b.trunk + b.head, b.thigh + b.shank + b.ankle + b.foot)  # from the hip joints, either way
    return AgentShape(geom="", radius=reach, half_z=b.below_root(posture), mass=b.mass, label="body",
                      fragment=body_fragment(posture, scale, name=ROOT), body=b, count=count)


def heading_axes(heading: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """The task-frame unit vectors (x, y) of the body's forward (its +x) and its left (its +y) facing ``heading``."""
    yaw = math.radians(dict(HEADINGS)[heading])
    c, s = round(math.cos(yaw), 12) + 0.0, round(math.sin(yaw), 12) + 0.0  # the four headings' exact 0 and ±1
    return (c, s), (-s + 0.0, c)


def heading_vias(shape: AgentShape, heading: str, rel_xy: tuple[float, float],
                 off_xy: tuple[float, float] = (0.0, 0.0)) -> list[ViaPose]:
    """Lower the body facing ``heading`` with its hip joints over ``rel_xy`` (units of h, task frame) + ``off_xy``
    (m): from above the object's box straight down towards the ground."""
    yaw = math.radians(dict(HEADINGS)[heading]) / 2
    quat = [math.cos(yaw), 0.0, 0.0, math.sin(yaw)]
    scale = shape.body.scale if shape.body is not None else 1.0
    start = shape.radius + GAP * scale  # the body's whole reach clear of the box (a stage-5 check), a gap more
    ox, oy = round(off_xy[0], 5), round(off_xy[1], 5)
    return [ViaPose(rel=[rel_xy[0], rel_xy[1], 1.0], offset_m=[ox, oy, round(start, 5)], quat=quat),
            ViaPose(rel=[rel_xy[0], rel_xy[1], -1.0], offset_m=[ox, oy, round(shape.half_z + 0.02 * scale, 5)],
                    quat=quat)]


def agents_segments(c: CandidateInteraction) -> list[dict[str, SegmentState]]:
    """Each body's segments by name, body by body."""
    out: dict[int, dict[str, SegmentState]] = {}
    for s in c.summary.segments:
        out.setdefault(s.agent, {})[s.name] = s
    return [out[i] for i in sorted(out)]


def level(segments: dict[str, SegmentState], names: Sequence[str], max_deg: float) -> str:
    """The first of ``names`` whose long axis is more than ``max_deg`` from level, in words; "" when none."""
    for name in names:
        tilt = abs(90.0 - math.degrees(math.acos(segments[name].up)))
        if tilt > max_deg:
            return f"the {name.replace('_l', ' (left)').replace('_r', ' (right)')} is {tilt:.0f} deg from level"
    return ""


def tilt(segment: SegmentState) -> float:
    """How far (deg) ``segment``'s long axis leans from upright."""
    return math.degrees(math.acos(segment.up))


def upright(segment: SegmentState, max_deg: float) -> str:
    """Why ``segment`` is more than ``max_deg`` from upright; "" when it is not."""
    lean = tilt(segment)
    return f"the {segment.name} leans {lean:.0f} deg from upright" if lean > max_deg else ""


def leans_back(segments: dict[str, SegmentState]) -> bool:
    """Whether a sitting body's torso rests on a back: touching the object, or reaching it as the trunk reclines
    (:func:`rail_mj.mjcf.body.back_reach`)."""
    return segments["torso"].touching_object or segments["torso"].reaches_object


def knees_raised(segments: dict[str, SegmentState]) -> float:
    """How far (deg) the lower-lying thigh rises from the hip to the knee; 0 where a thigh slopes down or lies
    level. A thigh's z axis runs from the knee to the hip: past 90° from vertical, the knee is the higher end."""
    return max(0.0, min(math.degrees(math.acos(segments[t].up)) - 90.0 for t in LEGS))
