"""Cost per case of the evaluation, serial and spread: CPU seconds per case, the driver's share, and a projection.

Run::

    python benchmarks/eval_scaling.py [--classes cup,bowl,...] [--per-class 1] [--affordances cup,bowl]
                                      [--cache cold|warm] [--no-ray] [--out DIR] [--json P]

One procedural dataset (default: every class, one object each, the paper's eight affordances: README
command 1's cases) is evaluated in turn by each mode: serial (``--workers 1``), ``--workers 2`` and a local
Ray with 2 CPUs, each into its own folder under ``--out``, with the offline provider and the native backend.
``--cache cold`` (the default) gives every mode a fresh cache, so CoACD and the stable poses run in each;
``--cache warm`` fills one cache with a serial run first and times all three on it.

For each mode it prints the wall time and the CPU seconds per case summed over every process that worked
on the run: the driver (``python -m rail_mj.eval``'s process: planning, writing results.jsonl) and the
workers (local worker processes, the CoACD children and the scoring sandbox's processes, counted by
``getrusage(RUSAGE_CHILDREN)`` once they are waited for; Ray's worker processes, their children and Ray's own
daemons, raylet and GCS, which are not this process's waited children, by sampling their CPU times with
psutil every 0.2 s from the run's start to its end: a child a Ray worker has waited for is counted in the
worker's time, not again on its own, and up to 0.2 s of a process that exits unwaited in between is missed).
Next to it, the driver's own CPU seconds per case: the serial part of a spread run.

From those figures it projects N = 16, 64, 256 cores by Amdahl's law with the driver's share of the CPU
time as the serial fraction f: speedup S(N) = 1 / (f + (1 - f) / N), throughput S(N) / (CPU s per case)
cases per second, and core-seconds per case N / throughput = (CPU s per case) x (N f + 1 - f). It assumes
the per-case CPU measured here holds on the cluster's cores, cases spread evenly (no straggler object
at the end), the LLM provider (offline here) adds no driver work, and the driver's work does not overlap
the workers' (pessimistic: the driver writes one result while the workers compute the next). Then it
checks that the three modes gave identical results apart from the timings. Exit 1 when they differ.
Timing on a shared machine is noisy: the load average is printed with the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from rail_mj.affordances import PAPER_AFFORDANCES
from rail_mj.core.paths import CACHE_ENV
from rail_mj.dataset.ground_truth import CLASSES
from rail_mj.dataset.procedural import generate
from rail_mj.eval import run as rail_eval
from rail_mj.scoring.pool import close_workers

CORES = (16, 64, 256)
SAMPLE_S = 0.2  # how often the Ray processes' CPU times are read
TARGET = 1.15  # the target: a spread run costs at most 15% more CPU per case than serial


def _rusage() -> tuple[float, float]:
    """(this process's CPU seconds, its waited-for descendants' CPU seconds)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, kids.ru_utime + kids.ru_stime


@dataclass
class _Seen:
    """One descendant process at its latest reading."""

    parent: int
    worker: bool  # a Ray worker (titled ray::<task>) or a process under one (its CoACD children)
    own: float  # its own CPU seconds
    waited: float  # CPU seconds of its children that it has waited for (the kernel adds each once, at its exit)


