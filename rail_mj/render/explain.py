"""Why a result came out as it did: every stable pose, each plan's score in it, the rules that fired, the verdict.

Built from an :class:`~rail_mj.core.results.AffordanceResult` alone (its stable poses, score grid and analyser
reasons) plus the registry row's pose envelope, so any stored result (an eval's ``results.jsonl`` line too)
can be explained after the fact. ``python -m rail_mj MESH -a NAME --explain`` prints :func:`format_explanation`;
with ``--json`` the result line carries :func:`explain` under ``"explain"``.
"""

from __future__ import annotations

import re

from pydantic import BaseModel, Field

from rail_mj.affordances.envelope import VESSEL_BASE
from rail_mj.affordances.names import get
from rail_mj.core.errors import UnknownAffordanceError
from rail_mj.core.results import AffordanceResult, BasinInfo, PoseProbability

__all__ = ["PoseExplanation", "Explanation", "explain", "format_explanation", "up_axis"]

_POSE_REASON = re.compile(r"^pose (\d+): (.*)$", re.DOTALL)
#: An up vector within this many degrees' cosine of a mesh axis is named after it.
_AXIS_COS = 0.985


class PoseExplanation(BaseModel):
    """One stable pose and what happened in it."""

    index: int
    probability: float
    up: str = Field(description="the mesh axis that points up in this pose (+z, -y, ...), or the vector")
    up_in_mesh_frame: list[float]
    box_size_m: list[float] = Field(description="full extents of the pose's box, x y z (z up), m")
    envelope: str = Field(description="the pose's envelope prior: each box size, its typical range and width, "
                                      "its plausibility, and their product")
    basin: str = Field(default="", description="seen from above, where poured water stands: its spill level and "
                                               "length, 'none' without a basin")
    toe_room: str = Field(default="", description="how wide a foot gets under the object's middle at toe height "
                                                  "from beside it, '' where not mapped")
    scores: dict[str, float] = Field(description="plan -> score (> 0 succeeded; -1 also when not imagined)")
    analyzer: str = Field(description="the Functional Pose Analyzer's reasons for this pose, '' when none")
    functional: bool = Field(description="whether this is the functional pose")
    factors: str = Field(default="", description="prior x physics = probability in words, '' when not imagined")
    blew_up: list[str] = Field(default_factory=list, description="rollouts of this pose that blew up (failures)")


class Explanation(BaseModel):
    """Why one (object, affordance) got its verdict."""

    object: str
    requested: str
    affordance: str
    verdict: str
    dims_fit: bool | None
    probability: float = Field(default=0.0, description="the result's probability: its most probable pose's")
    pose_probability: float | None = Field(default=None, description="the functional pose's probability, None "
                                                                     "without one")
    prior: str = Field(default="", description="the factors of the functional (or most probable accepted) "
                                               "pose's prior, in words")
    functional_pose: int | None
    best_plan: str | None
    poses: list[PoseExplanation]
    reasons: list[str] = Field(description="the analyser's reasons that belong to no single pose (the verdict's)")
    profile_notes: list[str] = Field(default_factory=list, description="what the import of a profile folder "
                                                                       "adapted to run it")
    error: str | None = None


def up_axis(up: list[float]) -> str:
    """The name of the mesh axis a unit vector lies along (``+z``, ``-x``), else the vector rounded."""
    for i, axis in enumerate("xyz"):
        if abs(up[i]) >= _AXIS_COS:
            return f"{'+' if up[i] > 0 else '-'}{axis}"
    return "[" + ", ".join(f"{v:.2f}" for v in up) + "]"


def _envelope(affordance: str, half: list[float], basin: BasinInfo | None) -> str:
    try:
        aff = get(affordance)
    except UnknownAffordanceError:
        return "no registered envelope"
    # a vessel's aspect at its rim, without its stem
    return aff.pose_prior(half, None if basin is None else basin.rim, None if basin is None else basin.floor).doc()


def _factors(v: PoseProbability) -> str:
    """``prior 0.72 (height ...) x physics 0.80 (plan 'above' in 4 of 5 worlds) = 0.58``."""
    if v.best_plan:
        plan = f"plan {v.best_plan!r} in {v.successes} of {v.worlds} worlds"
    elif v.imagined < v.worlds:
        plan = "no plan succeeded in the nominal world, so the perturbed ones were not imagined"
    else:
        plan = f"no plan succeeded in any of {v.worlds} worlds"
    return (f"prior {v.prior:.2f} ({v.prior_factors}) x physics {v.physics:.2f} ({plan}) = {v.probability:.2f}")


