"""Time one CoACD decomposition (default DecompositionConfig) of generated household shapes.

Run: ``python benchmarks/coacd_time.py`` (uses a fresh temporary cache, so
CoACD really runs). Prints wall and CPU seconds, hull count, max hull
vertices, total hull volume over mesh volume, and for shapes with a cavity the
fraction of cavity sample points some hull covers (should be ~0: hulls that
fill a cup's inside make it hold nothing).
"""

from __future__ import annotations

import os
import tempfile
import time

import numpy as np
import trimesh


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


def main() -> None:
    os.environ["RAIL_MJ_CACHE"] = tempfile.mkdtemp(prefix="rail_mj_coacd_bench_")
    from rail_mj.objects import DecompositionConfig, decompose, repair_mesh

    config = DecompositionConfig()
    print(f"config: {config}")
    print(
        f"{'shape':8s} {'faces':>6s} {'wall_s':>7s} {'cpu_s':>7s} {'hulls':>5s} {'max_v':>5s} "
        f"{'hull_vol/mesh_vol':>17s} {'cavity_covered':>14s}"
    )
    shapes = (
        ("cup", cup(), cavity_samples(0.034, 0.01, 0.095)),
        ("bowl", bowl(), cavity_samples(0.05, 0.03, 0.075)),
        ("open_cup", open_cup(), cavity_samples(0.034, 0.01, 0.095)),
        ("stool", stool(), None),
    )
    for name, mesh, cavity in shapes:
        mesh = repair_mesh(mesh, label=name)
        wall, cpu = time.perf_counter(), time.process_time()
        hulls = decompose(mesh, config)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        hull_meshes = [trimesh.convex.convex_hull(h) for h in hulls]
        hull_volume = sum(h.volume for h in hull_meshes)
        covered = "-"
        if cavity is not None:
            covered = f"{np.any([h.contains(cavity) for h in hull_meshes], axis=0).mean():.3f}"
        print(
            f"{name:8s} {len(mesh.faces):6d} {wall:7.1f} {cpu:7.1f} {len(hulls):5d} "
            f"{max(len(h) for h in hulls):5d} {hull_volume / abs(mesh.volume):17.2f} {covered:>14s}",
            flush=True,
        )


if __name__ == "__main__":
    main()
