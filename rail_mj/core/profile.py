"""The imagination profile's neutral types: what the kinds produce and the LLM stages wrap.

Plans, via-poses and trajectories, the agents' layout, the scoring source, and
the summary of a rollout that stage 7 judges (with the two constants that
define its leak and enclosure fractions). The LLM's stage requests and answers
(:mod:`rail_mj.llm.schemas`) are built from these; the JSON shapes are the
prompts' schemas.

Trajectories are pose-independent: every via-pose position is
``rel * h + offset_m`` in the task frame (see :mod:`rail_mj.core.types`), where
``h`` are the half extents of the object's bounding box in the stable pose
being imagined. ``rel`` is in units of ``h`` (``(0, 0, 1)`` is the centre of
the top face, ``(0, 0, -1)`` the ground under the centre), ``offset_m`` is in
metres (clearances that depend on the agent, not the object). One profile
therefore serves every stable pose of the object.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_serializer
from pydantic.json_schema import SkipJsonSchema

from rail_mj.core.results import BasinInfo

__all__ = [
    "Vec3",
    "Quat",
    "Scale",
    "ProfileModel",
    "BENEATH_MIDDLE",
    "OPEN_SECTOR",
    "MAX_ARRANGED_AGENTS",
    "AgentLayout",
    "MotionPlan",
    "ViaPose",
    "PlanTrajectory",
    "ScoringCode",
    "SegmentState",
    "ResultSummary",
    "CandidateInteraction",
    "PoseShape",
    "PoseCandidates",
    "PoseVerdict",
    "FunctionalPoseVerdict",
]

Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Quat = Annotated[list[float], Field(min_length=4, max_length=4, description="unit quaternion w, x, y, z")]


class ProfileModel(BaseModel):
    """Base of the profile's and the stages' models: frozen, no fields beyond the declared ones."""

    model_config = ConfigDict(extra="forbid", frozen=True)


#: Agent scale: the request's agent against a person (rail_mj.affordances.request_scale; a doll 0.18).
Scale = Annotated[float, Field(gt=0, le=10, description="size of the agent the object is for, relative to a "
                                                        "person's (a doll: 0.18); every real-world size of the "
                                                        "affordance scales by it")]

#: A point on the ground is beneath the object's middle when (x/h_x)^2 + (y/h_y)^2 is below this (an ellipse
#: half the footprint's size): a droplet resting there came through the object, so it leaks. The scoring source
#: (run in the sandbox, so it cannot import this) has it formatted in; stage 7's ``frac_through_object`` reads it.
BENEATH_MIDDLE = 0.25

#: Most agents an explicit arrangement may hold: the grid's own largest (12 per axis).
MAX_ARRANGED_AGENTS = 12**3

#: Consecutive directions of the enclosure probe (:data:`rail_mj.imagination.batch.PROBE_DIRECTIONS`, 16, 22.5 deg
#: apart) free of the object that make a droplet's side open: 4 span 67.5 deg, wider than a chance line-up of a
#: basket's slots, narrower than the gap between an upturned table's legs or a seat's open front.
OPEN_SECTOR = 4


class AgentLayout(ProfileModel):
    """Output of stage 3: a world-aligned grid of identical agents about the layout centre (or, imported, their
    explicit ``offsets``)."""

    nx: int = Field(ge=1, le=12)
    ny: int = Field(ge=1, le=12)
    nz: int = Field(ge=1, le=12)
    sx: float = Field(gt=0, description="spacing along x between neighbouring agent centres, m")
    sy: float = Field(gt=0, description="spacing along y, m")
    sz: float = Field(gt=0, description="spacing along z, m")
    collide_agents: bool = Field(description="whether agents collide with each other (droplets pile up)")
    # Not in the stage's schema (an LLM answers the grid); set by an imported arrangement (rail_mj.profiles).
    offsets: SkipJsonSchema[list[Vec3] | None] = Field(
        default=None, min_length=1, max_length=MAX_ARRANGED_AGENTS,
        description="explicit agent positions about the layout centre, m, in place of the grid (an arrangement)")

    @property
    def n_agents(self) -> int:
        return len(self.offsets) if self.offsets is not None else self.nx * self.ny * self.nz

    @model_serializer(mode="wrap")
    def _drop_unset_offsets(self, handler):
        # a grid layout dumps as before the field existed: prompts, cache keys and saved profiles are unchanged
        out = handler(self)
        if isinstance(out, dict) and out.get("offsets", 0) is None:
            out.pop("offsets")
        return out


class MotionPlan(ProfileModel):
    """One high-level plan in language, step by step from the start to the end point."""

    name: str = Field(description="short identifier, e.g. above, front, back, left, right")
    description: str


class ViaPose(ProfileModel):
    """A via-pose of the layout centre: position ``rel * h + offset_m`` in the task frame, from the box centre or
    from the pose's opening."""

    rel: Vec3 = Field(description="position in units of the object's half extents h (task frame)")
    offset_m: Vec3 = Field(description="additional offset in metres (agent-size clearances)")
    quat: Quat
    anchor: Literal["box", "opening"] = Field(
        default="box",
        description="'box': x and y from the centre of the object's box; 'opening': from the middle of the "
                    "pose's deepest basin seen from above (where a pour aims; a long handle moves the box "
                    "centre off it), or the box centre in a pose without a basin")


class PlanTrajectory(ProfileModel):
    """The via-poses of one plan, first = start (outside the object), last = end."""

    plan: str
    via_poses: list[ViaPose] = Field(min_length=2, max_length=8)


