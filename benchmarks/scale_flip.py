"""Robustness: how often a verdict flips when the mesh is rescaled by ±10%.

    python benchmarks/scale_flip.py [--dataset DIR|procedural] [--objects N] [--affordances a,b]
                                    [--scales 0.9 1.1] [--perturbations K] [--workers N] [--json]

Every object of the set is classified for each labelled affordance at scale 1 and at each of ``--scales`` (the
mesh read with its units times the scale: the whole pipeline runs on the rescaled mesh, hulls and stable poses
included). A case flips when its ``functional`` at some scale differs from scale 1's; the flip rate is the fraction
of (object, affordance) cases that flip (issue 22's target: at most 3%). ``--dataset procedural`` generates the
core family with ``--objects`` per class (seed 0) in a temporary folder.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from rail_mj.dataset.labels import LabelRecord, read_labels
from rail_mj.dataset.procedural import generate
from rail_mj.dataset.realset import real_data_dir
from rail_mj.imagination import ImaginationConfig
from rail_mj.pipeline import classify
from rail_mj.pipeline.config import ObjectInput, RunConfig


def _verdicts(root: Path, rows: list[LabelRecord], affordances: list[str], scale: float, cfg: RunConfig,
              workers: int | None) -> dict[tuple[str, str], bool | None]:
    """(mesh, affordance) -> functional (None: the case failed) with every mesh read ``scale`` times its size."""
    items = [ObjectInput(path=root / r.mesh, units=r.units * scale, up=r.up, name=r.mesh) for r in rows]
    results = classify(items, affordances, config=cfg.model_copy(update=dict(provider="offline", backend="native")),
                       progress=False, workers=workers)
    return {(r.object, r.requested): None if r.error else r.functional for r in results}


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--dataset", default=None, help="a folder with labels.jsonl, or 'procedural' (default: the "
                    "real-mesh development set, $RAIL_MJ_REAL_DATA or the cache's, built there on first use)")
    ap.add_argument("--objects", type=int, default=None,
                    help="the first N objects of the set (procedural: N per class, default 1)")
    ap.add_argument("--affordances", default=None, help="comma-separated; default: every labelled one")
    ap.add_argument("--scales", type=float, nargs="+", default=[0.9, 1.1])
    ap.add_argument("--perturbations", type=int, default=None, help="K (default: ImaginationConfig's)")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        if args.dataset == "procedural":
            root = Path(tmp)
            generate(root, per_class=args.objects or 1, seed=0)
            rows = read_labels(root / "labels.jsonl")
        else:
            root = Path(args.dataset) if args.dataset is not None else real_data_dir()
            rows = read_labels(root / "labels.jsonl")[: args.objects]
        affordances = (args.affordances.split(",") if args.affordances
                       else sorted({a for r in rows for a in r.affordances}))
        imagination = (ImaginationConfig() if args.perturbations is None
                       else ImaginationConfig(perturbations=args.perturbations))
        cfg = RunConfig(imagination=imagination)
        t = time.perf_counter()
        base = _verdicts(root, rows, affordances, 1.0, cfg, args.workers)
        scaled = {s: _verdicts(root, rows, affordances, s, cfg, args.workers) for s in args.scales}
        seconds = time.perf_counter() - t
    cases = [k for k in base if base[k] is not None and all(v.get(k) is not None for v in scaled.values())]
    flips = {s: sorted(f"{m}::{a}" for m, a in cases if v[(m, a)] != base[(m, a)]) for s, v in scaled.items()}
    flipped = sorted({c for f in flips.values() for c in f})
    out = {
        "dataset": str(args.dataset or real_data_dir()), "objects": len(rows), "cases": len(cases),
        "failed": len(base) - len(cases), "perturbations": imagination.perturbations,
        "flip_rate": len(flipped) / len(cases) if cases else None,
        "flips_per_scale": {str(s): len(f) for s, f in flips.items()}, "flipped": flipped,
        "seconds": round(seconds, 1),
    }
    if args.json:
        print(json.dumps(out))
        return
    rate = "-" if out["flip_rate"] is None else f"{100 * out['flip_rate']:.1f}%"
    print(f"{out['cases']} (object, affordance) cases over {len(rows)} objects, K={imagination.perturbations}, "
          f"{out['failed']} failed: flip rate {rate} under scales {args.scales}")
    for s, f in flips.items():
        print(f"  x{s}: {len(f)} flips" + "".join(f"\n    {c}" for c in f))
    print(f"  {seconds:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
