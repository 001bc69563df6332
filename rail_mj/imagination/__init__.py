"""Batched imagination: every stable pose × plan of one object simulated in one call.

``imagine`` places the object in each stable pose, drives the agents through
each plan's via-poses (task frame), releases each agent at the end of its plan
or at its first contact, lets everything settle and returns :class:`Outcomes`.
The inputs are prepared once (:func:`~rail_mj.imagination.batch.prepare`) and
run by a :class:`~rail_mj.imagination.backend.Backend`: ``native`` (MuJoCo C,
threaded batch) or ``mjx`` (JAX, vmapped, compiled once per shape bucket);
``auto`` picks mjx on GPU/TPU, native on CPU.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from rail_mj.core.errors import ImaginationError
from rail_mj.core.types import AgentSetup, Outcomes, RailObject, StablePose, StablePoses
from rail_mj.imagination.backend import Backend, Progress
from rail_mj.imagination.batch import Placement, RolloutBatch, pose_plan, prepare, rollout_index
from rail_mj.imagination.config import ImaginationConfig
from rail_mj.imagination.perturb import Perturbation, PerturbationSet, draw_perturbations
from rail_mj.imagination.registry import BACKENDS, get_backend, resolve_backend

__all__ = [
    "BACKENDS",
    "Backend",
    "ImaginationConfig",
    "Perturbation",
    "PerturbationSet",
    "draw_perturbations",
    "Placement",
    "RolloutBatch",
    "get_backend",
    "imagine",
    "pose_plan",
    "prepare",
    "resolve_backend",
    "rollout_index",
]


def imagine(
    obj: RailObject,
    poses: StablePoses | Sequence[StablePose],
    agents: AgentSetup,
    trajectories: Sequence[np.ndarray] | Sequence[Sequence[np.ndarray]],
    *,
    backend: str | Backend = "auto",
    config: ImaginationConfig | None = None,
    progress: Progress | None = None,
    perturbations: PerturbationSet | None = None,
) -> Outcomes:
    """Simulate every (stable pose, plan) pair, pose-major, and return their outcomes.

    ``trajectories[i]`` is plan i's (K_i, 7) via-poses of the layout centre (pos xyz + quat wxyz) in the task
    frame, shared by all poses; or ``trajectories[p][i]`` per pose (via-poses that scale with each pose's
    half extents). Agents start at ``via[0] + offsets``. ``backend`` is a name (``auto``, ``native``, ``mjx``)
    or a :class:`Backend`, which brings its own config. ``progress(done, total)`` is called with simulated steps.
    ``perturbations`` (:func:`rail_mj.imagination.perturb.draw_perturbations`) adds its perturbed worlds to the same
    batch, world-major after the nominal rollouts (``Outcomes.world``); None: the nominal world alone.
    """
    if isinstance(backend, Backend):
        if config is not None and config != backend.config:
            raise ImaginationError(
                f"the {backend.name} backend was built with its own config; pass config=None, or build the "
                f"backend with this config (get_backend({backend.name!r}, config))"
            )
        engine = backend
    else:
        engine = get_backend(backend, config)
    # StablePoses reads as a sequence of StablePose (len, iteration, indexing)
    return engine.run(prepare(obj, cast(Sequence[StablePose], poses), agents, trajectories, engine.config,
                              perturbations), progress=progress)
