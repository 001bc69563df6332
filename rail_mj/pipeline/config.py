"""The settings of a classification run, as one tree: the run's own options and each stage's config.

:class:`RunConfig` nests the configs of the stages it runs: ``decomposition`` (CoACD, rail_mj.mesh),
``stable_poses`` (:class:`~rail_mj.stable_poses.StablePoseConfig`) and ``imagination``
(:class:`~rail_mj.imagination.ImaginationConfig`); the :class:`~rail_mj.pipeline.chain.Pipeline` passes each
down to its stage. Its defaults give the chain's defaults. :class:`ObjectInput` is one mesh file to classify.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from rail_mj.imagination.config import ImaginationConfig
from rail_mj.llm.schemas import ImaginationProfile
from rail_mj.mesh import DecompositionConfig
from rail_mj.profiles import PROFILE_DIR_ENV, Origin, default_profile_dir
from rail_mj.stable_poses.config import StablePoseConfig

__all__ = ["PoseMode", "Definition", "RunOptions", "RunConfig", "ObjectInput"]

#: ``stable``: imagine every stable pose found by dropping the object; ``as_placed``: only the pose it stands in.
PoseMode = Literal["stable", "as_placed"]


class Definition(BaseModel):
    """A use outside the registry as the provider defined it (stage 0): a row of a registered kind, or none."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str = Field(description="the use as requested")
    row_toml: str | None = Field(description="its [[affordance]] table; None: no kind models it")
    reason: str = Field(description="why the kind's test is the use's test, or why no kind's is")
    size_basis: list[str] = Field(default_factory=list, description="what each size range of the row comes from")
    profile: ImaginationProfile | None = Field(
        default=None, description="without a row: the free-form profile (stages 1-6) written once for every object "
                                  "of the use, at the run's agent scale, proven on its prototypes")
    profile_check: str | None = Field(default=None, description="the row's or the profile's proof on its "
                                                                "prototypes, in words")
    by: str = Field(description="provider:model that wrote it")
    llm_calls: dict[str, int] = Field(default_factory=dict, description="requests sent for it, per stage (stage 0, "
                                                                        "and stages 1-6 for a profile; none: "
                                                                        "answered from the cache)")
    llm_repairs: dict[str, int] = Field(default_factory=dict, description="repair rounds among them, per stage")


class RunOptions(BaseModel):
    """The run's own options (no stage's config): provider, backend, LLM, profile reuse and folders, poses and
    agent."""

    model_config = ConfigDict(extra="forbid")

    provider: str = Field(default="auto", description="auto | offline | anthropic | openai")
    backend: str = Field(default="auto", description="auto | native | mjx")
    model: str | None = Field(default=None, description="LLM model name (anthropic, openai provider)")
    # None: the provider's own default (rail_mj.llm.ProviderConfig, LLMConfig: each declared there with its range)
    max_retries: int | None = Field(default=None, description="LLM repair rounds per stage (--max-repairs); None: "
                                                              "the provider's")
    cache: bool | None = Field(default=None, description="cache LLM answers on disk; None: the provider's")
    llm_timeout: float | None = Field(default=None, description="seconds one LLM request may take (--llm-timeout); "
                                                                "None: the provider's")
    llm_pictures: bool | None = Field(default=None, description="send stage 7 a picture of each pose "
                                                                "(--no-llm-pictures); None: the provider's")
    provider_options: dict[str, Any] = Field(
        default_factory=dict, description="further settings of the provider (rail_mj.llm.get_provider: temperature, "
                                          "max_tokens, base_url, http_retries, strict, ...); the fields above win")
    profile_bin: float = Field(
        default=0.1, gt=0, le=1.0, description="relative size bin within which a profile is reused"
    )
    min_pose_probability: float = Field(
        default=0.0, ge=0, lt=1, description="stable poses rarer than this are not imagined"
    )
    pose: PoseMode = Field(default="stable", description="stable: search the stable poses; as_placed: the "
                                                         "object's pose as it stands (mesh frame z up, on the ground)")
    agent: str | None = Field(default=None, description="the request's agent (doll, apple, ...): a figure scales "
                                                        "every real-world size of the affordance (rail_mj."
                                                        "affordances.request_scale)")
    owner: str | None = Field(default=None, description="the figure or animal the request's object is for, by its "
                                                        "name (doll for \"the doll's chair\", dog for \"the dog "
                                                        "bed\"): sets the scale in place of the agent")
    affordances_files: list[Path] = Field(
        default_factory=list, description="affordance files (TOML, rail_mj.affordances.files) whose rows are "
                                          "registered before the names are checked, in this process and in "
                                          "every worker (absolute paths: a worker may run elsewhere)"
    )

    save_affordance: Path | None = Field(
        default=None, description="write each use the provider defined, once proven and before any object: a row as "
                                  "DIR/<use>.toml (an affordance file), a profile as DIR/<use>/ (a profile folder "
                                  "with definition.txt); both load with no model (--affordances-file, --profile-dir)")
    definitions: list[Definition] = Field(
        default_factory=list, description="uses outside the registry that the provider defined (stage 0), filled "
                                          "by classify before any object: a row is registered here and in every "
                                          "worker and imagined with its kind's tested physics; without a row, the "
                                          "provider writes a free-form profile")

    profile_dir: Path | None = Field(
        default_factory=default_profile_dir,
        description="a profile folder in the paper authors' format, or a folder of them named by affordance "
                    "(rail_mj.profiles): an affordance with a folder is imagined from it, the stages it lacks and "
                    "the other affordances from the provider (absolute: a worker may run elsewhere; default "
                    f"${PROFILE_DIR_ENV})")
    profile_adapt: bool = Field(
        default=True, description="adapt what a profile folder's format leaves open the way the authors' simulator "
                                  "would run it (agents that start inside each other spread apart), each adaptation "
                                  "named in the result's profile_notes; False: refuse such a folder")
    profile_origin: Origin = Field(
        default="ground", description="where the folders' via-points start: ground (the centre of the object's "
                                      "footprint on the ground, z up) or center (the centre of its box)")

    @field_validator("affordances_files")
    @classmethod
    def _absolute(cls, paths: list[Path]) -> list[Path]:
        return [p.resolve() for p in paths]

    @field_validator("profile_dir", "save_affordance")
    @classmethod
    def _absolute_dir(cls, path: Path | None) -> Path | None:
        return None if path is None else path.expanduser().resolve()


class RunConfig(RunOptions):
    """Settings of a classification run: its options and the config of each stage."""

    decomposition: DecompositionConfig | None = Field(
        default=None, description="CoACD settings; None: chosen per mesh (rail_mj.mesh.decomposition_for), with "
                                  "the hull quality guard"
    )
    stable_poses: StablePoseConfig = Field(default_factory=StablePoseConfig, description="the stable-pose search")
    imagination: ImaginationConfig = Field(default_factory=ImaginationConfig,
                                           description="physics and driving of the imagination rollouts")


class ObjectInput(BaseModel):
    """A mesh file and how to read it."""

    path: Path
    units: float = Field(default=1.0, gt=0, description="metres per mesh unit")
    up: Literal["z", "y"] = "z"
    name: str | None = None
    oriented: bool = Field(default=True, description="the file stands the object as it came to rest (as made, "
                           "or as it fell); False: an arbitrary orientation (a generated set's random rotations), "
                           "no evidence of the pose it was made to stand in")
