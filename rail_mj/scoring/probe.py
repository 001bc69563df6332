"""A small synthetic batch shaped exactly like the imagination's, to try generated scoring code on before use.

The arrays have the names, dtypes and per-rollout shapes of the
:class:`~rail_mj.core.types.Outcomes` that :func:`rail_mj.imagination.imagine`
returns (float64 positions, quaternions, velocities, tilts and half extents;
int64 contact counts), pose-major over stable poses × plans like the real
batch. Their values are plausible end states — agents inside the object's
box, resting on its top, on the ground beside it, scattered around it — so
that code which fails only on some configurations fails here too.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rail_mj.core.errors import ConfigError
from rail_mj.core.types import Outcomes
from rail_mj.imagination.batch import PROBE_DIRECTIONS

__all__ = ["probe_outcomes"]

_SCENARIOS = 4  # inside the box, on its top, on the ground beside it, scattered (one object tipped over)


def _tilt_quats(angle: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Unit wxyz quaternions tilted by ``angle`` about random horizontal axes."""
    axis = rng.normal(size=angle.shape + (3,))
    axis[..., 2] = 0.0
    axis /= np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-12)
    return np.concatenate([np.cos(angle / 2)[..., None], np.sin(angle / 2)[..., None] * axis], axis=-1)


def probe_outcomes(n_agents: int, n_plans: int, half_extents: Sequence[Sequence[float]] | np.ndarray, *,
                   seed: int = 0) -> Outcomes:
    """Outcomes of ``len(half_extents) * n_plans`` synthetic rollouts of ``n_agents`` agents (deterministic per seed).

    ``half_extents`` (P, 3) are the object's half sizes in P stable poses.
    """
    h = np.asarray(half_extents, dtype=np.float64).reshape(-1, 3)
    if n_agents < 1 or n_plans < 1 or len(h) == 0 or not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise ConfigError(f"a probe batch needs n_agents >= 1, n_plans >= 1 and positive finite (P, 3) half extents; "
                          f"got {n_agents}, {n_plans}, {h.tolist()}")
    rng = np.random.default_rng(seed)
    pose_index = np.repeat(np.arange(len(h)), n_plans)
    plan_index = np.tile(np.arange(n_plans), len(h))
    batch = len(pose_index)
    half = h[pose_index]
    hb = half[:, None, :]
    scenario = np.arange(batch) % _SCENARIOS

    pos = rng.uniform(-0.8, 0.8, (batch, n_agents, 3)) * hb  # inside the box
    on_top = scenario == 1
    pos[on_top, :, 2] = hb[on_top, :, 2] * rng.uniform(1.02, 1.2, (int(on_top.sum()), n_agents))
    beside = scenario == 2
    side = rng.choice([-1.0, 1.0], (int(beside.sum()), n_agents))
    pos[beside, :, 0] = side * hb[beside, :, 0] * rng.uniform(1.2, 2.0, side.shape)
    pos[beside, :, 2] = -hb[beside, :, 2] * rng.uniform(0.9, 0.98, side.shape)
    scattered = scenario == 3
    pos[scattered] = rng.uniform(-3.0, 3.0, (int(scattered.sum()), n_agents, 3)) * hb[scattered]

    contacts_object = np.where((scenario <= 1)[:, None], rng.integers(1, 4, (batch, n_agents)), 0).astype(np.int64)
    contacts_ground = np.where(beside[:, None], rng.integers(1, 3, (batch, n_agents)), 0).astype(np.int64)
    contacts_agents = (rng.integers(0, 3, (batch, n_agents)) if n_agents > 1
                       else np.zeros((batch, 1))).astype(np.int64)
    tilt = np.where(scattered, rng.uniform(1.0, 1.6, batch), rng.uniform(0.0, 0.1, batch))
    speed = np.where(scattered, 0.5, 0.01)[:, None, None]
    # the enclosure probe: walled all round inside, open on every side beside the object or scattered
    open_sector = np.where((beside | scattered)[:, None], PROBE_DIRECTIONS,
                           np.where(on_top[:, None], rng.integers(0, PROBE_DIRECTIONS + 1, (batch, n_agents)), 0))
    return Outcomes(
        pose_index=pose_index.astype(np.int64),
        plan_index=plan_index.astype(np.int64),
        agent_pos=pos,
        agent_quat=_tilt_quats(rng.uniform(0.0, 0.5, (batch, n_agents)) * (scenario != 1)[:, None], rng),
        agent_vel=rng.normal(0.0, 1.0, (batch, n_agents, 3)) * speed,
        contacts_object=contacts_object,
        contacts_agents=contacts_agents,
        contacts_ground=contacts_ground,
        released_early=rng.random((batch, n_agents)) < 0.2,
        object_pos=rng.normal(0.0, 0.005, (batch, 3)),
        object_quat=_tilt_quats(tilt, rng),
        object_tilt=tilt,
        object_half_extents=half.copy(),
        settled=~scattered,
        agent_open_sector=open_sector.astype(np.int64),
        unstable=np.zeros(batch, dtype=bool),  # world stays None: a nominal batch, as imagine() returns one
    )