def explain(r: AffordanceResult) -> Explanation:
    """The structured explanation of one result."""
    per_pose: dict[int, list[str]] = {}
    general: list[str] = []
    for reason in r.analyzer_reasons:
        m = _POSE_REASON.match(reason)
        if m:
            per_pose.setdefault(int(m.group(1)), []).append(m.group(2))
        else:
            general.append(reason)
    best = r.functional_pose.index if r.functional_pose is not None else None
    verdicts = {v.index: v for v in r.pose_verdicts}
    poses = []
    for p in r.stable_poses:
        row = r.scores[p.index] if p.index < len(r.scores) else []
        poses.append(PoseExplanation(
            index=p.index, probability=p.probability, up=up_axis(p.up_in_mesh_frame),
            up_in_mesh_frame=[round(v, 4) for v in p.up_in_mesh_frame],
            box_size_m=[round(2.0 * v, 4) for v in p.half_extents],
            envelope=_envelope(r.affordance, p.half_extents, p.basin),
            basin="none" if p.basin is None else (f"water stands up to {p.basin.rim:.3f} m, {p.basin.length:.2f} m long"
                                                  + (f", over a floor {p.basin.floor:.3f} m up" if p.basin.floor
                                                     > VESSEL_BASE else "")),
            toe_room="" if p.toe_room is None else f"a foot up to {p.toe_room:.3f} m broad gets under the middle",
            scores={name: round(s, 4) for name, s in zip(r.plans, row, strict=False)},
            analyzer="; ".join(per_pose.get(p.index, [])), functional=p.index == best,
            factors=_factors(verdicts[p.index]) if p.index in verdicts else "",
            blew_up=verdicts[p.index].blew_up if p.index in verdicts else [],
        ))
    if r.error:
        verdict = "failed"
    elif r.functional:
        verdict = "functional"
    else:
        verdict = "not functional"
    return Explanation(object=r.object, requested=r.requested, affordance=r.affordance, verdict=verdict,
                       dims_fit=r.dims_fit, probability=r.probability, prior=r.prior, functional_pose=best,
                       pose_probability=verdicts[best].probability if best in verdicts else None,
                       best_plan=r.best_plan.name if r.best_plan is not None else None,
                       poses=poses, reasons=general, error=r.error, profile_notes=list(r.profile_notes))


def format_explanation(e: Explanation) -> str:
    """The explanation as text for people: one block per stable pose, then the verdict."""
    lines = [f"{e.object}: {e.requested!r} (imagined as {e.affordance!r})"]
    if e.dims_fit is False:
        lines.append("  dimension check: unusual sizes for the use" + ("" if e.poses and any(p.scores for p in e.poses)
                                                                         else ", nothing was imagined"))
    if e.prior:
        lines.append(f"  prior: {e.prior}")
    for note in e.profile_notes:
        lines.append(f"  profile folder adapted: {note}")
    for p in e.poses:
        mark = "  <- functional pose" if p.functional else ""
        size = " x ".join(f"{v:.3f}" for v in p.box_size_m)
        lines.append(f"  pose {p.index}: p={p.probability:.2f}, up {p.up}, box {size} m{mark}")
        lines.append(f"    envelope prior: {p.envelope}")
        if p.basin:
            lines.append(f"    basin: {p.basin}")
        if p.toe_room:
            lines.append(f"    toe room: {p.toe_room}")
        if p.scores:
            lines.append("    scores: " + ", ".join(f"{k} {v:+.2f}" for k, v in p.scores.items()))
        if p.analyzer:
            lines.append(f"    analyser: {p.analyzer}")
        if p.factors:
            lines.append(f"    probability: {p.factors}")
        for b in p.blew_up:
            lines.append(f"    blew up (a failure): {b}")
    for reason in e.reasons:
        lines.append(f"  rule: {reason}")
    tail = f" in pose {e.functional_pose} with plan {e.best_plan!r}" if e.functional_pose is not None else ""
    error = f" ({e.error})" if e.error else ""
    tied = ""
    if e.pose_probability is not None and e.pose_probability < e.probability:
        tied = (f" (pose {e.functional_pose}: {e.pose_probability:.2f}, within one world of the most probable pose: "
                "a tie, which stage 7's pick wins)")
    lines.append(f"  verdict: {e.verdict}{tail}, probability {e.probability:.2f}{tied}{error}")
    return "\n".join(lines)
