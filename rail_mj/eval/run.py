"""Running an evaluation: the dataset, the cases, and ``OUT/results.jsonl`` written as each case finishes.

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
"""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import sys
import time
from collections import Counter
from collections.abc import Sequence
from contextlib import ExitStack, closing
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from rail_mj.affordances import PAPER_AFFORDANCES, load_files
from rail_mj.affordances.judge import rules_row
from rail_mj.core.errors import ConfigError, DatasetError
from rail_mj.core.runfiles import atomic_write_text, folder_lock
from rail_mj.dataset import ground_truth, labels, procedural, shapes
from rail_mj.dataset.ground_truth import AFFORDANCES, FAMILIES, normalize_affordance
from rail_mj.dataset.labels import LabelRecord, read_labels
from rail_mj.dataset.procedural import generate
from rail_mj.eval.report import write_report
from rail_mj.eval.summary import _line, summarize
from rail_mj.pipeline.chain import Pipeline, define_uses, definition_counter, object_task
from rail_mj.pipeline.config import ObjectInput, RunConfig
from rail_mj.pipeline.parallel import check_executor, run_tasks
from rail_mj.pipeline.ray_executor import Placement
from rail_mj.pipeline.tasks import cpu_count, plan_workers

__all__ = [
    "PLAN_FILE",
    "DATASET_SPEC",
    "DatasetConfig",
    "EvalConfig",
    "run_eval",
    "parse_shard",
    "cases_without_timings",
]

#: a run's settings and cases, written before any case runs: what ``merge`` joins shards by
PLAN_FILE = "plan.json"


class DatasetConfig(BaseModel):
    """The labelled objects an evaluation runs on: the procedural generator's, or a folder's."""

    model_config = ConfigDict(extra="forbid")

    source: str = Field(default="procedural", description="'procedural' or a folder with labels.jsonl")
    per_class: int = Field(default=3, ge=1, description="objects per class (procedural)")
    seed: int = Field(default=0, description="the generator's seed (procedural)")
    family: Literal["core", "world", "all"] = Field(
        default="core", description="procedural class family (rail_mj.dataset.ground_truth.FAMILIES)")
    classes: list[str] | None = Field(default=None, description="procedural classes; None: all of the family")
    orientation: Literal["random", "as_built"] = Field(
        default="random", description="procedural objects in random orientations, or standing as built")


class EvalConfig(BaseModel):
    """A run of the evaluation: the pipeline's settings (``run``), the dataset, and what to evaluate."""

    model_config = ConfigDict(extra="forbid")

    run: RunConfig = Field(default_factory=RunConfig, description="the classification run's settings")
    dataset: DatasetConfig = Field(default_factory=DatasetConfig)
    affordances: list[str] | None = Field(default=None, description="requested affordances; None: all labelled")
    render: bool = Field(default=True, description="the pictures in report.md")


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


def _generator_sources() -> list[Path]:
    """The source files of the procedural generator, in a fixed order: the dataset modules that make the meshes,
    their labels and their ground truth, then every file of the shapes package by name."""
    modules = [Path(inspect.getfile(m)) for m in (procedural, ground_truth, labels)]
    return modules + sorted(Path(inspect.getfile(shapes)).parent.glob("*.py"))


