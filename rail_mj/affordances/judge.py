"""The Functional Pose Analyzer's rules: the one judge of what an imagined rollout shows, whichever provider runs.

Stage 7 asks whether a pose's success is consistent with common sense. These rules answer it for every
affordance: a registered row by its kind's rules (:meth:`Kind.judge` on each candidate, then
:meth:`Kind.accept_pose` on the pose's candidates together), a name outside the registry by the generic rules
(:func:`rail_mj.affordances.kinds.judge_unregistered`). The pipeline counts a pose's successes over its imagined
worlds with :func:`judge_pose` (:mod:`rail_mj.pipeline.verdicts`); the offline provider answers stage 7 with
:func:`functional_poses`; a model's stage-7 answer meets these rules in :func:`rail_mj.pipeline.verdicts.judge`.
"""

from __future__ import annotations

from collections.abc import Sequence

from rail_mj.affordances.kinds import judge_unregistered, kind_of
from rail_mj.affordances.names import get
from rail_mj.affordances.row import Affordance
from rail_mj.core.errors import UnknownAffordanceError
from rail_mj.core.profile import CandidateInteraction, FunctionalPoseVerdict, PoseCandidates, PoseVerdict

__all__ = ["rules_row", "world_row", "judge_pose", "functional_poses"]


def rules_row(affordance: str, scale: float = 1.0) -> Affordance | None:
    """The registry row whose kind's rules judge ``affordance`` at the agent ``scale``; None outside the registry
    (the generic rules judge it)."""
    try:
        return get(affordance).scaled(scale)
    except UnknownAffordanceError:
        return None


def world_row(affordance: str, scale: float, agent_size: float) -> Affordance | None:
    """The row a world whose agent is ``agent_size`` times the nominal size is judged by: scaled for that agent
    where the kind's rules read the agent's size (a body's reach: a doll's chair is judged for a doll), else
    :func:`rules_row` at ``scale``."""
    aff = rules_row(affordance, scale)
    if aff is None or agent_size == 1.0 or not kind_of(aff).rules_read_agent_size:
        return aff
    return rules_row(affordance, scale * agent_size)


def judge_pose(aff: Affordance | None, pose: PoseCandidates) -> tuple[list[CandidateInteraction], list[str]]:
    """The rules on one pose: its candidates that its kind's rules accept (each, then the pose's together), and the
    reasons; ``aff`` None: the generic rules of an affordance outside the registry."""
    kind = kind_of(aff) if aff is not None else None
    accepted: list[CandidateInteraction] = []
    reasons: list[str] = []
    h = list(pose.half_extents)
    for c in pose.candidates:
        ok, why = (kind.judge(aff, c, h, None if pose.basin is None else pose.basin.rim)
                   if kind is not None and aff is not None
                   else judge_unregistered(c))
        reasons.append(f"{c.plan}: {why}")
        if ok:
            accepted.append(c)
    if not pose.candidates:
        reasons.append("no plan succeeded")
    if kind is not None and aff is not None and accepted:
        accepted, why_not = kind.accept_pose(aff, accepted, pose)
        if why_not:
            reasons.append(why_not)
    return accepted, reasons


def functional_poses(affordance: str, scale: float, poses: Sequence[PoseCandidates]) -> FunctionalPoseVerdict:
    """Stage 7 by the rules: accept a pose when its kind's rules accept one of its candidates; the best pose is the
    one the kind ranks first, then the one accepted with the most plans, the one the kind's tie rank puts first,
    the top score, the most probable.

    Affordances outside the registry get the generic rules (object not tipped, agents not mostly on the ground
    away from it).
    """
    aff = rules_row(affordance, scale)
    kind = kind_of(aff) if aff is not None else None
    verdicts: list[PoseVerdict] = []
    # best = ((kind's rank, accepted plans, kind's tie rank, top score, probability), pose, plan): the pose that works
    # from the most approaches, after what the kind ranks first (for dishes: a rim rises around the food)
    best: tuple[tuple[int, int, int, float, float], int, str] | None = None
    for pose in poses:
        h = list(pose.half_extents)
        accepted, reasons = judge_pose(aff, pose)
        top = max(accepted, key=lambda c: c.score) if accepted else None
        verdicts.append(PoseVerdict(pose_index=pose.pose_index, accept=top is not None, reason="; ".join(reasons),
                                    plan=top.plan if top else None))
        rank, tie = ((kind.rank(aff, accepted, h), kind.tie_rank(aff, accepted, h)) if kind is not None
                     and aff is not None else (0, 0))
        key = (rank, len(accepted), tie, top.score if top else 0.0, pose.probability)
        if top is not None and (best is None or key > best[0]):
            best = (key, pose.pose_index, top.plan)
    if best is None:
        return FunctionalPoseVerdict(poses=verdicts, best_pose=None, best_plan=None,
                                     reason="no candidate interaction is consistent with common sense")
    (_, n_plans, _, score, _), index, plan = best
    return FunctionalPoseVerdict(poses=verdicts, best_pose=index, best_plan=plan,
                                 reason=f"pose {index} works with the most plans ({n_plans}); plan {plan!r} "
                                        f"has its best accepted score ({score:.3f})")
