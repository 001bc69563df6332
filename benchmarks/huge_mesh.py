"""Time the one-object CLI end to end on a huge mesh: a torus PLY of about 2M faces.

Run: ``python benchmarks/huge_mesh.py [--faces 2000000] [--affordance cup] [--cpus 2]``.
It writes the torus (16 cm across, 4 cm thick: it passes a cup's dimension check, so the whole
imagination runs) into a temporary folder, runs ``python -m rail_mj MESH -a cup --json`` in a
subprocess with a fresh cache (CoACD really runs) and prints the wall time, whether the mesh was
classified (and how it was decimated) or refused, the stage timings and the child's peak RSS.
Meshes over ``rail_mj.mesh.FACE_BUDGET`` faces are decimated, over ``MAX_FACES`` refused.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh


def torus_ply(path: Path, faces: int) -> int:
    """Write a closed torus grid with about ``faces`` triangles (2 per cell); return the exact count.

    Built here rather than with trimesh.creation.torus, whose processing drops faces of fine grids.
    """
    n = max(3, round(math.sqrt(faces / 2)))
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, n, endpoint=False), np.linspace(0, 2 * np.pi, n, endpoint=False),
                       indexing="ij")
    ring = 0.06 + 0.02 * np.cos(v)
    vertices = np.column_stack([(ring * np.cos(u)).ravel(), (ring * np.sin(u)).ravel(), (0.02 * np.sin(v)).ravel()])
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a, b = i * n + j, ((i + 1) % n) * n + j
    c, d = ((i + 1) % n) * n + (j + 1) % n, i * n + (j + 1) % n
    tris = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    trimesh.Trimesh(vertices, tris, process=False).export(path)
    return len(tris)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--faces", type=int, default=2_000_000, help="torus faces (default 2,000,000)")
    parser.add_argument("--affordance", default="cup")
    parser.add_argument("--cpus", type=int, help="pin the CLI to this many CPU cores (default: all)")
    parser.add_argument("--timeout", type=float, default=600.0, help="kill the CLI after this many seconds")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory(prefix="rail_mj_huge_") as tmp:
        mesh = Path(tmp) / "torus.ply"
        n_faces = torus_ply(mesh, args.faces)
        print(f"mesh: {mesh.name}, {n_faces:,} faces, {mesh.stat().st_size / 2**20:.1f} MiB")
        env = {**os.environ, "RAIL_MJ_CACHE": str(Path(tmp) / "cache"), "RAIL_MJ_NO_CACHE": "1"}
        cpus = sorted(os.sched_getaffinity(0))[: args.cpus] if args.cpus else None
        cmd = [sys.executable, "-m", "rail_mj", str(mesh), "-a", args.affordance, "--json", "--provider", "offline"]
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(
                cmd, env=env, capture_output=True, text=True, timeout=args.timeout,
                preexec_fn=(lambda: os.sched_setaffinity(0, cpus)) if cpus else None,
            )
        except subprocess.TimeoutExpired:
            print(f"HUNG: killed after {args.timeout:.0f} s")
            return 1
        wall = time.perf_counter() - t0
    peak_mib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # KiB on Linux
    lines = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    print(f"cores: {len(cpus) if cpus else os.cpu_count()}, exit status {proc.returncode}")
    print(f"wall time: {wall:.1f} s, peak RSS of the CLI: {peak_mib:.0f} MiB")
    for r in lines:
        if "requested" not in r:  # the CLI's own error object
            print(f"refused: {r['type']}: {r['error']}")
        elif r["error"]:
            print(f"refused: {r['error']}")
        else:
            print(f"classified: {r['requested']!r} -> {'FUNCTIONAL' if r['functional'] else 'not functional'}"
                  f" (dims_fit {r['dims_fit']})")
            for note in r["mesh_notes"]:
                print(f"  mesh: {note}")
            print("  timings: " + ", ".join(f"{k} {v:.1f} s" for k, v in r["timings"].items()))
    if not lines:
        print(proc.stderr[-2000:])
    return 0 if lines else 1


if __name__ == "__main__":
    sys.exit(main())
