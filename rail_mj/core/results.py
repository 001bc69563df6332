"""What the pipeline returns per (object, affordance): typed, JSON-serialisable."""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from rail_mj.core.types import Basin, StablePose

__all__ = ["BasinInfo", "PoseInfo", "PlanInfo", "PoseProbability", "AffordanceResult"]


class BasinInfo(BaseModel):
    """A pose's deepest basin (:class:`rail_mj.core.types.Basin`) as JSON."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    rim: float = Field(description="spill level of the pose's deepest basin above the ground, m (a vessel's aspect "
                                   "is judged at it)")
    opening: list[float] = Field(min_length=2, max_length=2, description="x, y (m) of the middle of that basin's "
                                 "water surface from the box centre (where pours aim)")
    length: float = Field(description="longer side (m) of that basin's water surface at the spill level")
    floor: float = Field(default=0.0, description="height (m) of that basin's floor where it is deepest above the "
                                                  "ground (a wine glass's stem raises it)")

    @classmethod
    def of(cls, basin: Basin | None) -> BasinInfo | None:
        if basin is None:
            return None
        return cls(rim=float(basin.rim), opening=[float(v) for v in basin.opening], length=float(basin.length),
                   floor=float(basin.floor))

    def to_basin(self) -> Basin:
        return Basin(rim=self.rim, opening=np.asarray(self.opening, dtype=np.float64), length=self.length,
                     floor=self.floor)


class PoseInfo(BaseModel):
    """A stable pose of the object (see rail_mj.core.types for the frames)."""

    model_config = ConfigDict(frozen=True)

    index: int = Field(description="index into the object's stable poses, most probable first")
    pos: list[float] = Field(description="world position of the mesh-frame origin, m")
    quat: list[float] = Field(description="world orientation of the mesh frame, wxyz")
    probability: float = Field(description="fraction of drops that ended in this pose")
    half_extents: list[float] = Field(description="half-sizes of the world-aligned box in this pose, m")
    up_in_mesh_frame: list[float] = Field(description="mesh-frame unit vector pointing up in this pose")
    basin: BasinInfo | None = Field(default=None, description="where poured water stands in this pose; None "
                                    "without a basin")
    toe_room: float | None = Field(default=None, description="the widest foot (m) that gets under the middle of "
                                   "the object at toe height from beside it; None where not mapped")

    @classmethod
    def from_pose(cls, index: int, pose: StablePose) -> PoseInfo:
        """The one way a :class:`StablePose` becomes JSON (results, the stable-pose cache)."""
        return cls(
            index=index,
            pos=[float(v) for v in pose.pos],
            quat=[float(v) for v in pose.quat],
            probability=float(pose.probability),
            half_extents=[float(v) for v in pose.half_extents],
            up_in_mesh_frame=[float(v) for v in pose.up_in_mesh_frame],
            basin=BasinInfo.of(pose.basin),
            toe_room=pose.toe_room,
        )

    def to_pose(self) -> StablePose:
        """The :class:`StablePose` this record holds (render, the robot, the stable-pose cache)."""
        return StablePose(pos=np.asarray(self.pos, dtype=np.float64), quat=np.asarray(self.quat, dtype=np.float64),
                          probability=self.probability, half_extents=np.asarray(self.half_extents, dtype=np.float64),
                          basin=None if self.basin is None else self.basin.to_basin(), toe_room=self.toe_room)


class PlanInfo(BaseModel):
    """One imagined interaction plan and how it scored."""

    model_config = ConfigDict(frozen=True)

    index: int
    name: str
    description: str
    via_poses: list[list[float]] = Field(description="K x 7 via-poses of the layout centre, task frame")
    score: float


class PoseProbability(BaseModel):
    """How probable it is that one imagined stable pose affords the use: prior × physics
    (:mod:`rail_mj.pipeline.verdicts`)."""

    model_config = ConfigDict(frozen=True)

    index: int = Field(description="index into the object's stable poses")
    prior: float = Field(ge=0, le=1, description="size prior of the object x pose prior of this pose's box")
    prior_factors: str = Field(default="", description="each size's plausibility in words")
    physics: float = Field(ge=0, le=1, description="fraction of the worlds (nominal + perturbed) in which the "
                                                   "best plan succeeded")
    probability: float = Field(ge=0, le=1, description="prior x physics")
    best_plan: str | None = Field(default=None, description="the plan that succeeded in the most worlds")
    successes: int = Field(default=0, ge=0, description="worlds in which the best plan succeeded")
    worlds: int = Field(default=1, ge=1, description="worlds of the object (1 + perturbations, + 1 for the second "
                                                  "decomposition where it matters): physics' denominator")
    imagined: int = Field(default=1, ge=1, description="worlds this pose was imagined in: all of them with a "
                                                       "candidate in the nominal world, else the nominal one alone")
    blew_up: list[str] = Field(default_factory=list, description="rollouts of this pose that blew up (failures)")


class AffordanceResult(BaseModel):
    """The verdict for one object and one requested affordance."""

    object: str
    affordance: str = Field(description="the affordance that was imagined")
    requested: str = Field(description="the affordance the user asked for")
    alternative: str | None = Field(
        default=None, description="what the analyser proposed when the dimensions did not fit"
    )
    dims_fit: bool | None = Field(
        default=None, description="the Affordance Analyzer's dimension check; None when the case failed before it"
    )
    functional: bool = Field(default=False, description="probability >= 0.5: the use is more likely than not")
    probability: float = Field(
        default=0.0, ge=0.0, le=1.0, allow_inf_nan=False,
        description="how likely the object affords the use, in [0, 1]: the most probable pose's size prior x pose "
                    "prior x physics (rail_mj.pipeline.verdicts); the OBB's prior, or the most plausible pose's, alone "
                    "when it is negligible (< 0.01) and nothing was imagined",
    )
    prior: str = Field(default="", description="the prior's factors in words (each size, its typical range and "
                                               "width, its plausibility), for the most probable pose")
    pose_verdicts: list[PoseProbability] = Field(default_factory=list,
                                                 description="per imagined pose: prior, physics, probability")
    functional_pose: PoseInfo | None = None
    best_plan: PlanInfo | None = None
    pose_without_analyzer: PoseInfo | None = Field(
        default=None, description="the best-scoring pose when the Functional Pose Analyzer is skipped"
    )
    stable_poses: list[PoseInfo] = Field(default_factory=list)
    plans: list[str] = Field(default_factory=list, description="plan names, the columns of `scores`")
    scores: list[list[float]] = Field(default_factory=list, description="stable pose x plan scores")
    analyzer_reasons: list[str] = Field(default_factory=list)
    agent_fragment: str = ""
    agent_offsets: list[list[float]] = Field(default_factory=list)
    evidence_pose: int | None = Field(
        default=None, description="stable pose of the rollout kept as evidence (best, or best-scoring)"
    )
    evidence_agent_pos: list[list[float]] = Field(
        default_factory=list, description="N x 3 final agent positions of that rollout, task frame"
    )
    scoring_source: str = ""
    profile_notes: list[str] = Field(default_factory=list, description="what the import of a profile folder "
                                                                       "adapted to run it; empty otherwise")
    timings: dict[str, float] = Field(default_factory=dict, description="seconds per stage")
    definition: str | None = Field(default=None, description="for a use outside the registry: how the provider "
                                                             "defined it (stage 0)")
    definition_toml: str | None = Field(default=None, description="the row it wrote, as an affordance file's "
                                                                  "[[affordance]] table; None without one")
    profile_check: str | None = Field(default=None, description="a model-written affordance's (row or profile) "
                                                                "proof on its prototypes, before it judged any "
                                                                "object; None for the library's and a folder's")
    llm_calls: dict[str, int] = Field(default_factory=dict, description="requests this case sent to the model, per "
                                                                        "stage (a profile reused from an earlier "
                                                                        "case sends none; the offline library none)")
    llm_repairs: dict[str, int] = Field(default_factory=dict, description="repair rounds among them, per stage")
    provider: str = ""
    backend: str = ""
    mesh_notes: list[str] = Field(
        default_factory=list, description="what loading changed in the mesh beyond repair, e.g. decimation"
    )
    error: str | None = Field(default=None, description="why this case failed, when it did")
