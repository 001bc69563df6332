"""Physics and driving settings of the imagination rollouts, locked when a backend is built."""

from __future__ import annotations

import os

from pydantic import BaseModel, ConfigDict, Field

from rail_mj.core.errors import ConfigError
from rail_mj.mjcf import FRICTION, SOLREF_TIMECONST_FACTOR, ScenePhysics

__all__ = ["THREADS_ENV", "ImaginationConfig"]

#: MuJoCo batch threads of this process when a config does not name ``nthread`` (0 or unset: all CPUs).
#: rail_mj.pipeline.parallel sets it in its workers so that workers x threads = cores; outcomes do not depend on it.
THREADS_ENV = "RAIL_MJ_THREADS"


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
