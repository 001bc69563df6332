"""The requests and answers of the seven LLM stages and the request parser, and the imagination profile.

They wrap the profile's neutral types (:mod:`rail_mj.core.profile`: plans,
via-poses, layout, scoring source, rollout summaries), which the kinds produce
without the LLM; the JSON shapes are the prompts' schemas.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from rail_mj.affordances.prototypes import Prototype
from rail_mj.affordances.sizes import UseSizes
from rail_mj.core.profile import (
    AgentLayout,
    FunctionalPoseVerdict,
    MotionPlan,
    PlanTrajectory,
    PoseCandidates,
    PoseShape,
    PoseVerdict,
    ProfileModel,
    Scale,
    ScoringCode,
    Vec3,
)

__all__ = [
    "DefinitionRequest",
    "AffordanceDefinition",
    "TaskDescription",
    "AnalyzerRequest",
    "AffordanceAnalysis",
    "AgentModelRequest",
    "AgentModel",
    "LayoutRequest",
    "PlannerRequest",
    "MotionPlans",
    "TrajectoryRequest",
    "Trajectories",
    "ScoringRequest",
    "FunctionalPoseRequest",
    "PoseVerdict",
    "FunctionalPoseVerdict",
    "ImaginationProfile",
    "Preposition",
    "RequestText",
    "Request",
]


class DefinitionRequest(ProfileModel):
    """Input of stage 0, the Affordance Definer: a named use outside the registry and the loaded files."""

    affordance: str


class AffordanceDefinition(ProfileModel):
    """Output of stage 0: the use as a row of a registered kind, whose tested physics then imagines it, or the
    reason no kind models it (the stages 1-6 then write a free-form profile)."""

    affordance: str
    kind: str | None = Field(description="the registered kind whose physics tests this use; null when none does")
    row_toml: str | None = Field(description="the use as one [[affordance]] table of an affordance file (TOML); "
                                             "null exactly when kind is null")
    size_basis: list[str] = Field(description="one line per size range of the row: what real objects of the use "
                                              "measure and where that comes from; empty when kind is null")
    prototypes: list[Prototype] = Field(description="with a kind: at least one positive prototype and one near-miss "
                                                    "negative, which the row is proven on before use; [] when kind "
                                                    "is null")
    reason: str = Field(description="why this kind's test is the use's test, or why no kind models the use")


class TaskDescription(ProfileModel):
    """d_task: the requested affordance and the object's OBB extents (m, sorted descending), or none: a profile for
    every object of the use (a use no kind models: its sizes and prototypes come from stage 1)."""

    affordance: str
    obb_dims: Vec3 | None = Field(description="the object's OBB extents, m, sorted descending; null: the profile "
                                              "serves every object of the use")
    scale: Scale = 1.0


class AnalyzerRequest(ProfileModel):
    """Input of stage 1, the Affordance Analyzer."""

    task: TaskDescription


class AffordanceAnalysis(ProfileModel):
    """Output of stage 1: dimension check, IBD and the imagination outline."""

    affordance: str = Field(description="the affordance analysed (the requested one)")
    fits: bool = Field(description="whether the object's dimensions are plausible for the affordance")
    reason: str = Field(description="why the dimensions fit or not, with the sizes compared")
    alternative: str | None = Field(description="an affordance the dimensions do fit when fits is false, else null")
    ibd: str = Field(description="interaction-based definition of the affordance")
    agent_description: str = Field(description="shape, size and layout of the agent(s)")
    interaction_description: str = Field(description="how the agents move to interact with the object")
    expected_outcome: str = Field(description="resultant configuration that means the object affords it")
    sizes: UseSizes | None = Field(default=None, description="with a task of no obb_dims: the use's typical sizes, "
                                                             "the prior each object is weighed by; else null")
    prototypes: list[Prototype] = Field(default_factory=list, description="with a task of no obb_dims: a positive "
                                                                          "and a near-miss negative prototype the "
                                                                          "profile is proven on; else []")


class AgentModelRequest(ProfileModel):
    """Input of stage 2, the Agent Model Generator."""

    task: TaskDescription
    analysis: AffordanceAnalysis


class AgentModel(ProfileModel):
    """Output of stage 2: one rigid agent as an MJCF fragment (one body, no joints)."""

    name: str
    description: str
    mjcf: str = Field(
        description="<mujoco><worldbody><body name=...><geom .../></body></worldbody></mujoco>, "
        "exactly one body, no joints, geoms with explicit mass, sizes in metres"
    )


class LayoutRequest(ProfileModel):
    """Input of stage 3, the Agent Configuration Generator."""

    task: TaskDescription
    analysis: AffordanceAnalysis
    agent: AgentModel


class PlannerRequest(ProfileModel):
    """Input of stage 4, the Agent Motion Planner."""

    task: TaskDescription
    analysis: AffordanceAnalysis


class MotionPlans(ProfileModel):
    """Output of stage 4: at least five plans from different directions, at most sixteen (a seat for one: four
    headings, the hips at three places along each, and four put down to either side)."""

    plans: list[MotionPlan] = Field(min_length=5, max_length=16)


class TrajectoryRequest(ProfileModel):
    """Input of stage 5, the Trajectory Generator."""

    task: TaskDescription
    analysis: AffordanceAnalysis
    agent: AgentModel
    layout: AgentLayout
    plans: MotionPlans


class Trajectories(ProfileModel):
    """Output of stage 5: one trajectory per plan, same names and order."""

    trajectories: list[PlanTrajectory] = Field(min_length=1)


class ScoringRequest(ProfileModel):
    """Input of stage 6, the Scoring Function Generator."""

    task: TaskDescription
    analysis: AffordanceAnalysis
    agent: AgentModel
    layout: AgentLayout
    plans: MotionPlans


class FunctionalPoseRequest(ProfileModel):
    """Input of stage 7, the Functional Pose Analyzer."""

    affordance: str = Field(description="the use judged")
    expected_outcome: str = Field(description="stage 1's resultant configuration that means the object affords it")
    poses: list[PoseCandidates] = Field(description="the stable poses with a candidate")
    scale: Scale = 1.0
    came_in: PoseShape | None = Field(default=None, description="the object's shape as it came (its mesh file's own "
                                                                "up axis up), whether or not that is a stable pose; "
                                                                "null where not measured")


class ImaginationProfile(ProfileModel):
    """Outputs of stages 1–6 for one affordance and one object size, or every object of the use (``obb_dims``
    None); JSON round-trips."""

    affordance: str
    obb_dims: Vec3 | None
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
    notes: list[str] = Field(default_factory=list, description="what an import adapted to run the profile (a "
                                                               "folder's agents spread apart); empty otherwise")


Preposition = Literal["in", "on"]


class RequestText(ProfileModel):
    """Input of the request parser: what a person asked the robot, e.g. "put the apple in the bowl"."""

    text: str = Field(min_length=1, max_length=500)


class Request(ProfileModel):
    """Output of the request parser: the agent to place and the affordance the object must have for it."""

    text: str = Field(description="the sentence as given")
    agent: str = Field(min_length=1, description="what is placed, singular, without article (apple, doll, water)")
    affordance: str = Field(min_length=1, description="the use asked of the object, singular (bowl, chair, pen "
                                                      "holder)")
    preposition: Preposition = Field(description="in (in, into, inside) or on (on, onto, on top of)")
    owner: str | None = Field(default=None, description="the figure or animal the object's name says it is for "
                                                        "(doll for \"the doll's chair\", dog for \"the dog bed\"), "
                                                        "else null")
