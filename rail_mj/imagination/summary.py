"""What a batched imagination gives stage 7: each rollout's resultant configuration summarised, per pose × plan.

The summary's fractions are defined with :class:`rail_mj.core.profile.ResultSummary`
(:data:`~rail_mj.core.profile.BENEATH_MIDDLE`, :data:`~rail_mj.core.profile.OPEN_SECTOR`,
which the container kind's rules read too, both from that module when they run); rollouts are pose-major
(:func:`rail_mj.imagination.batch.rollout_index`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

import rail_mj.core.profile as profile
from rail_mj.core.profile import (
    CandidateInteraction,
    MotionPlan,
    PoseCandidates,
    ResultSummary,
    SegmentState,
)
from rail_mj.core.results import BasinInfo
from rail_mj.core.types import Outcomes, StablePose
from rail_mj.imagination.batch import rollout_index

__all__ = ["result_summary", "pose_candidates"]


def result_summary(outcomes: Outcomes, b: int) -> ResultSummary:
    """Summary of rollout ``b`` for the Functional Pose Analyzer."""
    h = outcomes.object_half_extents[b]
    pos = outcomes.agent_pos[b]
    q = outcomes.agent_quat[b]
    cos_tilt = np.clip(1.0 - 2.0 * (q[:, 1] ** 2 + q[:, 2] ** 2), -1.0, 1.0)
    rel = pos - outcomes.object_pos[b]  # the object may have slid under the agents' impacts
    beneath = (rel[:, 0] / h[0]) ** 2 + (rel[:, 1] / h[1]) ** 2 < profile.BENEATH_MIDDLE  # the container's leak test
    return ResultSummary(
        frac_inside_bbox=float(np.mean(np.all(np.abs(pos) < h, axis=1))),
        frac_on_ground=float(np.mean(outcomes.contacts_ground[b] > 0)),
        frac_touching_object=float(np.mean(outcomes.contacts_object[b] > 0)),
        mean_height=float(np.mean(pos[:, 2]) / h[2]),
        object_tilt_deg=float(np.degrees(outcomes.object_tilt[b])),
        agent_tilt_deg=float(np.mean(np.degrees(np.arccos(cos_tilt)))),
        agent_speed=float(np.mean(np.linalg.norm(outcomes.agent_vel[b], axis=1))),
        frac_through_object=float(np.mean(beneath & (outcomes.contacts_ground[b] > 0))),
        frac_beneath_middle=float(np.mean(beneath)),
        frac_open_side=_frac_open_side(outcomes, b),
        segments=_segments(outcomes, b),
    )


def _segments(outcomes: Outcomes, b: int) -> list[SegmentState]:
    """The segments of rollout ``b``'s articulated agents; [] for one-body agents."""
    height, up, contacts = outcomes.segment_height, outcomes.segment_up, outcomes.segment_contacts
    names = outcomes.segment_names
    if height is None or up is None or contacts is None or names is None:
        return []
    reach = outcomes.segment_reach
    return [SegmentState(agent=i, name=name, height=float(height[b, i, k]),
                         up=float(np.clip(up[b, i, k], -1.0, 1.0)), touching_object=bool(contacts[b, i, k, 0] > 0),
                         on_ground=bool(contacts[b, i, k, 2] > 0),
                         reaches_object=reach is not None and bool(reach[b, i, k]))
            for i in range(height.shape[1]) for k, name in enumerate(names)]


def _frac_open_side(outcomes: Outcomes, b: int) -> float:
    """Of the agents inside the box, the fraction whose enclosure probe found an open sector; 0 without a probe."""
    if outcomes.agent_open_sector is None:
        return 0.0
    inside = np.all(np.abs(outcomes.agent_pos[b]) < outcomes.object_half_extents[b], axis=1)
    if not inside.any():
        return 0.0
    return float(np.mean(outcomes.agent_open_sector[b][inside] >= profile.OPEN_SECTOR))


def pose_candidates(
    plans: Sequence[MotionPlan],
    poses: Sequence[StablePose],
    kept: Sequence[int],
    outcomes: Outcomes,
    scores: np.ndarray,
    trajectories: Sequence[Sequence[np.ndarray]],
) -> list[PoseCandidates]:
    """The poses of one batched imagination with a candidate (a plan scored above 0), what stage 7 judges.

    ``kept`` are the indices into ``poses`` that were imagined, in batch order (rollout
    ``rollout_index(k, j, n_plans)`` is pose ``kept[k]``, plan ``j``); ``scores`` (B,) and ``trajectories``
    (per kept pose, per plan, (K, 7)) come from the same batch. A pose is put to the analyser
    only with a candidate; its failed plans go along as evidence.
    """
    n_plans = len(plans)
    out = []
    for k, i in enumerate(kept):
        if not np.any(scores[rollout_index(k, 0, n_plans) : rollout_index(k + 1, 0, n_plans)] > 0):
            continue
        tried = [
            CandidateInteraction(
                plan=plan.name,
                description=plan.description,
                via_poses=trajectories[k][j][:, :3].tolist(),
                score=float(scores[rollout_index(k, j, n_plans)]),
                summary=result_summary(outcomes, rollout_index(k, j, n_plans)),
            )
            for j, plan in enumerate(plans)
        ]
        out.append(
            PoseCandidates(
                pose_index=i,
                probability=float(poses[i].probability),
                half_extents=[float(v) for v in poses[i].half_extents],
                basin=BasinInfo.of(poses[i].basin),
                toe_room=poses[i].toe_room,
                candidates=[c for c in tried if c.score > 0],
                failed=[c for c in tried if c.score <= 0],
            )
        )
    return out