class _TreeSampler:
    """CPU seconds used by this process's descendants (Ray's processes) between start() and stop().

    Each process is counted once: a living process by its own time plus its waited-for children's; a process gone
    by the end is counted by its last reading unless its parent is still there, whose waited-for time holds it
    whole (a Ray worker's CoACD child: counting both would count it twice)."""

    def __init__(self) -> None:
        import psutil  # the [cluster] extra declares it: Ray's workers are not children this process waits for

        self._me = psutil.Process()
        self._base: dict[int, _Seen] = {}
        self._last: dict[int, _Seen] = {}
        self._halt = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)

    def _read(self) -> dict[int, _Seen]:
        import psutil

        raw: dict[int, tuple[int, bool, float, float]] = {}
        for p in self._me.children(recursive=True):
            try:
                t, argv, parent = p.cpu_times(), p.cmdline(), p.ppid()
            except psutil.Error:
                continue
            ray_worker = bool(argv) and (argv[0].startswith("ray::") or "default_worker.py" in " ".join(argv))
            raw[p.pid] = (parent, ray_worker, t.user + t.system, t.children_user + t.children_system)

        def under_worker(pid: int) -> bool:
            while pid in raw:
                if raw[pid][1]:
                    return True
                pid = raw[pid][0]
            return False

        return {pid: _Seen(parent, under_worker(pid), own, waited) for pid, (parent, _, own, waited) in raw.items()}

    def _loop(self) -> None:
        while not self._halt.wait(SAMPLE_S):
            self._last.update(self._read())

    def start(self) -> None:
        self._base = self._read()
        self._thread.start()

    def stop(self) -> tuple[float, float]:
        """(CPU s of the Ray worker processes and their children, CPU s of Ray's other processes) since start()."""
        self._halt.set()
        self._thread.join()
        alive = self._read()
        self._last.update(alive)
        workers = other = 0.0
        for pid, seen in self._last.items():
            if pid not in alive and seen.parent in alive:
                continue  # in its parent's waited-for time
            base = self._base.get(pid)
            used = seen.own + seen.waited - (base.own + base.waited if base else 0.0)
            if seen.worker:
                workers += used
            else:
                other += used
        return workers, other


def _run(dataset: Path, out: Path, affordances: list[str], cache: Path, **execution) -> dict:
    """One evaluation into ``out``: its wall time (the run's own, dataset and imports excluded) and CPU seconds."""
    os.environ[CACHE_ENV] = str(cache)  # the workers (and Ray's, started later) inherit it
    cfg = rail_eval.EvalConfig(dataset={"source": str(dataset)}, affordances=affordances,
                               run={"provider": "offline", "backend": "native"}, render=False)
    sampler = _TreeSampler() if execution.get("executor") == "ray" else None
    if sampler is not None:
        sampler.start()
    own0, kids0 = _rusage()
    summary = rail_eval.run_eval(cfg, out, progress=False, **execution)
    close_workers()  # the scoring sandbox's processes, waited for here, so that getrusage counts them
    own1, kids1 = _rusage()
    if not summary["complete"]:
        sys.exit(f"{out}: the run is not complete")
    figures = {"wall_s": summary["wall_s_this_run"], "driver_cpu_s": own1 - own0, "workers_cpu_s": kids1 - kids0}
    if sampler is not None:
        ray_workers, ray_daemons = sampler.stop()
        figures.update(workers_cpu_s=figures["workers_cpu_s"] + ray_workers, ray_daemons_cpu_s=ray_daemons)
    return figures


