"""Time and accuracy of the simulated wrist-camera scan (``rail_mj.robot.scan``) on generated objects.

Scans the robot demo's table-top objects (``rail_mj.robot.demo.make_object``) and the procedural dataset's
table-top generators (``rail_mj.dataset.shapes.GENERATORS``), each standing upright on the robot's table, and prints
per object the seconds of each phase (plan: IK for the views; render; fuse: TSDF; extract: plane, cluster,
mesh, carving, cap), the scan total, the Chamfer distance to the true mesh (mm), the views used and the
bounding-box error, then the median and worst. Objects larger than the fused workspace are listed apart::

    python benchmarks/scan_time.py [--demo cup,bowl] [--shapes cup,vase] [--noise 0.002 --dropout 0.1
                                    --edge-dropout 0.5] [--json out.json]

Needs the ``[scan]`` extra (``pip install -e '.[scan]'``); headless rendering uses ``MUJOCO_GL=egl``.
Timing on a shared machine is noisy: the load average is printed with the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

from rail_mj.core.types import RailObject  # noqa: E402
from rail_mj.dataset.shapes import GENERATORS  # noqa: E402
from rail_mj.mesh import mesh_hash  # noqa: E402
from rail_mj.robot.demo import make_object, upright_pose  # noqa: E402
from rail_mj.robot.scan import ScanConfig, ScanError, scan_object, true_mesh_world  # noqa: E402

DEMO = ("cup", "bowl", "vase", "pen_holder", "pot", "basket", "tray", "plate", "stool", "chair", "table")
SHAPES = ("cup", "bowl", "vase", "plate", "pot", "tray", "goblet", "saucepan", "bowl_real", "ashtray")


def _shape_object(kind: str, seed: int) -> RailObject:
    """A generated mesh as an object for the scan, which needs only its surface (no CoACD hulls)."""
    mesh = GENERATORS[kind](np.random.default_rng(seed)).mesh
    return RailObject(name=f"{kind}_{seed}", mesh=mesh, hulls=(), mesh_hash=mesh_hash(mesh),
                      obb_dims=np.sort(mesh.extents)[::-1].copy(), com=np.asarray(mesh.centroid), mass=1.0,
                      density=600.0)


def _fits(obj: RailObject, config: ScanConfig) -> bool:
    half = np.asarray(config.workspace_half)
    ext = np.asarray(obj.mesh.extents)
    return bool(np.all(ext[:2] / 2 < half[:2] - 0.01) and ext[2] < half[2] - 0.01)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--demo", default=",".join(DEMO), help="demo object kinds, comma separated ('' for none)")
    parser.add_argument("--shapes", default=",".join(SHAPES), help="rail_mj.dataset.shapes generators ('' for none)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--noise", type=float, default=0.0, help="depth noise, standard deviation per metre")
    parser.add_argument("--dropout", type=float, default=0.0)
    parser.add_argument("--edge-dropout", type=float, default=0.0)
    parser.add_argument("--json", type=Path, help="write the rows and the summary here")
    args = parser.parse_args(argv)
    unknown = [k for k in filter(None, args.shapes.split(",")) if k not in GENERATORS]
    if unknown:
        parser.error(f"unknown shapes {unknown}; known: {', '.join(GENERATORS)}")
    config = ScanConfig(depth_noise=args.noise, dropout=args.dropout, edge_dropout=args.edge_dropout,
                        seed=args.seed)
    objects = [("demo", make_object(k, args.seed)) for k in filter(None, args.demo.split(","))]
    objects += [("shapes", _shape_object(k, args.seed)) for k in filter(None, args.shapes.split(","))]

    rows, too_big, failed = [], [], []
    print(f"{'object':24s} {'plan':>5s} {'render':>6s} {'fuse':>5s} {'extract':>7s} {'scan s':>6s} "
          f"{'chamfer mm':>10s} {'views':>5s}  bbox error mm")
    for source, obj in objects:
        label = f"{source}:{obj.name}"
        if not _fits(obj, config):
            too_big.append(f"{label} ({np.round(obj.mesh.extents, 3).tolist()} m)")
            continue
        pose = upright_pose(obj)
        try:
            result = scan_object(obj, pose, config)
        except ScanError as exc:
            failed.append(f"{label}: {exc}")
            print(f"{label:24s} failed: {exc}")
            continue
        err = 1000 * (np.asarray(result.mesh.extents) - np.asarray(true_mesh_world(obj, pose).extents))
        s = result.seconds
        rows.append({"object": label, **result.to_dict(), "bbox_error_mm": err.tolist()})
        print(f"{label:24s} {s['plan']:5.2f} {s['render']:6.2f} {s['fuse']:5.2f} {s['extract']:7.2f} "
              f"{result.scan_seconds:6.2f} {1000 * result.chamfer_m:10.2f} {result.n_views:5d}  "
              f"{np.round(err, 1).tolist()}")
    summary: dict = {"objects": len(rows), "too_big": too_big, "failed": failed, "load_average": os.getloadavg(),
                     "config": config.model_dump(exclude={"robot"})}
    if rows:
        secs = [r["scan_seconds"] for r in rows]
        cham = [r["chamfer_mm"] for r in rows]
        summary.update(scan_seconds_median=statistics.median(secs), scan_seconds_worst=max(secs),
                       chamfer_mm_median=statistics.median(cham), chamfer_mm_worst=max(cham))
        for phase in ("plan", "render", "fuse", "extract"):
            summary[f"{phase}_seconds_median"] = statistics.median(r["seconds"][phase] for r in rows)
        print(f"\n{len(rows)} objects: scan {summary['scan_seconds_median']:.2f} s median, "
              f"{summary['scan_seconds_worst']:.2f} s worst (target 10 s); Chamfer "
              f"{summary['chamfer_mm_median']:.2f} mm median, {summary['chamfer_mm_worst']:.2f} mm worst")
        print("phase medians: " + ", ".join(f"{p} {summary[f'{p}_seconds_median']:.2f} s"
                                            for p in ("plan", "render", "fuse", "extract")))
    for line in too_big:
        print(f"larger than the workspace {config.workspace_half} m, not scanned: {line}")
    print(f"load average {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "summary": summary}, indent=1))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