class ScoringCode(ProfileModel):
    """Output of stage 6: vectorised numpy source of ``def score(...)``, success when > 0."""

    description: str
    source: str


class SegmentState(ProfileModel):
    """Where one segment of an articulated agent (a body's pelvis, torso, thigh, ...) came to rest."""

    agent: int = Field(ge=0, description="the agent the segment belongs to")
    name: str = Field(description="the segment's body name in the agent fragment")
    height: float = Field(description="height of the segment's origin (its proximal joint) above the ground, m")
    up: float = Field(ge=-1, le=1, description="cosine of the angle between the segment's own z axis and the "
                                               "vertical (1: upright, 0: level)")
    touching_object: bool = Field(description="the segment touches the object")
    on_ground: bool = Field(description="the segment touches the ground")
    reaches_object: bool = Field(default=False, description="touching nothing, the segment reaches the object: a "
                                                            "foot by bending the knee on to its limit (a rung, or "
                                                            "the floor past the seat's front), a "
                                                            "thigh over a seat pan it rose off (a low seat), a "
                                                            "torso reclining onto a back; for a pelvis touching it: "
                                                            "the object bears both sitting bones")


class ResultSummary(ProfileModel):
    """A rollout's resultant configuration, summarised over its agents."""

    frac_inside_bbox: float = Field(description="agents with |x|<h_x, |y|<h_y, |z|<h_z")
    frac_on_ground: float = Field(description="agents touching the ground")
    frac_touching_object: float = Field(description="agents touching the object")
    mean_height: float = Field(description="mean agent z divided by h_z (task frame; top = 1, ground = -1)")
    object_tilt_deg: float = Field(description="how far the object tilted from its pose, deg")
    agent_tilt_deg: float = Field(description="mean angle between agent +z and task +z")
    agent_speed: float = Field(description="mean agent speed at the end, m/s")
    frac_through_object: float = Field(
        default=0.0, description="agents on the ground beneath the middle of the object (within half its "
                                 "footprint): they came through it"
    )
    frac_beneath_middle: float = Field(
        default=0.0, description="agents whose centre lies beneath or over the middle of the object (within half "
                                 "its footprint), whatever they rest on"
    )
    frac_open_side: float = Field(
        default=0.0, description="agents inside the box that lie open to one side: horizontal rays from the agent "
                                 "leave without meeting the object over a sector of at least 67 deg (no enclosing "
                                 "wall there)"
    )
    segments: list[SegmentState] = Field(
        default_factory=list, description="an articulated agent's segments, agent by agent; empty for one-body agents"
    )


class CandidateInteraction(ProfileModel):
    """A plan and what happened: a candidate when its score said success, evidence when it said failure."""

    plan: str = Field(description="the plan's name")
    description: str = Field(description="the plan in words")
    via_poses: list[Vec3] = Field(description="layout-centre positions in this pose's task frame, m")
    score: float = Field(description="the scoring function's value: > 0 is success")
    summary: ResultSummary = Field(description="where the agents came to rest")


class PoseShape(ProfileModel):
    """The object's shape as one pose shows it (rail_mj.stable_poses.shape): what a model judging the pose cannot
    read from the rollouts' numbers."""

    open_faces: list[str] = Field(description="faces of the pose's box (top, bottom, front, back, left, right) "
                                              "through which most of the object's cavity sees out; [] for none")
    cavity: float = Field(ge=0, le=1, description="share of the pose's box that is cavity: empty, and bounded by the "
                                                  "object on at least 4 of its 6 sides")
    as_it_came: bool | None = Field(description="this pose has the mesh file's own up axis up (within 20 deg): the "
                                                "pose the object was modelled or scanned in; null for an object that "
                                                "came in an arbitrary orientation")


class PoseCandidates(ProfileModel):
    """One stable pose and its candidate functional interactions."""

    pose_index: int = Field(ge=0, description="the stable pose's index")
    probability: float = Field(ge=0, le=1, description="how often drops of the object end in this pose")
    half_extents: Vec3 = Field(description="half sizes h (m) of the object's world-aligned box in this pose, x, y, z")
    basin: BasinInfo | None = Field(default=None, description="where water poured into the object's deepest basin "
                                                              "stands in this pose: its spill level (the rim's lowest "
                                                              "point, below a rising handle), opening and length; "
                                                              "null without a basin")
    toe_room: float | None = Field(default=None, description="the widest foot (m) that gets under the middle of the "
                                                             "object at toe height from beside it (0: a wall all "
                                                             "round at the floor); null where not mapped")
    shape: PoseShape | None = Field(default=None, description="the object's shape in this pose; null where not "
                                                              "measured")
    candidates: list[CandidateInteraction] = Field(description="the pose's plans the scoring function called "
                                                               "successful")
    failed: list[CandidateInteraction] = Field(
        default_factory=list, description="the pose's plans that the scoring function called failures: evidence"
    )


class PoseVerdict(ProfileModel):
    """Whether one pose's success is consistent with common sense."""

    pose_index: int
    accept: bool
    reason: str
    plan: str | None = Field(description="the best accepted plan in this pose, null when rejected")


class FunctionalPoseVerdict(ProfileModel):
    """Output of stage 7: a verdict per pose and the best (pose, plan) if any is accepted."""

    poses: list[PoseVerdict]
    best_pose: int | None
    best_plan: str | None
    reason: str