def _projection(mode: str, m: dict) -> str:
    f, c = m["driver_share"], m["cpu_s_per_case"]
    rows = ""
    for n in CORES:
        speedup = 1.0 / (f + (1.0 - f) / n)
        m.setdefault("projection", {})[str(n)] = {"speedup": speedup, "cases_per_hour": 3600.0 * speedup / c,
                                                  "core_s_per_case": c * (n * f + 1.0 - f)}
        p = m["projection"][str(n)]
        rows += (f"| {mode} | {n} | {f:.4f} | {speedup:.1f} | {p['cases_per_hour']:.0f} | "
                 f"{p['core_s_per_case']:.2f} |\n")
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
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
    n_cases = n_objects * len(affordances)
    print(f"{n_objects} objects x {len(affordances)} affordances = {n_cases} cases, {os.cpu_count()} CPUs, "
          f"cache {args.cache}, runs in {base}")

    shared = base / "cache-warm"
    if args.cache == "warm":
        print("filling the warm cache with one serial run ...", flush=True)
        _run(dataset, base / "fill", affordances, shared, workers=1)
    cache_for = (lambda folder: base / f"cache-{folder}") if args.cache == "cold" else (lambda folder: shared)

    runs: list[tuple[str, str, dict[str, object]]] = [("serial", "serial", {"workers": 1}),
                                                      ("workers=2", "workers2", {"workers": 2})]
    if not args.no_ray:
        runs.append(("ray (2 CPUs)", "ray", {"executor": "ray"}))
    modes: dict[str, dict] = {}
    for mode, folder, execution in runs:
        load0 = os.getloadavg()[0]
        if execution.get("executor") == "ray":
            os.environ[CACHE_ENV] = str(cache_for(folder))  # before Ray starts: its workers inherit it
            # read when Ray is imported: with it, Ray's "local address" is loopback, and the nodes bind there
            os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
            import ray

            home = os.environ.get("HOME")
            os.environ["HOME"] = tempfile.mkdtemp(prefix="ray_home_")  # Ray's ~/.ray state stays out of other Rays
            t = time.perf_counter()
            ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, _node_ip_address="127.0.0.1")
            start = time.perf_counter() - t
            try:
                ips = {n["NodeManagerAddress"] for n in ray.nodes()}
                if ips != {"127.0.0.1"}:
                    sys.exit(f"Ray's node reports {ips}, not loopback")
                m = _run(dataset, base / folder, affordances, cache_for(folder), **execution)
            finally:
                ray.shutdown()
                if home is not None:
                    os.environ["HOME"] = home
            m["ray_start_s"] = start
        else:
            m = _run(dataset, base / folder, affordances, cache_for(folder), **execution)
        m["load_before"] = load0
        total = m["driver_cpu_s"] + m["workers_cpu_s"] + m.get("ray_daemons_cpu_s", 0.0)
        m.update(cpu_s=total, cpu_s_per_case=total / n_cases, driver_cpu_s_per_case=m["driver_cpu_s"] / n_cases,
                 driver_share=m["driver_cpu_s"] / total, cases_per_s=n_cases / m["wall_s"])
        modes[mode] = m

    ref = modes["serial"]["cpu_s_per_case"]
    print("\n| mode | wall s | cases/s | CPU s/case (all processes) | x serial | driver CPU s/case | "
          "Ray daemons CPU s | load avg before |\n|---|---|---|---|---|---|---|---|")
    for mode, m in modes.items():
        m["cpu_ratio_to_serial"] = m["cpu_s_per_case"] / ref
        daemons = f"{m['ray_daemons_cpu_s']:.1f}" if "ray_daemons_cpu_s" in m else "-"
        print(f"| {mode} | {m['wall_s']:.1f} | {m['cases_per_s']:.2f} | {m['cpu_s_per_case']:.3f} | "
              f"{m['cpu_ratio_to_serial']:.2f} | {m['driver_cpu_s_per_case']:.4f} | {daemons} | "
              f"{m['load_before']:.1f} |")
    for mode, m in modes.items():
        if mode != "serial":
            verdict = "within" if m["cpu_ratio_to_serial"] <= TARGET else "OVER"
            print(f"{mode}: {100 * (m['cpu_ratio_to_serial'] - 1):+.1f}% CPU per case against serial: {verdict} "
                  f"the +{100 * (TARGET - 1):.0f}% target")
    if "ray_start_s" in modes.get("ray (2 CPUs)", {}):
        print(f"Ray's start-up ({modes['ray (2 CPUs)']['ray_start_s']:.1f} s wall) is outside its figures")

    print("\nAmdahl projection, serial fraction f = the driver's share of the mode's CPU seconds:\n"
          "  S(N) = 1 / (f + (1 - f) / N);  cases/h = 3600 S(N) / (CPU s per case);  "
          "core-s per case = (CPU s per case) (N f + 1 - f)\n"
          "\n| mode | cores N | f | speedup S(N) | cases/h | core-s per case |\n|---|---|---|---|---|---|")
    print("".join(_projection(mode, m) for mode, m in modes.items() if mode != "serial"), end="")

    results = {mode: rail_eval.cases_without_timings(base / folder) for mode, folder, _ in runs}
    same = all(r == results["serial"] for r in results.values())
    print(f"\nresults identical apart from timings across {', '.join(modes)}: {same}")
    print(f"load average now: {os.getloadavg()[0]:.1f} ({os.cpu_count()} means every core busy with other work)")
    if args.json:
        args.json.write_text(json.dumps({"n_cases": n_cases, "cache": args.cache, "formula": {
            "speedup": "1 / (f + (1 - f) / N)", "cases_per_hour": "3600 * speedup / cpu_s_per_case",
            "core_s_per_case": "cpu_s_per_case * (N * f + 1 - f)", "f": "driver_cpu_s / cpu_s"},
            "cpu_s_per_case": {mode: m["cpu_s_per_case"] for mode, m in modes.items()},
            "modes": modes, "same_results": same}, indent=2))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
