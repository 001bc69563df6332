"""Imagination seconds with K perturbed worlds vs the nominal world alone, on a few real meshes (cached hulls).

    python benchmarks/perturbation_cost.py [--dataset DIR] [--k 0 4] [--objects 4] [--json]

Each object is loaded (hulls, stable poses) once; every affordance is then run with each K in turn in this process
(one thread per batch is not forced: the machine's load shows in the figures, so compare the columns of one run).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from rail_mj.dataset.labels import read_labels
from rail_mj.dataset.realset import real_data_dir
from rail_mj.imagination import ImaginationConfig
from rail_mj.pipeline import Pipeline
from rail_mj.pipeline.config import ObjectInput, RunConfig

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
    pipes = {k: Pipeline(RunConfig(provider="offline", imagination=ImaginationConfig(perturbations=k)))
             for k in args.k}
    first = pipes[args.k[0]]
    seconds = {k: 0.0 for k in args.k}
    cases = 0
    for row in labels:
        obj = first.load(ObjectInput(path=args.dataset / row.mesh, units=row.units, up=row.up))
        poses = first.stable_poses(obj)
        for a in AFFORDANCES:
            for k, pipe in pipes.items():
                r = pipe.run(obj, poses, a)
                seconds[k] += sum(r.timings.get(s, 0.0) for s in ("imagination", "scoring", "functional_pose_analyzer"))
            cases += 1
    out = {"objects": len(labels), "cases": cases, "seconds": {str(k): round(v, 2) for k, v in seconds.items()}}
    if args.json:
        print(json.dumps(out))
        return
    print(f"{len(labels)} objects, {cases} (object, affordance) cases")
    for k, v in seconds.items():
        print(f"K={k}: imagination + scoring + verdicts {v:.1f} s ({v / seconds[args.k[0]]:.2f}x K={args.k[0]})")


if __name__ == "__main__":
    main()
