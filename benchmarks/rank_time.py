"""``--rank`` against one affordance, with hulls and stable poses cached: the wall time of each, side by side.

    python benchmarks/rank_time.py [--mesh MESH --units U --up z|y] [--affordance cup] [--json P]

Without ``--mesh`` it ranks a generated mug (the dataset's ``cup`` builder, seed 0). A first, untimed
classification fills the hull and stable-pose cache (a temporary one unless ``--cache`` names one); then it
times one affordance, then ``rank`` over every registered affordance, each in this process with
``workers=1``, and prints both, their ratio (the issue's target: at most 4) and where the rank's time went.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mesh", type=Path)
    p.add_argument("--units", type=float, default=1.0)
    p.add_argument("--up", choices=("z", "y"), default="z")
    p.add_argument("--affordance", default="cup", help="the single affordance timed against the rank")
    p.add_argument("--cache", type=Path, help="cache folder (default: a fresh temporary one)")
    p.add_argument("--json", type=Path, metavar="P")
    args = p.parse_args()
    os.environ["RAIL_MJ_CACHE"] = str(args.cache or tempfile.mkdtemp(prefix="rank_time_"))

    import numpy as np

    from rail_mj.affordances.registry import known_affordances
    from rail_mj.dataset import shapes
    from rail_mj.pipeline.chain import classify
    from rail_mj.pipeline.config import ObjectInput
    from rail_mj.pipeline.rank import rank

    mesh = args.mesh
    if mesh is None:
        mesh = Path(tempfile.mkdtemp(prefix="rank_mesh_")) / "mug.stl"
        shapes.GENERATORS["cup"](np.random.default_rng(0)).mesh.export(mesh)
    item = ObjectInput(path=mesh, units=args.units, up=args.up)
    options = dict(provider="offline", workers=1, progress=False)
    classify([item], [args.affordance], **options)  # fills the hull and stable-pose cache

    t = time.perf_counter()
    one = classify([item], [args.affordance], **options)[0]
    t_one = time.perf_counter() - t
    names = known_affordances()
    t = time.perf_counter()
    ranking = rank([item], names, **options)[0]
    t_rank = time.perf_counter() - t

    stages: dict[str, float] = {}
    for r in ranking.results:
        for k, v in r.timings.items():
            if k not in ("load", "stable_poses"):
                stages[k] = stages.get(k, 0.0) + v
    print(f"mesh {mesh.name}; hulls and stable poses cached; offline provider, native backend, workers=1")
    print(f"one affordance ({args.affordance}): {t_one:.2f} s  (probability {one.probability:.2f})")
    print(f"rank over {len(names)} affordances: {t_rank:.2f} s  = {t_rank / t_one:.2f}x one (target <= 4x)")
    print("rank time by stage (s): " + ", ".join(f"{k} {v:.2f}" for k, v in sorted(stages.items())))
    print("top 5: " + ", ".join(f"{r.affordance} {r.probability:.2f}" for r in ranking.results[:5]))
    if args.json:
        args.json.write_text(json.dumps({"mesh": str(mesh), "one_s": t_one, "rank_s": t_rank,
                                         "ratio": t_rank / t_one, "affordances": len(names), "stages": stages,
                                         "ranking": [[r.affordance, r.probability, r.functional]
                                                     for r in ranking.results]}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
