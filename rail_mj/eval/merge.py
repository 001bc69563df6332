"""``python -m rail_mj.eval merge``: join the output folders of one evaluation's ``--shard`` runs into one."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Sequence
from contextlib import ExitStack
from pathlib import Path

from rail_mj.core.errors import ConfigError
from rail_mj.core.runfiles import atomic_write_text, folder_lock
from rail_mj.eval.report import write_report
from rail_mj.eval.run import PLAN_FILE, _read_lines
from rail_mj.eval.summary import summarize

__all__ = ["merge_runs"]


def _flat(config: dict, prefix: str = "") -> dict:
    """A run's settings by their dotted path (``run.stable_poses.n_drops``), so a refusal names the one that differs."""
    out: dict = {}
    for k, v in config.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


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
        mine, theirs = _flat(ref_plan["config"]), _flat(plan["config"])
        differ = sorted(k for k in mine.keys() | theirs.keys() if mine.get(k) != theirs.get(k))
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
