"""Typed inputs and outputs of the seven LLM stages, and the imagination profile.

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

from pydantic import BaseModel, ConfigDict, Field

from rail_mj.core.results import BasinInfo

__all__ = [
    "Vec3",
    "TaskDescription",
    "AnalyzerRequest",
    "AffordanceAnalysis",
    "AgentModelRequest",
    "AgentModel",
    "LayoutRequest",
    "AgentLayout",
    "PlannerRequest",
    "MotionPlan",
    "MotionPlans",
    "TrajectoryRequest",
    "ViaPose",
    "PlanTrajectory",
    "Trajectories",
    "ScoringRequest",
    "ScoringCode",
    "ResultSummary",
    "CandidateInteraction",
    "PoseCandidates",
    "FunctionalPoseRequest",
    "PoseVerdict",
    "FunctionalPoseVerdict",
    "ImaginationProfile",
    "Preposition",
    "RequestText",
    "Request",
]

Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Quat = Annotated[list[float], Field(min_length=4, max_length=4, description="unit quaternion w, x, y, z")]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


#: Agent scale: the request's agent against a person (rail_mj.affordances.request_scale; a doll 0.18).
Scale = Annotated[float, Field(gt=0, le=10, description="size of the agent the object is for, relative to a "
                                                        "person's (a doll: 0.18); every real-world size of the "
                                                        "affordance scales by it")]


class TaskDescription(_Model):
    """d_task: the requested affordance and the object's OBB extents (m, sorted descending)."""

    affordance: str
    obb_dims: Vec3
    scale: Scale = 1.0


class AnalyzerRequest(_Model):
    """Input of stage 1, the Affordance Analyzer."""

    task: TaskDescription


class AffordanceAnalysis(_Model):
    """Output of stage 1: dimension check, IBD and the imagination outline."""

    affordance: str = Field(description="the affordance analysed (the requested one)")
    fits: bool = Field(description="whether the object's dimensions are plausible for the affordance")
    reason: str = Field(description="why the dimensions fit or not, with the sizes compared")
    alternative: str | None = Field(description="an affordance the dimensions do fit when fits is false, else null")
    ibd: str = Field(description="interaction-based definition of the affordance")
    agent_description: str = Field(description="shape, size and layout of the agent(s)")
    interaction_description: str = Field(description="how the agents move to interact with the object")
    expected_outcome: str = Field(description="resultant configuration that means the object affords it")


class AgentModelRequest(_Model):
    """Input of stage 2, the Agent Model Generator."""

    task: TaskDescription
    analysis: AffordanceAnalysis


class AgentModel(_Model):
    """Output of stage 2: one rigid agent as an MJCF fragment (one body, no joints)."""

    name: str
    description: str
    mjcf: str = Field(
        description="<mujoco><worldbody><body name=...><geom .../></body></worldbody></mujoco>, "
        "exactly one body, no joints, geoms with explicit mass, sizes in metres"
    )


class LayoutRequest(_Model):
    """Input of stage 3, the Agent Configuration Generator."""

    task: TaskDescription
    analysis: AffordanceAnalysis
    agent: AgentModel


class AgentLayout(_Model):
    """Output of stage 3: a world-aligned grid of identical agents about the layout centre."""

    nx: int = Field(ge=1, le=12)
    ny: int = Field(ge=1, le=12)
    nz: int = Field(ge=1, le=12)
    sx: float = Field(gt=0, description="spacing along x between neighbouring agent centres, m")
    sy: float = Field(gt=0, description="spacing along y, m")
    sz: float = Field(gt=0, description="spacing along z, m")
    collide_agents: bool = Field(description="whether agents collide with each other (droplets pile up)")

    @property
    def n_agents(self) -> int:
        return self.nx * self.ny * self.nz


class PlannerRequest(_Model):
    """Input of stage 4, the Agent Motion Planner."""

    task: TaskDescription
    analysis: AffordanceAnalysis


class MotionPlan(_Model):
    """One high-level plan in language, step by step from the start to the end point."""

    name: str = Field(description="short identifier, e.g. above, front, back, left, right")
    description: str


class MotionPlans(_Model):
    """Output of stage 4: at least five plans from different directions."""

    plans: list[MotionPlan] = Field(min_length=5, max_length=12)


class TrajectoryRequest(_Model):
    """Input of stage 5, the Trajectory Generator."""

    task: TaskDescription
    analysis: AffordanceAnalysis
    agent: AgentModel
    layout: AgentLayout
    plans: MotionPlans


class ViaPose(_Model):
    """A via-pose of the layout centre: position ``rel * h + offset_m`` in the task frame, from the box centre or
    from the pose's opening."""

    rel: Vec3 = Field(description="position in units of the object's half extents h (task frame)")
    offset_m: Vec3 = Field(description="additional offset in metres (agent-size clearances)")
    quat: Quat
    anchor: Literal["box", "opening"] = Field(
        "box", description="'box': x and y from the centre of the object's box; 'opening': from the middle of the "
                           "pose's deepest basin seen from above (where a pour aims; a long handle moves the box "
                           "centre off it), or the box centre in a pose without a basin")


