"""Small hand-made rollout arrays for the pure verdict and evidence functions: one agent resting on an upright
0.1 m box, two plans, an affordance outside the registry (judged by the generic rules, no size prior)."""

import numpy as np

from rail_mj.core.profile import MotionPlan
from rail_mj.core.types import Outcomes, StablePose
from rail_mj.imagination import Perturbation, PerturbationSet
from rail_mj.imagination.worlds import ImaginedWorlds

H = np.array([0.05, 0.05, 0.05])
PLANS = [MotionPlan(name=f"plan{j}", description="drop") for j in range(2)]


def pose_of(probability: float = 0.5) -> StablePose:
    return StablePose(pos=np.zeros(3), quat=np.array([1.0, 0, 0, 0]), probability=probability, half_extents=H)


def outcomes_of(n_poses: int, tilt_deg: float = 0.0, on_ground: int = 0) -> Outcomes:
    """``n_poses`` × 2 plans of one agent resting on top of the object, the object tipped ``tilt_deg``."""
    b = n_poses * len(PLANS)
    return Outcomes(
        pose_index=np.repeat(np.arange(n_poses), len(PLANS)), plan_index=np.tile(np.arange(len(PLANS)), n_poses),
        agent_pos=np.tile([[[0.0, 0.0, 0.06]]], (b, 1, 1)), agent_quat=np.tile([[[1.0, 0, 0, 0]]], (b, 1, 1)),
        agent_vel=np.zeros((b, 1, 3)), contacts_object=np.ones((b, 1), dtype=np.int64),
        contacts_agents=np.zeros((b, 1), dtype=np.int64), contacts_ground=np.full((b, 1), on_ground, dtype=np.int64),
        released_early=np.zeros((b, 1), dtype=bool), object_pos=np.zeros((b, 3)),
        object_quat=np.tile([1.0, 0, 0, 0], (b, 1)), object_tilt=np.full(b, np.radians(tilt_deg)),
        object_half_extents=np.tile(H, (b, 1)), settled=np.ones(b, dtype=bool))


def world_major(n_worlds: int) -> Outcomes:
    """``n_worlds`` rollouts of one (pose, plan): what a perturbed call of one pair returns."""
    out = outcomes_of(1)
    return Outcomes(**{k: v[:1].repeat(n_worlds, axis=0) if isinstance(v, np.ndarray) else v
                       for k, v in vars(out).items()})


def evidence_of(n_poses: int, kept: list[int] | None = None, worlds: int = 1) -> ImaginedWorlds:
    """Evidence for ``n_poses`` stable poses of which ``kept`` (default all) are imagined, in ``worlds`` worlds."""
    kept = list(range(n_poses)) if kept is None else kept
    traj = [np.array([[0.0, 0.0, 0.2, 1, 0, 0, 0]])] * len(PLANS)
    return ImaginedWorlds("frobnicate", 1.0, PLANS, [pose_of() for _ in range(n_poses)], kept,
                          [list(traj) for _ in kept], PerturbationSet((Perturbation(),) * worlds))
