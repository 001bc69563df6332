"""Physics and driving settings of the imagination rollouts, locked when a backend is built."""

from __future__ import annotations

import math
import os
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from rail_mj.core.config import config_error
from rail_mj.core.errors import ConfigError
from rail_mj.mjcf import FRICTION, SOLREF_TIMECONST_FACTOR, ScenePhysics

__all__ = ["THREADS_ENV", "PERTURBATIONS_RANGE", "SEED_RANGE", "ImaginationConfig"]

#: MuJoCo batch threads of this process when a config does not name ``nthread`` (0 or unset: all CPUs).
#: rail_mj.pipeline.parallel sets it in its workers so that workers x threads = cores; outcomes do not depend on it.
THREADS_ENV = "RAIL_MJ_THREADS"


#: Perturbed worlds per (pose, plan): 0 (the nominal world alone) to 32 (the batch grows 33-fold; past that the
#: imagination, not the hulls, dominates an object's time).
PERTURBATIONS_RANGE = (0, 32)
#: Seeds of the perturbation draws: numpy's SeedSequence takes any non-negative integer; 32 bits keep them portable.
SEED_RANGE = (0, 2**32 - 1)
#: Perturbation amplitudes are fractions: 0 turns one off, 0.5 (half again or half as much) is no longer "the same"
#: object.
_AMPLITUDE_RANGE = (0, 0.5)
def _amplitude(default: float, description: str) -> Any:
    """A perturbation amplitude's field: a fraction in :data:`_AMPLITUDE_RANGE`."""
    return Field(default=default, ge=_AMPLITUDE_RANGE[0], le=_AMPLITUDE_RANGE[1], description=description)


def _env_threads() -> int:
    raw = os.environ.get(THREADS_ENV, "0").strip() or "0"
    if not raw.isdigit():
        raise ConfigError(f"{THREADS_ENV}={raw!r}: give a whole number of threads (0 = all CPUs), or unset it")
    return int(raw)


class ImaginationConfig(BaseModel):
    """Physics and driving settings of the imagination rollouts."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    timestep: float = Field(default=0.005, gt=0, le=0.02, description="simulation step, s")
    solref_factor: float = Field(
        default=SOLREF_TIMECONST_FACTOR, ge=2.0, description="contact time constant as a multiple of the timestep"
    )
    friction: float = Field(default=FRICTION[0], gt=0, description="sliding friction of the ground and the object")
    agent_speed: float = Field(default=0.5, gt=0, description="linear speed of the driven layout centre, m/s")
    agent_angular_speed: float = Field(default=3.0, gt=0,
                                       description="angular speed of the driven layout centre, rad/s")
    settle_time: float = Field(default=3.0, gt=0, description="longest simulated time after the drive, s")
    min_settle_time: float = Field(
        default=1.0, ge=0,
        description="rest sooner than this after a world's agents are all released does not count, s: a body set "
                    "down on a balance point starts at rest and needs a moment to topple (1 s is three toppling time "
                    "constants sqrt(L/g) of a 1 m tall body)",
    )
    settle_speed: float = Field(default=0.02, gt=0,
                                description="a body is at rest when no point of it moves faster, m/s")
    check_every: int = Field(default=20, ge=1, description="steps between settle checks")
    iterations: int = Field(default=20, ge=1, description="constraint solver iterations")
    ls_iterations: int = Field(default=10, ge=1, description="solver line-search iterations")
    nthread: int = Field(default_factory=_env_threads, ge=0, description="native threads; 0 = all CPUs")
    max_hull_vertices: int = Field(default=32, ge=4,
                                   description="MuJoCo simplifies each hull to at most this many vertices")
    speculative: bool = Field(
        default=True,
        description="speculative contacts (native): fast small droplets do not tunnel through thin bottoms"
    )
    perturbations: int = Field(
        default=4, ge=PERTURBATIONS_RANGE[0], le=PERTURBATIONS_RANGE[1], strict=True,
        description="perturbed worlds per (pose, plan), run in the same batch as the nominal one "
                    "(rail_mj.imagination.perturb); 0: the nominal world alone")
    seed: int = Field(default=0, ge=SEED_RANGE[0], le=SEED_RANGE[1], strict=True,
                      description="seed of the perturbation draws")
    # the mesh-scale uncertainty: a scan or a CAD model's units are good to about 10%
    perturb_scale: float = _amplitude(0.10, "mesh scale varies by +-this fraction")
    # sliding friction of dry household materials on each other spans about +-30% with surface condition
    perturb_friction: float = _amplitude(0.30, "friction varies by +-this fraction")
    # what is put on or in an object (a person, an apple, a doll) varies in weight by about +-20% within its kind
    perturb_agent_mass: float = _amplitude(0.20, "agent mass varies by +-this fraction")
    # and in size by about +-10% (body heights within one standard deviation of the mean are +-4-6%; fruit +-10%)
    perturb_agent_size: float = _amplitude(0.10, "agent size varies by +-this fraction")
    # a plan aims within about 5% of the object's half extents (a robot's placement error on a 20 cm object: 5 mm)
    perturb_offset: float = _amplitude(0.05, "plans shift sideways by +-this fraction of the pose's half extents")

    # a second CoACD setting shapes a cavity's hulls otherwise (rail_mj.mesh.second_decomposition)
    perturb_decomposition: bool = Field(
        default=True,
        description="where the object's concavities carry the use (a kind's decomposition_matters), imagine the "
                    "poses the perturbed worlds imagine once more on the object's second decomposition")

    def __init__(self, **data: Any) -> None:
        # a bad setting is the project's ConfigError naming its declared range (model_validate, e.g. a run
        # config's nested dict, reports the same range as pydantic's ValidationError)
        try:
            super().__init__(**data)
        except ValidationError as exc:
            raise config_error(type(self), exc) from None

    @property
    def settle_steps(self) -> int:
        """``settle_time`` in steps: the longest a world runs after the batch's drive."""
        return math.ceil(self.settle_time / self.timestep)

    @property
    def hold_steps(self) -> int:
        """``min_settle_time`` in steps: how long after its release a world's rest starts to count."""
        return math.ceil(self.min_settle_time / self.timestep)

    @property
    def physics(self) -> ScenePhysics:
        """The scene composer's settings for these rollouts."""
        return ScenePhysics(
            timestep=self.timestep,
            solref_factor=self.solref_factor,
            friction=self.friction,
            iterations=self.iterations,
            ls_iterations=self.ls_iterations,
            speculative=self.speculative,
            max_hull_vertices=self.max_hull_vertices,
        )
