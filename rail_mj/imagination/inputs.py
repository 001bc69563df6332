"""What the imagination takes from a profile: via-pose arrays per plan and the agent grid, for one pose.

Via-poses are ``rel * h + offset_m`` in the task frame (see
:mod:`rail_mj.core.profile`); these functions turn them into metres for one
stable pose's half extents ``h`` and basin.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rail_mj.core.errors import ConfigError
from rail_mj.core.profile import AgentLayout, PlanTrajectory
from rail_mj.core.types import AgentSetup, Basin

__all__ = ["layout_offsets", "via_positions", "trajectory_array", "agent_setup"]


def layout_offsets(layout: AgentLayout) -> np.ndarray:
    """Agent positions (N, 3) about the layout centre: the explicit ``offsets`` when given, else the grid, x
    fastest."""
    if layout.offsets is not None:
        return np.array(layout.offsets, dtype=float).reshape(-1, 3)
    axes = [
        (np.arange(n) - (n - 1) / 2.0) * s
        for n, s in ((layout.nx, layout.sx), (layout.ny, layout.sy), (layout.nz, layout.sz))
    ]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


def via_positions(trajectory_via: list, half_extents: np.ndarray,
                  opening: np.ndarray | None = None) -> np.ndarray:
    """Positions (K, 3) in metres of via-poses for the half extents ``h`` of one pose and its ``opening`` (x, y
    of its basin from the box centre, m; None without one)."""
    rel = np.array([v.rel for v in trajectory_via], dtype=float)
    off = np.array([v.offset_m for v in trajectory_via], dtype=float)
    pos = rel * np.asarray(half_extents, dtype=float) + off
    if opening is not None:
        at_opening = np.array([v.anchor == "opening" for v in trajectory_via])
        pos[at_opening, :2] += np.asarray(opening, dtype=float)
    return pos


def trajectory_array(trajectories: Sequence[PlanTrajectory] | PlanTrajectory,
                     half_extents: Sequence[float] | np.ndarray,
                     basin: Basin | None = None) -> list[np.ndarray]:
    """Via-poses per plan as (K, 7) arrays (task-frame position xyz, quat wxyz) for one pose's ``h`` and
    ``basin`` (:attr:`rail_mj.core.types.StablePose.basin`: where pours anchored at the opening aim)."""
    h = np.asarray(half_extents, dtype=float)
    if h.shape != (3,) or not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise ConfigError(f"half_extents must be three positive finite values; got {h.tolist()}")
    trajs = [trajectories] if isinstance(trajectories, PlanTrajectory) else trajectories
    out = []
    for t in trajs:
        quat = np.array([v.quat for v in t.via_poses], dtype=float)
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        opening = None if basin is None else basin.opening
        out.append(np.concatenate([via_positions(t.via_poses, h, opening), quat], axis=1))
    return out


def agent_setup(mjcf: str, layout: AgentLayout) -> AgentSetup:
    """The agent fragment and grid offsets the imagination needs."""
    return AgentSetup(fragment=mjcf, offsets=layout_offsets(layout), collide_agents=layout.collide_agents)
