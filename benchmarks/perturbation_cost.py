"""What the perturbed worlds and the second decomposition cost, and what they change, on a few real meshes.

    python benchmarks/perturbation_cost.py [--dataset DIR] [--k 0 4] [--objects 4] [--json]

Each object is loaded (hulls, stable poses) once; every affordance is then run in this process with each K of
``--k`` and the second decomposition off, and once more with the largest K and the second decomposition on
(``ImaginationConfig.perturb_decomposition``). The seconds are each ``Pipeline.run``'s wall time: the nominal
imagination, the perturbed worlds, the second decomposition (its CoACD run included, once per object: later
affordances find its hulls cached) and the verdicts. Next to them: how many verdicts (``functional``) differ from
the first column's, and in how many cases the second decomposition was imagined. The machine's load shows in the
seconds: compare the columns of one run. The CPU seconds (every thread of this process, the load of other processes
apart) of the nominal imagination and of the perturbed worlds, from each result's timings, split what the
perturbed worlds cost against what the nominal world costs.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from rail_mj.dataset.labels import read_labels
from rail_mj.dataset.realset import real_data_dir
from rail_mj.imagination import ImaginationConfig
from rail_mj.pipeline import Pipeline
from rail_mj.pipeline.config import ObjectInput, RunConfig

#: Two uses that rest in a concavity, one on a top, one on a seat, one in a basket's cavity.
AFFORDANCES = ("cup", "bowl", "basket", "table", "chair")


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--dataset", type=Path, default=None,
                    help="a folder with labels.jsonl (default: the real-mesh development set, $RAIL_MJ_REAL_DATA or "
                         "the cache's, built there on first use)")
    ap.add_argument("--k", type=int, nargs="+", default=[0, 4])
    ap.add_argument("--objects", type=int, default=4)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    args.dataset = args.dataset or real_data_dir()
    labels = read_labels(args.dataset / "labels.jsonl")[: args.objects]
    modes = {f"K={k}": ImaginationConfig(perturbations=k, perturb_decomposition=False) for k in args.k}
    modes[f"K={max(args.k)} + second decomposition"] = ImaginationConfig(perturbations=max(args.k))
    pipes = {name: Pipeline(RunConfig(provider="offline", imagination=cfg)) for name, cfg in modes.items()}
    first_mode = next(iter(pipes))
    first = pipes[first_mode]
    seconds = dict.fromkeys(pipes, 0.0)
    cpu = {name: {"imagination_cpu": 0.0, "perturbed_worlds_cpu": 0.0} for name in pipes}
    changed = dict.fromkeys(pipes, 0)
    decomposed = 0
    cases = 0
    for row in labels:
        obj = first.load(ObjectInput(path=args.dataset / row.mesh, units=row.units, up=row.up))
        poses = first.stable_poses(obj)
        for a in AFFORDANCES:
            verdicts = {}
            for name, pipe in pipes.items():
                t = time.perf_counter()
                r = pipe.run(obj, poses, a)
                seconds[name] += time.perf_counter() - t
                verdicts[name] = r.functional
                for stage in cpu[name]:
                    cpu[name][stage] += r.timings.get(stage, 0.0)
                decomposed += "second_decomposition" in r.timings
            for name, v in verdicts.items():
                changed[name] += v != verdicts[first_mode]
            cases += 1
    out = {"objects": len(labels), "cases": cases, "seconds": {k: round(v, 2) for k, v in seconds.items()},
           "cpu_seconds": {k: {s: round(v, 2) for s, v in c.items()} for k, c in cpu.items()},
           "verdicts_changed": changed, "second_decomposition_imagined": decomposed}
    if args.json:
        print(json.dumps(out))
        return
    print(f"{len(labels)} objects, {cases} (object, affordance) cases; seconds of Pipeline.run (imagination, perturbed "
          f"worlds, second decomposition, verdicts), hulls and stable poses loaded once")
    for name, v in seconds.items():
        print(f"{name}: {v:.1f} s ({v / seconds[first_mode]:.2f}x {first_mode}); verdicts that differ from "
              f"{first_mode}'s: {changed[name]}")
    print(f"the second decomposition was imagined in {decomposed} of {cases} cases (where it could turn the verdict)")
    for name, c in cpu.items():
        nominal, perturbed = c["imagination_cpu"], c["perturbed_worlds_cpu"]
        ratio = f" ({perturbed / nominal:.2f}x)" if nominal else ""
        print(f"{name}: CPU s nominal imagination {nominal:.1f}, perturbed worlds {perturbed:.1f}{ratio}")


if __name__ == "__main__":
    main()
