"""Evaluation throughput over processes: workers=1 (one process), workers=2, and a local Ray with 2 CPUs.

Run::

    python benchmarks/eval_scaling.py [--classes cup,bowl,...] [--per-class 1] [--affordances cup,bowl]
                                      [--cache cold|warm] [--no-ray] [--out DIR] [--json P]

One procedural dataset (default: every class, one object each, the paper's eight affordances: README
command 1's cases) is evaluated in turn by each mode, each into its own folder under ``--out``, with the
offline provider and the native backend. ``--cache cold`` (the default) gives every mode a fresh cache,
so CoACD and the stable poses run in each. ``--cache warm`` fills one cache with a serial run first and
times all three on it. Prints each mode's wall time, cases/s, its ratio to workers=1, and the cores the
local modes kept busy (CPU seconds / wall seconds; workers=1 runs MuJoCo's batch on every core, so the
cores it leaves idle bound what more processes can gain). Ray is
started before its run and its start-up is timed apart (the figure with and without it). Then it checks
that the three modes gave identical verdicts, and identical results apart from the timings. Exit 1 when
they differ. Timing on a shared machine is noisy: the load average is printed with the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from cpu_time import cpu_seconds  # benchmarks/cpu_time.py, beside this script

from rail_mj.affordances import PAPER_AFFORDANCES
from rail_mj.core.paths import CACHE_ENV
from rail_mj.dataset.ground_truth import CLASSES
from rail_mj.dataset.procedural import generate
from rail_mj.eval import run as rail_eval

VERDICT = ("predicted", "correct", "pose_correct", "pose_correct_without_analyzer", "error")




def _run(dataset: Path, out: Path, affordances: list[str], cache: Path, **execution) -> float:
    """One evaluation into ``out``; its wall time (the run's own, dataset and imports excluded)."""
    os.environ[CACHE_ENV] = str(cache)  # the workers (and Ray's, started later) inherit it
    cfg = rail_eval.EvalConfig(dataset=str(dataset), affordances=affordances, provider="offline", backend="native",
                               render=False)
    summary = rail_eval.run_eval(cfg, out, progress=False, **execution)
    if not summary["complete"]:
        sys.exit(f"{out}: the run is not complete")
    return summary["wall_s_this_run"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--classes", default=",".join(CLASSES), help="comma-separated classes (default: all)")
    parser.add_argument("--per-class", type=int, default=1)
    parser.add_argument("--affordances", default=",".join(PAPER_AFFORDANCES))
    parser.add_argument("--seed", type=int, default=0, help="dataset seed")
    parser.add_argument("--cache", choices=("cold", "warm"), default="cold")
    parser.add_argument("--no-ray", action="store_true", help="skip the Ray mode (no [cluster] extra)")
    parser.add_argument("--out", type=Path, help="folder for the runs (default: a temporary one)")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    classes = [c for c in args.classes.split(",") if c]
    affordances = [a for a in args.affordances.split(",") if a]
    base = args.out or Path(tempfile.mkdtemp(prefix="eval_scaling_"))
    base.mkdir(parents=True, exist_ok=True)
    dataset = base / "dataset"
    if not (dataset / "labels.jsonl").exists():
        generate(dataset, classes=classes, per_class=args.per_class, seed=args.seed, affordances=affordances)
    n_objects = len(classes) * args.per_class
    print(f"{n_objects} objects x {len(affordances)} affordances = {n_objects * len(affordances)} cases, "
          f"{os.cpu_count()} CPUs, cache {args.cache}, runs in {base}")

    shared = base / "cache-warm"
    if args.cache == "warm":
        print("filling the warm cache with one serial run ...", flush=True)
        _run(dataset, base / "fill", affordances, shared, workers=1)
    cache_for = (lambda mode: base / f"cache-{mode}") if args.cache == "cold" else (lambda mode: shared)

    modes: dict[str, dict] = {}
    for mode, execution in (("workers=1", {"workers": 1}), ("workers=2", {"workers": 2})):
        load0, cpu0 = os.getloadavg()[0], cpu_seconds()
        wall = _run(dataset, base / mode.replace("=", ""), affordances, cache_for(mode.replace("=", "")), **execution)
        modes[mode] = {"wall_s": wall, "load_before": load0, "cores_used": (cpu_seconds() - cpu0) / wall}
    if not args.no_ray:
        import ray

        os.environ[CACHE_ENV] = str(cache_for("ray"))
        t = time.perf_counter()
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        start = time.perf_counter() - t
        try:
            load0 = os.getloadavg()[0]
            wall = _run(dataset, base / "ray", affordances, cache_for("ray"), executor="ray")
        finally:
            ray.shutdown()
        modes["ray (2 CPUs)"] = {"wall_s": wall, "load_before": load0, "ray_start_s": start}

    n_cases = n_objects * len(affordances)
    ref = modes["workers=1"]["wall_s"]
    print("\n| mode | wall s | cases/s | x workers=1 | cores busy | load avg before |\n|---|---|---|---|---|---|")
    for mode, m in modes.items():
        m["cases_per_s"] = n_cases / m["wall_s"]
        m["ratio"] = ref / m["wall_s"]
        busy = f"{m['cores_used']:.2f}" if "cores_used" in m else "-"
        print(f"| {mode} | {m['wall_s']:.1f} | {m['cases_per_s']:.2f} | {m['ratio']:.2f} | {busy} | "
              f"{m['load_before']:.1f} |")
        if "ray_start_s" in m:
            with_start = m["wall_s"] + m["ray_start_s"]
            m["ratio_with_start"] = ref / with_start
            print(f"| {mode} + its start-up ({m['ray_start_s']:.1f} s) | {with_start:.1f} | "
                  f"{n_cases / with_start:.2f} | {m['ratio_with_start']:.2f} | - | |")
    # workers=1 already runs MuJoCo's batch on every core during physics: what it leaves idle bounds the gain
    ceiling = os.cpu_count() / modes["workers=1"]["cores_used"]
    print(f"\nworkers=1 keeps {modes['workers=1']['cores_used']:.2f} of {os.cpu_count()} cores busy: no mode can "
          f"beat it by more than {ceiling:.2f}x here")

    folders = {"workers=1": "workers1", "workers=2": "workers2", "ray (2 CPUs)": "ray"}
    results = {mode: rail_eval.cases_without_timings(base / folders[mode]) for mode in modes}
    reference = results["workers=1"]
    verdicts = {mode: {k: [ln[f] for f in VERDICT] for k, ln in r.items()} for mode, r in results.items()}
    same_verdicts = all(v == verdicts["workers=1"] for v in verdicts.values())
    same_results = all(r == reference for r in results.values())
    print(f"\nverdicts identical across {', '.join(modes)}: {same_verdicts}")
    print(f"results identical apart from timings: {same_results}")
    print(f"load average now: {os.getloadavg()[0]:.1f} (2 means both cores busy with other work)")
    if args.json:
        args.json.write_text(json.dumps({"n_cases": n_cases, "cache": args.cache, "modes": modes,
                                         "same_verdicts": same_verdicts, "same_results": same_results}, indent=2))
    return 0 if same_verdicts and same_results else 1


if __name__ == "__main__":
    sys.exit(main())
