"""``python -m rail_mj.eval``: the paper's Table 1 and Table 2 on a labelled dataset.

Writes ``OUT/results.jsonl`` (one line per object × affordance, as it goes),
``OUT/summary.json`` and ``OUT/report.md`` (tables + a picture per
misclassified case). ``--resume`` skips finished lines; Ctrl-C leaves a valid
results file.

Rules (also printed in the report):

* classification is correct when ``functional`` equals the label; a case that
  failed (bad mesh, LLM stage out of retries) counts as wrong;
* a functional pose is correct when the predicted pose puts the labelled
  ``functional_up`` within 20° of world up; it is scored over the positive
  cases, and a positive case predicted non-functional has no pose (wrong);
* the dimensions-only baseline says "functional" when the Affordance
  Analyzer's dimension check passes (bounding box alone, no physics) and takes
  the most probable stable pose as its functional pose.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from rail_mj.dataset import DEFECTS, LabelRecord, generate, read_labels
from rail_mj.errors import ConfigError, RailError
from rail_mj.pipeline import ObjectInput, Pipeline, RunConfig
from rail_mj.results import AffordanceResult, PoseInfo

__all__ = ["POSE_TOLERANCE_DEG", "EvalConfig", "run_eval", "summarize", "main"]

POSE_TOLERANCE_DEG = 20.0
PER_OBJECT_STAGES = ("load", "stable_poses")
PAPER_AFFORDANCES = ("basket", "bathtub", "chair", "cup", "plate", "table", "vase", "bowl")


class EvalConfig(RunConfig):
    """A run of the evaluation: the pipeline settings plus what to evaluate."""

    dataset: str = "procedural"
    per_class: int = 3
    dataset_seed: int = 0
    affordances: list[str] | None = None
    classes: list[str] | None = None
    render: bool = True


def _mesh_up(record: LabelRecord) -> np.ndarray | None:
    """The labelled functional up vector in the loaded mesh frame (after the up-axis change)."""
    if record.functional_up is None:
        return None
    v = np.asarray(record.functional_up, dtype=float)
    if record.up == "y":  # the loader turns mesh +y into +z: (x, y, z) -> (x, -z, y)
        v = np.array([v[0], -v[2], v[1]])
    return v / np.linalg.norm(v)


def _pose_correct(pose: PoseInfo | None, up: np.ndarray | None) -> bool:
    if pose is None or up is None:
        return False
    cos = float(np.clip(np.dot(pose.up_in_mesh_frame, up), -1.0, 1.0))
    return math.degrees(math.acos(cos)) <= POSE_TOLERANCE_DEG


def _line(record: LabelRecord, affordance: str, result: AffordanceResult) -> dict:
    label = bool(record.affordances[affordance])
    up = _mesh_up(record)
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
            "pose_correct": label and result.dims_fit and _pose_correct(base_pose, up),
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
    all_correct = [ln["correct"] for ln in lines]
    return {
        "n_cases": len(lines),
        "n_errors": sum(ln["error"] is not None for ln in lines),
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
    return (
        f"Table 1 — affordance classification accuracy (%), {summary['n_cases']} cases, "
        f"{summary['n_errors']} errors\n\n{t1}\n"
        f"Table 2 — functional pose accuracy (%) over {fp['n_positive']} positive cases "
        f"(correct when the labelled functional up is within {fp['tolerance_deg']:.0f}° of world up)\n\n{t2}"
    )


def _timing_table(summary: dict) -> str:
    rows = "".join(
        f"| {stage} | {t['total_s']:.1f} | {t['mean_s']:.3f} |\n" for stage, t in summary["timing"].items()
    )
    return "| stage | total s | mean s (per object for load and stable poses, else per case) |\n|---|---|---|\n" + rows


def _load_lines(path: Path) -> list[dict]:
    """Finished lines of a results file; a torn last line (killed mid-write) is dropped."""
    if not path.exists():
        return []
    lines = []
    for raw in path.read_text().splitlines():
        try:
            lines.append(json.loads(raw))
        except json.JSONDecodeError:
            continue
    return lines


def _dataset(cfg: EvalConfig, out: Path) -> tuple[Path, list[LabelRecord]]:
    if cfg.dataset == "procedural":
        root = out / "dataset"
        if not (root / "labels.jsonl").exists():
            generate(
                root,
                classes=cfg.classes,
                per_class=cfg.per_class,
                seed=cfg.dataset_seed,
                affordances=cfg.affordances or list(PAPER_AFFORDANCES),
            )
        return root, read_labels(root)
    root = Path(cfg.dataset)
    if not (root / "labels.jsonl").is_file():
        raise ConfigError(
            f"--dataset {root}: no labels.jsonl there; give a folder of meshes with a labels.jsonl "
            "(see `python -m rail_mj.dataset --help`) or 'procedural'"
        )
    return root, read_labels(root)


def run_eval(cfg: EvalConfig, out: Path, *, resume: bool = False, progress: bool = True) -> dict:
    """Run (or resume) an evaluation into ``out``; returns the summary."""
    out.mkdir(parents=True, exist_ok=True)
    results_path = out / "results.jsonl"
    if results_path.exists() and not resume:
        raise ConfigError(f"{results_path} exists: pass --resume to continue it, or choose another --out")
    root, records = _dataset(cfg, out)
    affordances = cfg.affordances or sorted({a for r in records for a in r.affordances})
    for r in records:
        missing = [a for a in affordances if a not in r.affordances]
        if missing:
            raise ConfigError(f"{r.mesh} has no label for {missing}; labelled: {sorted(r.affordances)}")
    finished = _load_lines(results_path)
    if finished:  # rewrite without a torn last line, so appending starts on a fresh line
        results_path.write_text("".join(json.dumps(ln) + "\n" for ln in finished))
    done = {ln["key"] for ln in finished}
    pending = [(r, [a for a in affordances if f"{r.mesh}::{a}" not in done]) for r in records]
    pending = [(r, affs) for r, affs in pending if affs]
    total = sum(len(affs) for _, affs in pending)

    pipe = Pipeline(RunConfig(**cfg.model_dump(include=set(RunConfig.model_fields))))
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=total, unit="case", desc="eval", dynamic_ncols=True)
    t0 = time.perf_counter()
    interrupted = False
    try:
        with results_path.open("a") as fh:
            for record, affs in pending:
                item = ObjectInput(path=root / record.mesh, units=record.units, up=record.up, name=record.mesh)
                for a, result in zip(affs, pipe.classify_object(item, affs)):
                    fh.write(json.dumps(_line(record, a, result)) + "\n")
                    fh.flush()
                    if bar is not None:
                        bar.update(1)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if bar is not None:
            bar.close()
    lines = _load_lines(results_path)
    summary = summarize(lines, config={**cfg.model_dump(mode="json"), "backend_used": pipe.backend})
    summary["wall_s_this_run"] = time.perf_counter() - t0  # a wall time, not a stage: kept out of "timing"
    summary["complete"] = not interrupted and len(lines) >= len(records) * len(affordances)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    write_report(out, summary, lines, root, render=cfg.render and not interrupted)
    if interrupted:
        raise KeyboardInterrupt
    return summary


def write_report(out: Path, summary: dict, lines: Sequence[dict], root: Path, *, render: bool) -> None:
    """report.md: the tables, timings, the rules, and each misclassified case with a picture."""
    wrong = [ln for ln in lines if not ln["correct"]]
    parts = [
        "# rail_mj evaluation\n",
        _tables(summary),
        "\n## Timing\n\n" + _timing_table(summary),
        "\n## Rules\n\n" + (__doc__ or "").split("Rules (also printed in the report):")[1].strip() + "\n",
        f"\n## Misclassified cases ({len(wrong)})\n",
    ]
    if render and wrong:
        from rail_mj.render import render_result

        (out / "renders").mkdir(exist_ok=True)
    for ln in wrong:
        r = AffordanceResult.model_validate(ln["result"])
        verdict = "error" if ln["error"] else ("functional" if ln["predicted"] else "not functional")
        parts.append(
            f"\n### {ln['mesh']} — {ln['affordance']}: predicted {verdict}, label "
            f"{'functional' if ln['label'] else 'not functional'}\n\n"
            + (f"Error: {ln['error']}\n" if ln["error"] else "Reasons: " + "; ".join(r.analyzer_reasons) + "\n")
        )
        if render and not ln["error"] and r.evidence_pose is not None:
            png = out / "renders" / (ln["key"].replace("/", "_").replace("::", "__") + ".png")
            try:
                render_result(root / ln["mesh"], r, png, units=1.0)
                parts.append(f"\n![{ln['key']}](renders/{png.name})\n")
            except RailError as exc:
                parts.append(f"\n(render failed: {exc})\n")
    (out / "report.md").write_text("".join(parts))


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m rail_mj.eval", description=__doc__.split("\n\n")[0])
    p.add_argument("--dataset", default="procedural", help="'procedural' or a folder with labels.jsonl")
    p.add_argument("--per-class", type=int, default=3, help="objects per class (procedural)")
    p.add_argument("--seed", type=int, default=0, help="dataset seed (procedural)")
    p.add_argument("--classes", help="comma-separated classes (procedural), default all")
    p.add_argument("--affordances", help="comma-separated requested affordances, default all labelled")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run in --out")
    p.add_argument("--provider", default="auto", help="auto | offline | anthropic")
    p.add_argument("--backend", default="auto", help="auto | native | mjx")
    p.add_argument("--drops", type=int, default=64, help="drops for stable-pose imagination")
    p.add_argument("--no-render", action="store_true", help="skip the pictures in report.md")
    p.add_argument("--no-progress", action="store_true")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    split = lambda s: [x.strip() for x in s.split(",") if x.strip()] if s else None  # noqa: E731
    try:
        cfg = EvalConfig(
            dataset=args.dataset,
            per_class=args.per_class,
            dataset_seed=args.seed,
            classes=split(args.classes),
            affordances=split(args.affordances),
            provider=args.provider,
            backend=args.backend,
            n_drops=args.drops,
            render=not args.no_render,
        )
        summary = run_eval(cfg, args.out, resume=args.resume, progress=not args.no_progress)
    except KeyboardInterrupt:
        print(f"\ninterrupted: finished lines are in {args.out / 'results.jsonl'}; rerun with --resume", file=sys.stderr)
        return 130
    except RailError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(_tables(summary))
    print("\n" + _timing_table(summary))
    print(f"\nwrote {args.out / 'results.jsonl'}, {args.out / 'summary.json'}, {args.out / 'report.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
