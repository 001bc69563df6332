"""Scoring the cases of an evaluation and summarising them: accuracy, the baseline, the paper's tables.

:func:`_line` scores one case into its ``results.jsonl`` line (the method's verdict and pose, and the
dimensions-only baseline's), :func:`summarize` turns lines into ``summary.json``, and the tables print it.
The rules are :data:`RULES`, which the report prints.
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from collections.abc import Sequence

import numpy as np

from rail_mj.core.results import AffordanceResult, PoseInfo
from rail_mj.dataset.ground_truth import DEFECTS
from rail_mj.dataset.labels import LabelRecord
from rail_mj.eval.calibration import calibration

__all__ = [
    "POSE_TOLERANCE_DEG",
    "PER_OBJECT_STAGES",
    "RULES",
    "summarize",
]

POSE_TOLERANCE_DEG = 20.0
PER_OBJECT_STAGES = ("load", "stable_poses")
#: How a case is scored (printed in the report).
RULES = """
* classification is correct when ``functional`` equals the label; a case that
  failed (bad mesh, LLM stage out of retries) counts as wrong;
* a functional pose is correct when the predicted pose puts the labelled
  ``functional_up`` (or one of its ``equivalent_ups``: an object that is
  itself upside down) within 20° of world up; it is scored over the positive
  cases, and a positive case predicted non-functional has no pose (wrong);
* the dimensions-only baseline says "functional" when the Affordance
  Analyzer's dimension check passes (bounding box alone, no physics) and takes
  the most probable stable pose as its functional pose.
