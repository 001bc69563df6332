"""Cold load time and hull quality of meshes: read, repair, decimate, CoACD, quality guard.

Run on a folder of meshes (metres, z up), on a labels file (``labels.jsonl`` or its folder: the
real-mesh development set, ``python -m rail_mj.dataset real --out DIR``; units and up axis come
from the labels), or, with neither, on four generated household shapes with known cavities::

    python benchmarks/coacd_time.py --labels DIR [--jobs 2] [--limit N]
    python benchmarks/coacd_time.py --dir DIR
    python benchmarks/coacd_time.py

Every run uses a fresh temporary cache, so CoACD really runs. Per mesh it prints the load wall
time (as ``load_object``), the CoACD part of it (wall and CPU), faces in the file, after repair (decimation) and
as CoACD saw them, the hull count, and the quality of the hulls (``rail_mj.mesh.hull_quality``):
the union volume over the mesh volume (closed meshes), the probe-ray excess (hulls standing in
front of the mesh: a filled cavity) and missing (mesh no hull covers); for the generated shapes
also the fraction of sample points inside the cavity that some hull covers (should be ~0). Then
the median and worst load, and the load average, since timing on a shared machine is noisy.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import trimesh
from cpu_time import cpu_seconds  # benchmarks/cpu_time.py, beside this script


def cup(profile_points: int = 20, sections: int = 64) -> trimesh.Trimesh:
    """A ~5.9k-face mug: revolved wall with a 6 mm bottom plus a torus handle."""
    r_out, r_in, height, bottom = 0.04, 0.036, 0.10, 0.006
    outer = np.column_stack([np.full(profile_points, r_out), np.linspace(0, height, profile_points)])
    inner = np.column_stack([np.full(profile_points, r_in), np.linspace(height, bottom, profile_points)])
    body = trimesh.creation.revolve(np.vstack([[0, 0], outer, inner, [0, bottom]]), sections=sections)
    handle = trimesh.creation.torus(0.025, 0.006, major_sections=32, minor_sections=12)
    handle.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    handle.apply_translation([r_out + 0.012, 0, height / 2])
    return trimesh.util.concatenate([body, handle])


def bowl(sections: int = 48) -> trimesh.Trimesh:
    """A hemispherical bowl shell, 16 cm wide."""
    t = np.linspace(0, np.pi / 2, 12)
    outer = np.column_stack([0.08 * np.sin(t), 0.08 - 0.08 * np.cos(t)])
    inner = np.column_stack([0.074 * np.sin(t[::-1]), 0.08 - 0.074 * np.cos(t[::-1])])
    return trimesh.creation.revolve(np.vstack([outer, inner]), sections=sections)


def open_cup(sections: int = 64) -> trimesh.Trimesh:
    """A single-surface cup (no wall thickness, open top): not a closed volume, so CoACD remeshes it."""
    profile = np.vstack([[0, 0], np.column_stack([np.full(30, 0.04), np.linspace(0, 0.1, 30)])])
    return trimesh.creation.revolve(profile, sections=sections)


def stool() -> trimesh.Trimesh:
    """A 45 cm stool: seat slab on four legs."""
    parts = [
        trimesh.creation.box(
            extents=(0.4, 0.4, 0.04), transform=trimesh.transformations.translation_matrix([0, 0, 0.43])
        )
    ]
    for x in (-0.17, 0.17):
        for y in (-0.17, 0.17):
            parts.append(
                trimesh.creation.cylinder(
                    0.02, 0.41, sections=16, transform=trimesh.transformations.translation_matrix([x, y, 0.205])
                )
            )
    return trimesh.util.concatenate(parts)


def cavity_samples(radius: float, z_lo: float, z_hi: float, n: int = 500) -> np.ndarray:
    """Points uniformly inside a vertical cylinder (a cup's cavity), fixed seed."""
    rng = np.random.default_rng(0)
    r, theta = radius * np.sqrt(rng.random(n)), rng.random(n) * 2 * np.pi
    return np.column_stack([r * np.cos(theta), r * np.sin(theta), rng.uniform(z_lo, z_hi, n)])


@dataclass(frozen=True)
class Item:
    name: str
    path: Path | None = None  # a mesh file, or None for a generated shape
    units: float = 1.0
    up: str = "z"


# Generated shapes and the cavity each should keep open.
GENERATED = {
    "cup": (cup, (0.034, 0.01, 0.095)),
    "bowl": (bowl, (0.05, 0.03, 0.075)),
    "open_cup": (open_cup, (0.034, 0.01, 0.095)),
    "stool": (stool, None),
}


def items_from(args: argparse.Namespace) -> list[Item]:
    from rail_mj.dataset.labels import read_labels
    from rail_mj.mesh import SUPPORTED_EXTENSIONS

    if args.labels:
        root = args.labels if args.labels.is_dir() else args.labels.parent
        return [
            Item(Path(r.mesh).stem, r.mesh_path(root), r.units, r.up) for r in read_labels(args.labels)
        ]
    if args.dir:
        files = sorted(p for p in args.dir.iterdir() if p.suffix.lower() in SUPPORTED_EXTENSIONS)
        return [Item(p.stem, p) for p in files]
    return [Item(name) for name in GENERATED]


def measure(item: Item) -> dict:
    """Load one object cold (the cache is empty) and measure its hulls."""
    from rail_mj.mesh import coacd_run, decomposition, hull_quality, load_object, mesh_notes, object_from_mesh

    seen: dict[str, float] = {"coacd_s": 0.0, "coacd_cpu_s": 0.0, "coacd_faces": 0}

    def spent() -> float:  # this process's, its finished children's, and its CoACD runs' (the servers reap those)
        return cpu_seconds() + coacd_run.cpu_seconds()
    run_coacd = decomposition._run_coacd

    def timed_coacd(mesh, config):
        t, cpu = time.perf_counter(), coacd_run.cpu_seconds()
        try:
            return run_coacd(mesh, config)
        finally:
            seen["coacd_s"] += time.perf_counter() - t
            seen["coacd_cpu_s"] += coacd_run.cpu_seconds() - cpu  # CoACD runs in children of a kept server
            seen["coacd_faces"] = len(mesh.faces)

    decomposition._run_coacd = timed_coacd
    t, cpu = time.perf_counter(), spent()
    if item.path is None:
        raw = GENERATED[item.name][0]()
        faces_in = len(raw.faces)
        obj = object_from_mesh(raw, name=item.name)
    else:
        faces_in = len(trimesh.load(item.path, force="mesh", process=False).faces)
        t, cpu = time.perf_counter(), spent()
        obj = load_object(item.path, units=item.units, up=item.up, name=item.name)  # type: ignore[arg-type]
    load_s, cpu_s = time.perf_counter() - t, spent() - cpu
    decomposition._run_coacd = run_coacd
    t = time.perf_counter()
    quality = hull_quality(obj.mesh, obj.hulls)
    quality_s = time.perf_counter() - t
    covered = None
    if item.path is None and GENERATED[item.name][1] is not None:
        cavity = cavity_samples(*GENERATED[item.name][1])
        covered = float(np.any([trimesh.convex.convex_hull(h).contains(cavity) for h in obj.hulls], axis=0).mean())
    return {
        "name": item.name,
        "faces_in": faces_in,
        "faces": len(obj.mesh.faces),
        "coacd_faces": int(seen["coacd_faces"]),
        "closed": bool(obj.mesh.is_volume),
        "extent": float(np.ptp(obj.mesh.bounds, axis=0).max()),
        "load_s": load_s,
        "cpu_s": cpu_s,
        "coacd_s": seen["coacd_s"],
        "coacd_cpu_s": seen["coacd_cpu_s"],
        "quality_s": quality_s,
        "hulls": quality.n_hulls,
        "volume_ratio": quality.volume_ratio,
        "excess": quality.excess,
        "missing": quality.missing,
        "covered": covered,
        "notes": mesh_notes(obj.mesh),
    }


def run_one(item: Item, mem_gb: float, timeout_s: float) -> dict:
    """:func:`measure` in a child process under an address-space cap, so a CoACD blow-up fails one mesh."""

    def cap() -> None:
        limit = int(mem_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    t = time.perf_counter()
    try:
        done = subprocess.run(
            [sys.executable, __file__, "--worker", json.dumps(asdict(item), default=str)],
            capture_output=True, text=True, timeout=timeout_s, preexec_fn=cap, check=False,
        )
    except subprocess.TimeoutExpired:
        return {"name": item.name, "error": f"no result within {timeout_s:.0f} s", "load_s": time.perf_counter() - t}
    lines = done.stdout.strip().splitlines()
    if done.returncode == 0 and lines:
        return json.loads(lines[-1])
    why = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
    return {"name": item.name, "error": why[:200], "load_s": time.perf_counter() - t}


def _fmt(x: float | None, spec: str) -> str:
    return "-" if x is None else format(x, spec)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--labels", type=Path, help="labels.jsonl, or the folder holding it (units, up from it)")
    source.add_argument("--dir", type=Path, help="a folder of mesh files in metres, z up")
    parser.add_argument("--jobs", type=int, default=1, help="objects loaded at once, each in its own process")
    parser.add_argument("--limit", type=int, default=0, help="only the first N meshes")
    parser.add_argument("--mem-gb", type=float, default=6.0, help="address-space cap of each mesh's process")
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds one mesh may take")
    parser.add_argument(
        "--cache", type=Path, help="hull cache to use (default: a fresh one, so every load is cold); a second "
        "run with the first one's cache measures the quality of its hulls again without CoACD"
    )
    parser.add_argument("--worker", help=argparse.SUPPRESS)  # one item as JSON: measure it, print the row as JSON
    args = parser.parse_args(argv)
    if args.worker:
        item = json.loads(args.worker)
        item["path"] = item["path"] and Path(item["path"])
        print(json.dumps(measure(Item(**item))))
        return 0
    os.environ["RAIL_MJ_CACHE"] = str(args.cache or tempfile.mkdtemp(prefix="rail_mj_coacd_bench_"))
    items = items_from(args)[: args.limit or None]
    print(
        f"{len(items)} meshes, {args.jobs} at once, cache {os.environ['RAIL_MJ_CACHE']}, load average before: "
        f"{os.getloadavg()}",
        flush=True,
    )
    header = (
        f"{'mesh':22s} {'faces_in':>8s} {'faces':>6s} {'coacd_f':>7s} {'closed':>6s} {'size_m':>6s} "
        f"{'load_s':>7s} {'cpu_s':>7s} {'coacd_s':>7s} {'co_cpu':>6s} {'qual_s':>6s} {'hulls':>5s} {'vol':>5s} "
        f"{'excess':>6s} {'missing':>7s} {'cavity':>6s}"
    )
    print(header, flush=True)
    rows = []
    wall = time.perf_counter()
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for r in pool.map(lambda item: run_one(item, args.mem_gb, args.timeout), items):
            rows.append(r)
            if "error" in r:
                print(f"{r['name'][:22]:22s} failed after {r['load_s']:.1f} s: {r['error']}", flush=True)
                continue
            print(
                f"{r['name'][:22]:22s} {r['faces_in']:8d} {r['faces']:6d} {r['coacd_faces']:7d} "
                f"{'yes' if r['closed'] else 'no':>6s} {r['extent']:6.3f} {r['load_s']:7.1f} {r['cpu_s']:7.1f} "
                f"{r['coacd_s']:7.1f} {r['coacd_cpu_s']:6.1f} "
                f"{r['quality_s']:6.2f} {r['hulls']:5d} {_fmt(r['volume_ratio'], '5.2f')} {r['excess']:6.3f} "
                f"{r['missing']:7.3f} {_fmt(r['covered'], '6.3f')}",
                flush=True,
            )
    wall = time.perf_counter() - wall
    failed = [r for r in rows if "error" in r]
    rows = [r for r in rows if "error" not in r]
    if not rows:
        print(f"every mesh failed ({len(failed)})")
        return 1
    loads, cpus = [r["load_s"] for r in rows], [r["cpu_s"] for r in rows]
    worst = max(rows, key=lambda r: r["load_s"])
    print(
        f"load per mesh: median {statistics.median(loads):.1f} s, mean {statistics.mean(loads):.1f} s, "
        f"worst {worst['load_s']:.1f} s ({worst['name']}); CPU median {statistics.median(cpus):.1f} s, "
        f"worst {max(cpus):.1f} s; {len(rows)} loaded, {len(failed)} failed, {wall:.0f} s wall"
    )
    coacd, coacd_cpu = [r["coacd_s"] for r in rows], [r["coacd_cpu_s"] for r in rows]
    print(
        f"CoACD per mesh: wall median {statistics.median(coacd):.1f} s, worst {max(coacd):.1f} s; CPU median "
        f"{statistics.median(coacd_cpu):.1f} s, worst {max(coacd_cpu):.1f} s, total {sum(coacd_cpu):.0f} s; load CPU "
        f"total {sum(cpus):.0f} s; {sum(c == 0 for c in coacd_cpu)} meshes without a CoACD run"
    )
    ratios = [r["volume_ratio"] for r in rows if r["volume_ratio"] is not None]
    if ratios:
        print(f"volume ratio (closed meshes): min {min(ratios):.2f}, median {statistics.median(ratios):.2f}, "
              f"max {max(ratios):.2f}")
    print(f"excess: worst {max(r['excess'] for r in rows):.3f}; missing: worst {max(r['missing'] for r in rows):.3f}")
    for r in rows:
        for note in r["notes"]:
            print(f"note {r['name']}: {note}")
    for r in failed:
        print(f"failed {r['name']}: {r['error']}")
    print(f"load average after: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