class PlanTrajectory(_Model):
    """The via-poses of one plan, first = start (outside the object), last = end."""

    plan: str
    via_poses: list[ViaPose] = Field(min_length=2, max_length=8)


class Trajectories(_Model):
    """Output of stage 5: one trajectory per plan, same names and order."""

    trajectories: list[PlanTrajectory] = Field(min_length=1)


class ScoringRequest(_Model):
    """Input of stage 6, the Scoring Function Generator."""

    task: TaskDescription
    analysis: AffordanceAnalysis
    agent: AgentModel
    layout: AgentLayout
    plans: MotionPlans


class ScoringCode(_Model):
    """Output of stage 6: vectorised numpy source of ``def score(...)``, success when > 0."""

    description: str
    source: str


class ResultSummary(_Model):
    """A rollout's resultant configuration, summarised over its agents."""

    frac_inside_bbox: float = Field(description="agents with |x|<h_x, |y|<h_y, |z|<h_z")
    frac_on_ground: float = Field(description="agents touching the ground")
    frac_touching_object: float = Field(description="agents touching the object")
    mean_height: float = Field(description="mean agent z divided by h_z (task frame; top = 1, ground = -1)")
    object_tilt_deg: float
    agent_tilt_deg: float = Field(description="mean angle between agent +z and task +z")
    agent_speed: float = Field(description="mean agent speed at the end, m/s")
    frac_through_object: float = Field(
        0.0, description="agents on the ground beneath the middle of the object (within half its footprint): "
                         "they came through it"
    )
    frac_beneath_middle: float = Field(
        0.0, description="agents whose centre lies beneath or over the middle of the object (within half its "
                         "footprint), whatever they rest on"
    )
    frac_open_side: float = Field(
        0.0, description="agents inside the box that lie open to one side: horizontal rays from the agent leave "
                         "without meeting the object over a sector of at least 67 deg (no enclosing wall there)"
    )


class CandidateInteraction(_Model):
    """A plan and what happened: a candidate when its score said success, evidence when it said failure."""

    plan: str
    description: str
    via_poses: list[Vec3] = Field(description="layout-centre positions in this pose's task frame, m")
    score: float
    summary: ResultSummary


class PoseCandidates(_Model):
    """One stable pose and its candidate functional interactions."""

    pose_index: int = Field(ge=0)
    probability: float = Field(ge=0, le=1)
    half_extents: Vec3
    basin: BasinInfo | None = Field(None, description="where water poured into the object's deepest basin stands "
                                                      "in this pose: its spill level (the rim's lowest point, below "
                                                      "a rising handle), opening and length; null without a basin")
    candidates: list[CandidateInteraction]
    failed: list[CandidateInteraction] = Field(
        default_factory=list, description="the pose's plans that the scoring function called failures: evidence"
    )


class FunctionalPoseRequest(_Model):
    """Input of stage 7, the Functional Pose Analyzer."""

    affordance: str
    expected_outcome: str
    poses: list[PoseCandidates]
    scale: Scale = 1.0


class PoseVerdict(_Model):
    """Whether one pose's success is consistent with common sense."""

    pose_index: int
    accept: bool
    reason: str
    plan: str | None = Field(description="the best accepted plan in this pose, null when rejected")


class FunctionalPoseVerdict(_Model):
    """Output of stage 7: a verdict per pose and the best (pose, plan) if any is accepted."""

    poses: list[PoseVerdict]
    best_pose: int | None
    best_plan: str | None
    reason: str


class ImaginationProfile(_Model):
    """Outputs of stages 1–6 for one affordance and one object size; JSON round-trips."""

    affordance: str
    obb_dims: Vec3
    provider: str
    model: str
    scale: Scale = 1.0
    prompt_versions: dict[str, str]
    analysis: AffordanceAnalysis
    agent: AgentModel
    layout: AgentLayout
    plans: MotionPlans
    trajectories: Trajectories
    scoring: ScoringCode


Preposition = Literal["in", "on"]


class RequestText(_Model):
    """Input of the request parser: what a person asked the robot, e.g. "put the apple in the bowl"."""

    text: str = Field(min_length=1, max_length=500)


class Request(_Model):
    """Output of the request parser: the agent to place and the affordance the object must have for it."""

    text: str = Field(description="the sentence as given")
    agent: str = Field(min_length=1, description="what is placed, singular, without article (apple, doll, water)")
    affordance: str = Field(min_length=1, description="the use asked of the object, singular (bowl, chair, pen "
                                                      "holder)")
    preposition: Preposition = Field(description="in (in, into, inside) or on (on, onto, on top of)")