def _dataset_spec(cfg: EvalConfig, classes: Sequence[str], affordances: Sequence[str]) -> dict:
    code = hashlib.sha256(b"".join(path.read_bytes() for path in _generator_sources())).hexdigest()
    data = cfg.dataset
    return {"family": data.family, "classes": list(classes), "per_class": data.per_class, "seed": data.seed,
            "orientation": data.orientation, "affordances": list(affordances), "generator_sha256": code}


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
    data = cfg.dataset
    if data.source == "procedural":
        classes = list(dict.fromkeys(data.classes or FAMILIES[data.family]))
        names = affordances or list(PAPER_AFFORDANCES)
        _check_names(classes, FAMILIES[data.family], "--classes")
        _check_names(names, list(AFFORDANCES), "--affordances")
        root = out / "dataset"
        spec = _dataset_spec(cfg, classes, names)
        why = _stale_reason(root, spec)
        if why is not None:
            if root.exists():  # e.g. left by an older run killed while writing it
                print(f"rebuilding {root}: {why}", file=sys.stderr)
                (root / DATASET_SPEC).unlink(missing_ok=True)
            generate(root, classes=classes, per_class=data.per_class, seed=data.seed, affordances=names,
                     family=data.family, orientation=data.orientation)
            atomic_write_text(root / DATASET_SPEC, json.dumps(spec, indent=2))
        return root, read_labels(root)
    root = Path(data.source)
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

    ``workers``, ``executor`` and ``ray_address`` say where the objects run
    (:func:`rail_mj.pipeline.parallel.run_tasks`; ``workers=None``: every core). ``shard=(i, n)`` takes every
    n-th labelled object from the i-th (1-based).
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
    load_files(cfg.run.affordances_files)  # before any name is read
    requested = list(dict.fromkeys(normalize_affordance(a) for a in cfg.affordances)) if cfg.affordances else None
    root, records = _dataset(cfg, out, requested)
    repeated = sorted(m for m, n in Counter(r.mesh for r in records).items() if n > 1)
    if repeated:  # one key per case: a mesh listed twice would be evaluated twice and never "complete"
        raise DatasetError(f"{root / 'labels.jsonl'} lists {', '.join(repeated)} more than once; "
                           "give each mesh one line")
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

    run_cfg = cfg.run
    pipe = Pipeline(run_cfg)
    # stage 0 once for the run, before any object: each use outside the registry a proven row or profile
    # a label key outside the registry ("fruit_bowl") is put to the model in words, as a person names the use
    use = {a: a if rules_row(a) is not None else " ".join(a.split("_")) for _, affs in pending for a in affs}
    run_cfg, defined = define_uses(list(dict.fromkeys(use.values())), pipe, run_cfg)
    count = definition_counter(defined)
    config = {**cfg.model_dump(mode="json"), "backend_used": pipe.backend}
    plan = {"config": config, "shard": list(shard) if shard else None, "dataset_root": str(root.resolve()),
            "keys": all_keys, "expected": expected}
    atomic_write_text(out / PLAN_FILE, json.dumps(plan))
    # the workers get the provider and backend this process resolved, so a node without an API key fails
    # visibly instead of falling back to another provider
    task_cfg = run_cfg.model_copy(update={"provider": pipe.provider_name, "backend": pipe.backend})
    tasks = [
        # absolute: a Ray worker resolves a relative path against its own folder, not this process's
        object_task(i, ObjectInput(path=root.resolve() / r.mesh, units=r.units, up=r.up, name=r.mesh,
                                        oriented=r.oriented),
                    [use[a] for a in affs], task_cfg)
        for i, (r, affs) in enumerate(pending)
    ]
    if executor == "local":
        n_workers, threads = plan_workers(workers, len(tasks))
        execution = {"executor": "local", "workers": n_workers, "threads_per_worker": threads, "cores": cpu_count()}
    else:
        execution = {"executor": executor, "address": ray_address, "local_cpus": workers}
    execution["shard"] = f"{shard[0]}/{shard[1]}" if shard else None
    placement = Placement()  # filled by a Ray run: which node ran which object
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
                closing(run_tasks(tasks, workers=workers, executor=executor, ray_address=ray_address,
                                  placement=placement))
            )
            for task, results in stream:
                record, keys = pending[task.index]
                for a, result in zip(keys, results):
                    count(result)
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
    if executor == "ray":
        mesh = {t.label: pending[t.index][0].mesh for t in tasks}  # the dataset's names, as in results.jsonl
        execution.update(nodes={node: [mesh[label] for label in labels] for node, labels in placement.nodes.items()},
                         node_ips=placement.node_ips, lost_nodes=placement.lost)
    summary["execution"] = execution
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2))
    write_report(out, summary, lines, root, render=cfg.render and not interrupted)
    if interrupted:
        raise KeyboardInterrupt
    return summary
