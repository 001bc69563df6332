"""Batched imagination: every stable pose × plan of one object simulated in one call.

``imagine`` places the object in each stable pose, drives the agents through
each plan's via-poses (task frame), releases each agent at the end of its plan
or at its first contact, lets everything settle and returns :class:`Outcomes`.
Backends: ``native`` (MuJoCo C, threaded batch) and ``mjx`` (JAX, vmapped,
compiled once per shape bucket); ``auto`` picks mjx on GPU/TPU, native on CPU.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from rail_mj.errors import ImaginationError
from rail_mj.imagination.common import ImaginationConfig, build_scene_model, drive_table, initial_state, plan_rows
from rail_mj.types import AgentSetup, Outcomes, RailObject, StablePose, StablePoses

__all__ = ["BACKENDS", "ImaginationConfig", "imagine", "resolve_backend", "mjx_compile_count"]

BACKENDS = ("auto", "native", "mjx")


def resolve_backend(backend: str) -> str:
    """``auto`` → ``mjx`` when JAX runs on a GPU/TPU, else ``native``."""
    if backend not in BACKENDS:
        raise ImaginationError(f"unknown imagination backend {backend!r}; valid: {', '.join(BACKENDS)}")
    if backend != "auto":
        return backend
    import jax

    return "mjx" if jax.default_backend() in ("gpu", "tpu", "cuda", "rocm") else "native"


def mjx_compile_count() -> int:
    """How many times the MJX rollout has been traced and compiled in this process."""
    from rail_mj.imagination import mjx

    return mjx.compile_count()


def imagine(
    obj: RailObject,
    poses: StablePoses | Sequence[StablePose],
    agents: AgentSetup,
    trajectories: Sequence[np.ndarray] | Sequence[Sequence[np.ndarray]],
    *,
    backend: str = "auto",
    config: ImaginationConfig | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Outcomes:
    """Simulate every (stable pose, plan) pair, pose-major, and return their outcomes.

    ``trajectories[i]`` is plan i's (K_i, 7) via-poses of the layout centre (pos xyz + quat wxyz) in the task
    frame, shared by all poses; or ``trajectories[p][i]`` per pose (via-poses that scale with each pose's
    half extents). Agents start at ``via[0] + offsets``. ``progress(done, total)`` is called with simulated steps.
    """
    cfg = config or ImaginationConfig()
    pose_list = list(poses)
    if not pose_list:
        raise ImaginationError("imagine needs at least one stable pose; got none")
    offsets = np.asarray(agents.offsets, dtype=np.float64)
    rows, n_plans = plan_rows(trajectories, len(pose_list))
    chosen = resolve_backend(backend)
    if chosen == "native":
        from rail_mj.imagination.native import run_native

        scene = build_scene_model(obj, agents, cfg)
        table = drive_table(rows, cfg)
        init = initial_state(scene, pose_list, n_plans, table, offsets)
        return run_native(scene, init, table, offsets, cfg, progress=progress)
    from rail_mj.imagination.mjx import run_mjx

    return run_mjx(obj, pose_list, agents, rows, n_plans, cfg, progress=progress)
