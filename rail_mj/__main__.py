"""``python -m rail_mj MESH --affordance NAME``: one object, one verdict, for people."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from rail_mj.errors import RailError

__all__ = ["main"]


def _describe(r) -> str:
    lines = [f"{r.object}: {r.requested!r} -> {'FUNCTIONAL' if r.functional else 'not functional'}"]
    if r.error:
        return f"{r.object}: {r.requested!r} -> error: {r.error}"
    if not r.dims_fit:
        lines.append(f"  dimension check failed: {'; '.join(r.analyzer_reasons)}")
        if r.alternative:
            lines.append(f"  the analyser suggests: {r.alternative}")
    if r.functional_pose is not None:
        p = r.functional_pose
        lines.append(
            f"  functional pose #{p.index} (p={p.probability:.2f}): pos {[round(v, 3) for v in p.pos]}, "
            f"quat {[round(v, 3) for v in p.quat]}, mesh up {[round(v, 2) for v in p.up_in_mesh_frame]}"
        )
    if r.best_plan is not None:
        lines.append(f"  best interaction: {r.best_plan.name} (score {r.best_plan.score:.2f}): {r.best_plan.description}")
    for reason in r.analyzer_reasons if r.dims_fit else []:
        lines.append(f"  analyser: {reason}")
    lines.append("  timings: " + ", ".join(f"{k} {v:.2f}s" for k, v in r.timings.items()))
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m rail_mj", description=__doc__)
    p.add_argument("mesh", type=Path, help="OBJ, STL, PLY, OFF, GLB or GLTF file")
    p.add_argument("--affordance", "-a", action="append", required=True, help="requested use; repeat for several")
    p.add_argument("--units", type=float, default=1.0, help="metres per mesh unit (0.001 for millimetres)")
    p.add_argument("--up", choices=("z", "y"), default="z", help="the mesh's up axis")
    p.add_argument("--provider", default="auto", help="auto | offline | anthropic")
    p.add_argument("--backend", default="auto", help="auto | native | mjx")
    p.add_argument("--json", action="store_true", help="print the results as JSON lines")
    p.add_argument("--render", type=Path, help="write a PNG of the functional pose with the agents")
    args = p.parse_args(argv)

    from rail_mj.pipeline import ObjectInput, classify

    try:
        results = classify(
            [ObjectInput(path=args.mesh, units=args.units, up=args.up)],
            args.affordance,
            provider=args.provider,
            backend=args.backend,
            progress=False,
        )
        for r in results:
            print(r.model_dump_json() if args.json else _describe(r))
        if args.render:
            from rail_mj.render import render_result

            shown = next((r for r in results if r.functional), results[0])
            render_result(args.mesh, shown, args.render, units=args.units, up=args.up)
            print(f"wrote {args.render}", file=sys.stderr)
    except RailError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0 if all(r.error is None for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
