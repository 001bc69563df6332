"""``python -m rail_mj.eval``: the paper's Table 1 and Table 2 on a labelled dataset.

Writes ``OUT/results.jsonl`` (one line per object × affordance, keyed
``mesh::affordance``, appended and fsynced as each case finishes),
``OUT/summary.json`` and ``OUT/report.md`` (tables + a picture per
misclassified case). A kill at any moment, SIGKILL included, loses at most the
case in progress:

* one run per ``OUT``: a second one fails at once, naming the holder
  (:func:`rail_mj.core.runfiles.folder_lock`; the kernel frees the lock of a killed run);
* the procedural dataset appears in ``OUT/dataset`` only when whole, and one that
  does not match the command (an older run killed while writing it) is rebuilt;
* ``--resume`` drops torn and repeated lines by writing a new file and
  ``os.replace``-ing the old one, then appends; lines of cases this run does not
  ask for (another ``--affordances``) stay in the file and out of the summary;
* ``summary.json`` is computed over one line per expected case, and ``complete``
  is true when the file holds every expected case exactly once.

Objects are spread over ``--workers`` processes (default: every core), or run as
Ray tasks with ``--ray [ADDRESS]`` (see :mod:`rail_mj.pipeline.parallel`; the caches are
keyed by content, so shared storage in ``RAIL_MJ_CACHE`` serves a cluster). This
process stays the only writer of ``results.jsonl``. Each case's result is the same
however the objects were spread. ``--shard i/n`` evaluates every n-th object
starting with the i-th. ``python -m rail_mj.eval merge OUT... --out OUT`` joins
the shards' folders into the files that one serial run would have written (the
timings apart). Each run writes ``OUT/plan.json`` (its settings and cases) first.

Rules (also printed in the report):

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

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections import Counter, defaultdict
from collections.abc import Sequence
from contextlib import ExitStack, closing
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, ValidationError

from rail_mj.affordances import PAPER_AFFORDANCES
from rail_mj.core.cli import EXIT_FAILED, EXIT_OK, report_error
from rail_mj.dataset.procedural import AFFORDANCES, DEFECTS, FAMILIES, LabelRecord, generate, normalize_affordance, read_labels
from rail_mj.core.errors import ConfigError, DatasetError, RailError
from rail_mj.pipeline.chain import Pipeline, object_task
from rail_mj.pipeline.config import ObjectInput, RunConfig, RunOptions
from rail_mj.pipeline.parallel import check_executor, cpu_count, plan_workers, run_tasks
from rail_mj.core.results import AffordanceResult, PoseInfo
from rail_mj.core.runfiles import atomic_write_text, folder_lock
from rail_mj.stable_poses import StablePoseConfig

__all__ = [
    "POSE_TOLERANCE_DEG", "PLAN_FILE", "EvalConfig", "run_eval", "merge_runs", "parse_shard", "summarize",
    "cases_without_timings", "main",
]

POSE_TOLERANCE_DEG = 20.0
#: a run's settings and cases, written before any case runs: what ``merge`` joins shards by
PLAN_FILE = "plan.json"
PER_OBJECT_STAGES = ("load", "stable_poses")


class EvalConfig(RunOptions):
    """A run of the evaluation: the pipeline settings plus what to evaluate."""

    n_drops: int = Field(64, ge=8, le=4096, description="drops for stable-pose imagination")
    seed: int = 0
    dataset: str = "procedural"
    per_class: int = Field(3, ge=1)
    dataset_seed: int = 0
    family: Literal["core", "world", "all"] = "core"  # procedural class family (rail_mj.dataset.procedural.FAMILIES)
    affordances: list[str] | None = None
    classes: list[str] | None = None
    render: bool = True


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


def _parse_line(raw: str) -> dict | None:
    """A finished results line, or None for a torn one (killed mid-write) or anything else."""
    try:
        line = json.loads(raw)
    except json.JSONDecodeError:
        return None
    return line if isinstance(line, dict) and isinstance(line.get("key"), str) else None


def _read_lines(path: Path) -> list[dict]:
    """Every finished line of a results file, in file order, repeats included."""
    if not path.exists():
        return []
    text = path.read_text(encoding="utf-8", errors="replace")
    return [ln for ln in map(_parse_line, text.split("\n")) if ln is not None]


def _tidy_results(path: Path) -> set[str]:
    """The keys of the finished lines; torn and repeated lines (the first of a key is kept) are
    dropped by writing a new file that replaces the old one in one step, so a kill during the
    rewrite leaves the old file whole. Appending then starts on a fresh line."""
    if not path.exists():
        return set()
    text = path.read_text(encoding="utf-8", errors="replace")
    kept: dict[str, str] = {}
    for raw in text.split("\n"):
        line = _parse_line(raw)
        if line is not None and line["key"] not in kept:
            kept[line["key"]] = raw
    clean = "".join(raw + "\n" for raw in kept.values())
    if clean != text:
        atomic_write_text(path, clean)
    return set(kept)


def _check_names(given: Sequence[str], valid: Sequence[str], option: str) -> None:
    unknown = [n for n in given if n not in valid]
    if unknown:
        raise ConfigError(f"{option}: unknown {', '.join(map(repr, unknown))}; valid: {', '.join(valid)}")


#: Written beside a generated procedural dataset: what made it, so a resumed run reuses it only when the
#: command and the generator code are the same (class counts alone missed another --seed).
DATASET_SPEC = "dataset_spec.json"


def _dataset_spec(cfg: EvalConfig, classes: Sequence[str], affordances: Sequence[str]) -> dict:
    import hashlib

    from rail_mj.dataset import procedural as dataset, shapes

    code = hashlib.sha256(Path(dataset.__file__).read_bytes() + Path(shapes.__file__).read_bytes()).hexdigest()
    return {"family": cfg.family, "classes": list(classes), "per_class": cfg.per_class, "seed": cfg.dataset_seed,
            "affordances": list(affordances), "generator_sha256": code}


def _stale_reason(root: Path, spec: dict) -> str | None:
    """Why ``root`` does not hold the procedural dataset ``spec`` describes; None when it does."""
    try:
        records = read_labels(root)
    except DatasetError as exc:
        return str(exc)
    try:
        made = json.loads((root / DATASET_SPEC).read_text())
    except (OSError, ValueError):
        return f"it has no readable {DATASET_SPEC} saying how it was made"
    changed = [k for k in spec if made.get(k) != spec[k]]
    if changed:
        return f"it was made with other settings or generator code ({', '.join(changed)})"
    want = Counter({c: spec["per_class"] for c in spec["classes"]})
    if Counter(r.class_name for r in records) != want:
        return f"it holds {len(records)} objects, the command asks for {sum(want.values())}"
    return None


def _dataset(cfg: EvalConfig, out: Path, affordances: list[str] | None) -> tuple[Path, list[LabelRecord]]:
    if cfg.dataset == "procedural":
        classes = list(dict.fromkeys(cfg.classes or FAMILIES[cfg.family]))
        names = affordances or list(PAPER_AFFORDANCES)
        _check_names(classes, FAMILIES[cfg.family], "--classes")
        _check_names(names, list(AFFORDANCES), "--affordances")
        root = out / "dataset"
        spec = _dataset_spec(cfg, classes, names)
        why = _stale_reason(root, spec)
        if why is not None:
            if root.exists():  # e.g. left by an older run killed while writing it
                print(f"rebuilding {root}: {why}", file=sys.stderr)
                (root / DATASET_SPEC).unlink(missing_ok=True)
            generate(root, classes=classes, per_class=cfg.per_class, seed=cfg.dataset_seed, affordances=names,
                     family=cfg.family)
            atomic_write_text(root / DATASET_SPEC, json.dumps(spec, indent=2))
        return root, read_labels(root)
    root = Path(cfg.dataset)
    if not (root / "labels.jsonl").is_file():
        raise ConfigError(
            f"--dataset {root}: no labels.jsonl there; give a folder of meshes with a labels.jsonl "
            "(see `python -m rail_mj.dataset --help`) or 'procedural'"
        )
    return root, read_labels(root)


def cases_without_timings(out: Path) -> dict[str, dict]:
    """Each case's line in ``out/results.jsonl`` by key, without its timings: the one part that differs
    between two runs of the same cases (serial, parallel, Ray, merged shards)."""
    cases = {}
    for raw in (Path(out) / "results.jsonl").read_text().splitlines():
        line = json.loads(raw)
        line["result"].pop("timings")
        cases[line["key"]] = line
    return cases


def parse_shard(text: str) -> tuple[int, int]:
    """``"i/n"`` → ``(i, n)``, with 1 <= i <= n."""
    i, slash, n = text.partition("/")
    if not (slash and i.strip().isdigit() and n.strip().isdigit() and 1 <= int(i) <= int(n)):
        raise ConfigError(f"--shard {text!r}: give i/n with 1 <= i <= n, e.g. 1/4 (the first of four parts)")
    return int(i), int(n)


def run_eval(
    cfg: EvalConfig,
    out: Path,
    *,
    resume: bool = False,
    progress: bool = True,
    workers: int | None = None,
    executor: str = "local",
    ray_address: str | None = None,
    shard: tuple[int, int] | None = None,
) -> dict:
    """Run (or resume) an evaluation into ``out``; returns the summary.

    ``workers``, ``executor`` and ``ray_address`` say where the objects run (:func:`rail_mj.pipeline.parallel.run_tasks`;
    ``workers=None``: every core). ``shard=(i, n)`` takes every n-th labelled object from the i-th (1-based).
    Raises :class:`~rail_mj.core.errors.FolderInUseError` when another live run holds ``out``.
    """
    check_executor(executor, ray_address, workers)  # before any work
    if shard is not None:
        parse_shard(f"{shard[0]}/{shard[1]}")
    with folder_lock(out, advice="wait for it to end, or choose another --out"):
        return _run_locked(cfg, out, resume=resume, progress=progress, workers=workers, executor=executor,
                           ray_address=ray_address, shard=shard)


def _run_locked(
    cfg: EvalConfig, out: Path, *, resume: bool, progress: bool, workers: int | None, executor: str,
    ray_address: str | None, shard: tuple[int, int] | None,
) -> dict:
    for stale in out.glob(".*.tmp"):  # a killed run's unfinished atomic writes; no other run is here
        stale.unlink()
    results_path = out / "results.jsonl"
    if results_path.exists() and not resume:
        raise ConfigError(f"{results_path} exists: pass --resume to continue it, or choose another --out")
    requested = list(dict.fromkeys(normalize_affordance(a) for a in cfg.affordances)) if cfg.affordances else None
    root, records = _dataset(cfg, out, requested)
    repeated = sorted(m for m, n in Counter(r.mesh for r in records).items() if n > 1)
    if repeated:  # one key per case: a mesh listed twice would be evaluated twice and never "complete"
        raise DatasetError(f"{root / 'labels.jsonl'} lists {', '.join(repeated)} more than once; give each mesh one line")
    affordances = requested or sorted({a for r in records for a in r.affordances})
    for r in records:
        missing = [a for a in affordances if a not in r.affordances]
        if missing:
            raise ConfigError(f"{r.mesh} has no label for {missing}; labelled: {sorted(r.affordances)}")
    all_keys = [f"{r.mesh}::{a}" for r in records for a in affordances]
    if shard is not None:
        records = records[shard[0] - 1 :: shard[1]]
    expected = [f"{r.mesh}::{a}" for r in records for a in affordances]
    done = _tidy_results(results_path)
    pending = [(r, [a for a in affordances if f"{r.mesh}::{a}" not in done]) for r in records]
    pending = [(r, affs) for r, affs in pending if affs]
    total = sum(len(affs) for _, affs in pending)

    run_cfg = RunConfig(**cfg.model_dump(include=set(RunOptions.model_fields)),
                        stable_poses=StablePoseConfig(n_drops=cfg.n_drops, seed=cfg.seed))
    pipe = Pipeline(run_cfg)
    config = {**cfg.model_dump(mode="json"), "backend_used": pipe.backend}
    plan = {"config": config, "shard": list(shard) if shard else None, "dataset_root": str(root.resolve()),
            "keys": all_keys, "expected": expected}
    atomic_write_text(out / PLAN_FILE, json.dumps(plan))
    # the workers get the provider and backend this process resolved, so a node without an API key fails
    # visibly instead of falling back to another provider
    task_cfg = run_cfg.model_copy(update={"provider": pipe.provider_name, "backend": pipe.backend})
    tasks = [
        object_task(i, ObjectInput(path=root / r.mesh, units=r.units, up=r.up, name=r.mesh), affs, task_cfg)
        for i, (r, affs) in enumerate(pending)
    ]
    if executor == "local":
        n_workers, threads = plan_workers(workers, len(tasks))
        execution = {"executor": "local", "workers": n_workers, "threads_per_worker": threads, "cores": cpu_count()}
    else:
        execution = {"executor": executor, "address": ray_address, "local_cpus": workers}
    execution["shard"] = f"{shard[0]}/{shard[1]}" if shard else None
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=total, unit="case", desc="eval", dynamic_ncols=True)
    t0 = time.perf_counter()
    interrupted = False
    try:
        with ExitStack() as stack:
            fh = stack.enter_context(results_path.open("a", encoding="utf-8"))
            stream = stack.enter_context(
                closing(run_tasks(tasks, workers=workers, executor=executor, ray_address=ray_address))
            )
            for task, results in stream:
                record = pending[task.index][0]
                for a, result in zip(task.affordances, results):
                    fh.write(json.dumps(_line(record, a, result)) + "\n")
                    fh.flush()
                    os.fsync(fh.fileno())  # a finished case survives a kill or a power cut
                    if bar is not None:
                        bar.update(1)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if bar is not None:
            bar.close()
    found = _read_lines(results_path)
    counts = Counter(ln["key"] for ln in found)
    first: dict[str, dict] = {}
    for ln in found:
        first.setdefault(ln["key"], ln)
    lines = [first[k] for k in expected if k in first]
    summary = summarize(lines, config=config)
    summary["n_expected"] = len(expected)
    summary["wall_s_this_run"] = time.perf_counter() - t0  # a wall time, not a stage: kept out of "timing"
    summary["complete"] = not interrupted and all(counts[k] == 1 for k in expected)
    summary["execution"] = execution
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2))
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
        from rail_mj.render.images import nothing_to_draw, render_result

        (out / "renders").mkdir(exist_ok=True)
        how = {r.mesh: r for r in read_labels(root)}  # each mesh is drawn read as it was classified
    for ln in wrong:
        r = AffordanceResult.model_validate(ln["result"])
        verdict = "error" if ln["error"] else ("functional" if ln["predicted"] else "not functional")
        parts.append(
            f"\n### {ln['mesh']} — {ln['affordance']}: predicted {verdict}, label "
            f"{'functional' if ln['label'] else 'not functional'}\n\n"
            + (f"Error: {ln['error']}\n" if ln["error"] else "Reasons: " + "; ".join(r.analyzer_reasons) + "\n")
        )
        if render and not ln["error"] and nothing_to_draw(r) is not None:
            parts.append(f"\n({nothing_to_draw(r)})\n")
        elif render and not ln["error"]:
            png = out / "renders" / (ln["key"].replace("/", "_").replace("::", "__") + ".png")
            try:
                label = how[ln["mesh"]]
                render_result(root / ln["mesh"], r, png, units=label.units, up=label.up)
                parts.append(f"\n![{ln['key']}](renders/{png.name})\n")
            except RailError as exc:
                parts.append(f"\n(render failed: {exc})\n")
    atomic_write_text(out / "report.md", "".join(parts))


def _read_plan(folder: Path) -> dict:
    path = folder / PLAN_FILE
    try:
        plan = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{folder} holds no readable {PLAN_FILE} ({exc}); give folders that "
                          "`python -m rail_mj.eval --out` wrote") from None
    if not isinstance(plan, dict) or not {"config", "shard", "keys", "expected", "dataset_root"} <= set(plan):
        raise ConfigError(f"{path} is not a run plan (it lacks config, shard, keys, expected or dataset_root); "
                          "give folders that `python -m rail_mj.eval --out` wrote")
    return plan


def merge_runs(inputs: Sequence[Path], out: Path, *, render: bool = True) -> dict:
    """Join runs of one evaluation (its ``--shard`` parts) into ``out`` and return the summary.

    ``out`` gets ``results.jsonl`` in the order of one serial run, ``summary.json``, ``report.md`` and a
    ``plan.json``. Every case except the timings is the same as in that serial run. ``complete`` is true
    when every shard is there and each holds each of its cases exactly once. The runs must have used the
    same settings and labels. Each input is locked while it is read, so a run still writing one is refused.
    """
    inputs = [Path(p) for p in inputs]
    out = Path(out)
    if not inputs:
        raise ConfigError("merge: give the output folders of the runs to join, e.g. merge runs/s1 runs/s2 "
                          "--out runs/all")
    repeated = sorted({str(p) for p in inputs if inputs.count(p) > 1})
    if repeated:
        raise ConfigError(f"merge: {', '.join(repeated)} given more than once; give each run once")
    if any(p.resolve() == out.resolve() for p in inputs):
        raise ConfigError(f"merge: --out {out} is also an input; write the merge to a folder of its own")
    plans = [_read_plan(p) for p in inputs]
    if (out / "results.jsonl").exists() and "merged_from" not in _read_plan(out):
        raise ConfigError(f"merge: {out} holds a run's results; merge into an empty folder or a previous merge's")
    ref, ref_plan = inputs[0], plans[0]
    for p, plan in zip(inputs[1:], plans[1:]):
        differ = sorted(k for k in ref_plan["config"].keys() | plan["config"].keys()
                        if ref_plan["config"].get(k) != plan["config"].get(k))
        if differ:
            raise ConfigError(f"merge: {p} was run with other settings than {ref} ({', '.join(differ)}); "
                              "merge the shards of one command")
        if plan["keys"] != ref_plan["keys"]:
            raise ConfigError(f"merge: {p} evaluates other cases than {ref} (other labels or --affordances); "
                              "merge the shards of one command")
    shards = [tuple(plan["shard"]) if plan["shard"] else (1, 1) for plan in plans]
    if len({n for _, n in shards}) > 1:
        raise ConfigError("merge: the runs split the labels differently ("
                          + ", ".join(f"{p}: {i}/{n}" for p, (i, n) in zip(inputs, shards)) + "); give shards of one n")
    dupes = sorted({f"{i}/{n}" for i, n in shards if shards.count((i, n)) > 1})
    if dupes:
        raise ConfigError(f"merge: shard {', '.join(dupes)} given more than once; give each shard's folder once")
    n = shards[0][1]
    missing = [f"{i}/{n}" for i in range(1, n + 1) if (i, n) not in shards]
    with ExitStack() as stack:
        stack.enter_context(folder_lock(out, advice="wait for it to end, or choose another --out"))
        for p in inputs:
            stack.enter_context(folder_lock(p, advice="wait for that run to end, then merge"))
        by_key: dict[str, dict] = {}
        whole = True
        for p, plan in zip(inputs, plans):
            found = _read_lines(p / "results.jsonl")
            counts = Counter(ln["key"] for ln in found)
            first: dict[str, dict] = {}
            for ln in found:
                first.setdefault(ln["key"], ln)
            by_key.update((k, first[k]) for k in plan["expected"] if k in first)
            whole = whole and all(counts[k] == 1 for k in plan["expected"])
        lines = [by_key[k] for k in ref_plan["keys"] if k in by_key]
        summary = summarize(lines, config=ref_plan["config"])
        summary["n_expected"] = len(ref_plan["keys"])
        summary["complete"] = whole and not missing and len(lines) == len(ref_plan["keys"])
        summary["merged_from"] = [str(p) for p in inputs]
        summary["missing_shards"] = missing
        atomic_write_text(out / "results.jsonl", "".join(json.dumps(ln) + "\n" for ln in lines))
        merged_plan = {**ref_plan, "shard": None, "expected": ref_plan["keys"], "merged_from": summary["merged_from"]}
        atomic_write_text(out / PLAN_FILE, json.dumps(merged_plan))
        atomic_write_text(out / "summary.json", json.dumps(summary, indent=2))
        write_report(out, summary, lines, Path(ref_plan["dataset_root"]), render=render)
    return summary


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m rail_mj.eval", description=__doc__.split("\n\n")[0])
    p.add_argument("--dataset", default="procedural", help="'procedural' or a folder with labels.jsonl")
    p.add_argument("--per-class", type=int, default=3, help="objects per class (procedural)")
    p.add_argument("--seed", type=int, default=0, help="dataset seed (procedural)")
    p.add_argument("--family", default="core", choices=tuple(FAMILIES),
                   help="procedural class family: core (default, the published set), world (shapes of real meshes, "
                   "scan-like corruption mixed in) or all")
    p.add_argument("--classes", help="comma-separated classes (procedural), default all of the family")
    p.add_argument("--affordances", help="comma-separated requested affordances, default all labelled")
    p.add_argument("--out", type=Path, required=True, help="output folder (one run at a time)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run in --out")
    p.add_argument("--provider", default="auto", choices=("auto", "offline", "anthropic"))
    p.add_argument("--backend", default="auto", choices=("auto", "native", "mjx"))
    p.add_argument("--drops", type=int, default=64, help="drops for stable-pose imagination")
    p.add_argument("--no-render", action="store_true", help="skip the pictures in report.md")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--workers", type=int, default=None,
                   help=f"worker processes, one object each at a time (default: every core, {cpu_count()} here; "
                        "1 runs in this process); with --ray and no ADDRESS, the local Ray's CPUs")
    p.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                   help="run the objects as Ray tasks on the cluster at ADDRESS, or on a local Ray without one "
                        "(pip install -e '.[cluster]')")
    p.add_argument("--shard", help="i/n: evaluate every n-th labelled object from the i-th (1-based); "
                                   "join the parts with `python -m rail_mj.eval merge`")
    return p


def _merge_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m rail_mj.eval merge",
        description="Join the output folders of one evaluation's --shard runs into the files one serial run writes.",
    )
    p.add_argument("inputs", nargs="+", type=Path, metavar="OUT", help="output folders of the shard runs")
    p.add_argument("--out", type=Path, required=True, help="folder for the merged results (empty, or a merge's)")
    p.add_argument("--no-render", action="store_true", help="skip the pictures in report.md")
    return p


#: The command-line option of each EvalConfig field, for error messages.
_OPTIONS = {"per_class": "--per-class", "dataset_seed": "--seed", "n_drops": "--drops"}


def _config(args: argparse.Namespace) -> EvalConfig:
    split = lambda s: [x.strip() for x in s.split(",") if x.strip()] if s else None  # noqa: E731
    try:
        return EvalConfig(
            dataset=args.dataset,
            per_class=args.per_class,
            dataset_seed=args.seed,
            family=args.family,
            classes=split(args.classes),
            affordances=split(args.affordances),
            provider=args.provider,
            backend=args.backend,
            n_drops=args.drops,
            render=not args.no_render,
        )
    except ValidationError as exc:
        problems = "; ".join(
            f"{_OPTIONS.get(str(e['loc'][0]), e['loc'][0])} {e['input']!r}: {e['msg']}" for e in exc.errors()
        )
        raise ConfigError(f"bad option value: {problems}") from None


def _print_outcome(summary: dict, out: Path) -> int:
    print(_tables(summary))
    print("\n" + _timing_table(summary))
    print(f"\nwrote {out / 'results.jsonl'}, {out / 'summary.json'}, {out / 'report.md'}")
    for key, message in summary["errors"].items():
        print(f"error: {key}: {message}", file=sys.stderr)
    if summary.get("missing_shards"):
        print(f"error: shards {', '.join(summary['missing_shards'])} were not given; merge again with them",
              file=sys.stderr)
    if not summary["complete"]:
        print(
            f"error: {out / 'results.jsonl'} does not hold each of the {summary['n_expected']} expected "
            "cases exactly once; "
            + ("rerun the shard runs with --resume, then merge again" if "merged_from" in summary
               else "rerun with --resume"),
            file=sys.stderr,
        )
    return EXIT_OK if summary["complete"] and not summary["errors"] else EXIT_FAILED


def _merge_main(argv: Sequence[str]) -> int:
    args = _merge_parser().parse_args(argv)
    try:
        summary = merge_runs(args.inputs, args.out, render=not args.no_render)
    except RailError as exc:
        return report_error(exc)
    return _print_outcome(summary, args.out)


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; exit status by the rule in :mod:`rail_mj.core.cli`. ``merge ...`` joins shard runs."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["merge"]:
        return _merge_main(argv[1:])
    args = _parser().parse_args(argv)
    try:
        summary = run_eval(
            _config(args), args.out, resume=args.resume, progress=not args.no_progress, workers=args.workers,
            executor="local" if args.ray is None else "ray", ray_address=args.ray or None,
            shard=None if args.shard is None else parse_shard(args.shard),
        )
    except KeyboardInterrupt as exc:
        code = report_error(exc)
        print(f"finished lines are in {args.out / 'results.jsonl'}; rerun with --resume", file=sys.stderr)
        return code
    except RailError as exc:
        return report_error(exc)
    return _print_outcome(summary, args.out)