"""


def _mesh_ups(record: LabelRecord) -> np.ndarray | None:
    """The labelled functional up vector, then its equivalents, in the loaded mesh frame (after the up-axis
    change), (K, 3)."""
    if record.functional_up is None:
        return None
    v = np.asarray([record.functional_up, *(record.equivalent_ups or [])], dtype=float)
    if record.up == "y":  # the loader turns mesh +y into +z: (x, y, z) -> (x, -z, y)
        v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1)
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _pose_correct(pose: PoseInfo | None, ups: np.ndarray | None) -> bool:
    if pose is None or ups is None:
        return False
    cos = float(np.clip(np.max(ups @ np.asarray(pose.up_in_mesh_frame)), -1.0, 1.0))
    return math.degrees(math.acos(cos)) <= POSE_TOLERANCE_DEG


def _line(record: LabelRecord, affordance: str, result: AffordanceResult) -> dict:
    label = bool(record.affordances[affordance])
    up = _mesh_ups(record)
    failed = result.error is not None
    base_pose = result.stable_poses[0] if result.stable_poses else None
    return {
        "key": f"{record.mesh}::{affordance}",
        "mesh": record.mesh,
        "class": record.class_name,
        "defect": record.class_name in DEFECTS,
        "affordance": affordance,
        "label": label,
        "predicted": None if failed else result.functional,
        "correct": (not failed) and result.functional == label,
        "pose_correct": label and result.functional and _pose_correct(result.functional_pose, up),
        "pose_correct_without_analyzer": label and _pose_correct(result.pose_without_analyzer, up),
        "baseline_dims": {
            "predicted": None if failed else result.dims_fit,
            "correct": (not failed) and result.dims_fit == label,
            "pose_correct": label and result.dims_fit is True and _pose_correct(base_pose, up),
        },
        "error": result.error,
        "result": result.model_dump(mode="json"),
    }


def _rate(values: Sequence[bool]) -> float | None:
    return float(np.mean(values)) if values else None


def summarize(lines: Sequence[dict], config: dict | None = None) -> dict:
    """The summary.json content from results lines."""
    per_aff: dict[str, list[bool]] = defaultdict(list)
    base_aff: dict[str, list[bool]] = defaultdict(list)
    pose, pose_wo, pose_base = [], [], []
    defects: dict[str, list[bool]] = defaultdict(list)
    timing: dict[str, list[float]] = defaultdict(list)
    llm_calls: Counter[str] = Counter()
    llm_repairs: Counter[str] = Counter()
    seen: set[tuple[str, str]] = set()
    for ln in lines:
        a = ln["affordance"]
        per_aff[a].append(ln["correct"])
        base_aff[a].append(ln["baseline_dims"]["correct"])
        if ln["label"]:
            pose.append(ln["pose_correct"])
            pose_wo.append(ln["pose_correct_without_analyzer"])
            pose_base.append(ln["baseline_dims"]["pose_correct"])
        if ln["defect"]:
            defects[ln["class"]].append(ln["predicted"] is False)
        for stage, s in ln["result"].get("timings", {}).items():
            if stage in PER_OBJECT_STAGES and (stage, ln["mesh"]) in seen:
                continue  # every case of an object repeats its load and stable-pose times
            seen.add((stage, ln["mesh"]))
            timing[stage].append(s)
        llm_calls.update(ln["result"].get("llm_calls", {}))
        llm_repairs.update(ln["result"].get("llm_repairs", {}))
    all_correct = [ln["correct"] for ln in lines]
    return {
        "n_cases": len(lines),
        "n_errors": sum(ln["error"] is not None for ln in lines),
        "errors": {ln["key"]: ln["error"] for ln in lines if ln["error"] is not None},
        "classification": {
            "overall": _rate(all_correct),
            "per_affordance": {a: _rate(v) for a, v in sorted(per_aff.items())},
        },
        "functional_pose": {
            "overall": _rate(pose),
            "without_analyzer": _rate(pose_wo),
            "n_positive": len(pose),
            "tolerance_deg": POSE_TOLERANCE_DEG,
        },
        "baseline_dims": {
            "classification": {
                "overall": _rate([ln["baseline_dims"]["correct"] for ln in lines]),
                "per_affordance": {a: _rate(v) for a, v in sorted(base_aff.items())},
            },
            "functional_pose": {"overall": _rate(pose_base)},
        },
        "defects": {
            "all_non_functional": all(all(v) for v in defects.values()) if defects else None,
            "per_class": {c: _rate(v) for c, v in sorted(defects.items())},
        },
        "calibration": calibration(lines),
        # requests sent to the model per stage over the run's cases, and the repair rounds among them (repairs
        # counted apart); {} with the offline library
        "llm_calls": dict(sorted(llm_calls.items())),
        "llm_repairs": dict(sorted(llm_repairs.items())),
        "timing": {
            stage: {"total_s": float(np.sum(v)), "mean_s": float(np.mean(v))} for stage, v in sorted(timing.items())
        },
        "config": config or {},
    }


def _pct(v: float | None) -> str:
    return "–" if v is None else f"{100 * v:.1f}"


def _tables(summary: dict) -> str:
    affs = list(summary["classification"]["per_affordance"])
    head = "| method | " + " | ".join(affs) + " | overall |\n|---|" + "---|" * (len(affs) + 1) + "\n"
    ours = summary["classification"]
    base = summary["baseline_dims"]["classification"]
    t1 = head + "".join(
        f"| {name} | " + " | ".join(_pct(c["per_affordance"][a]) for a in affs) + f" | {_pct(c['overall'])} |\n"
        for name, c in (("rail_mj (imagination)", ours), ("dimensions only", base))
    )
    fp = summary["functional_pose"]
    t2 = (
        "| method | functional pose accuracy |\n|---|---|\n"
        f"| rail_mj, with Functional Pose Analyzer | {_pct(fp['overall'])} |\n"
        f"| rail_mj, without analyzer (best score) | {_pct(fp['without_analyzer'])} |\n"
        f"| dimensions only (most probable pose) | {_pct(summary['baseline_dims']['functional_pose']['overall'])} |\n"
    )
    cal = summary.get("calibration") or {}
    score = "–" if cal.get("brier") is None else f"{cal['brier']:.4f}"
    return (
        f"Table 1 — affordance classification accuracy (%), {summary['n_cases']} cases, "
        f"{summary['n_errors']} errors\n\n{t1}\n"
        f"Table 2 — functional pose accuracy (%) over {fp['n_positive']} positive cases "
        f"(correct when the labelled functional up is within {fp['tolerance_deg']:.0f}° of world up)\n\n{t2}\n"
        f"Calibration — Brier score of `probability` against the labels: {score} over {cal.get('n', 0)} cases "
        "(0 is perfect, always 0.5 scores 0.25)\n"
    )


def _timing_table(summary: dict) -> str:
    rows = "".join(
        f"| {stage} | {t['total_s']:.1f} | {t['mean_s']:.3f} |\n" for stage, t in summary["timing"].items()
    )
    return "| stage | total s | mean s (per object for load and stable poses, else per case) |\n|---|---|---|\n" + rows
