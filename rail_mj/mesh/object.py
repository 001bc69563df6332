"""The object: a RailObject from a mesh (repaired, decomposed with the quality guard, measured) or a mesh file.

Every in-memory mesh entering rail_mj goes through :func:`object_from_mesh`; it repairs and
validates it the same way :func:`~rail_mj.mesh.read.load_mesh` does files, so the mesh frame is
always metres, z up.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Literal, cast

import numpy as np
import trimesh

from rail_mj.core.errors import ConfigError
from rail_mj.core.types import RailObject
from rail_mj.mesh.decomposition import DecompositionConfig, decompose, mesh_hash, second_decomposition
from rail_mj.mesh.quality import _guarded_hulls
from rail_mj.mesh.read import load_mesh
from rail_mj.mesh.repair import _NOTES_KEY, mesh_notes, repair_mesh

__all__ = ["DEFAULT_DENSITY", "object_from_mesh", "object_from_parts", "load_object", "redecomposed"]

#: kg/m^3; a household-object average (wood ~500-700, plastic shells less) — mass matters for tipping.
DEFAULT_DENSITY = 500.0


def _mass_properties(mesh: trimesh.Trimesh, hulls: tuple[np.ndarray, ...]) -> tuple[float, np.ndarray]:
    """Volume and centre of mass: the mesh's own when it encloses a volume, else the hulls'."""
    if mesh.is_volume:
        return float(mesh.volume), np.asarray(mesh.center_mass, dtype=np.float64)
    vols, centres = [], []
    for h in hulls:
        hm = trimesh.convex.convex_hull(h)
        vols.append(hm.volume)
        centres.append(hm.center_mass)
    vols_arr = np.asarray(vols)
    return float(vols_arr.sum()), (np.asarray(centres) * vols_arr[:, None]).sum(0) / vols_arr.sum()


def object_from_mesh(
    mesh: trimesh.Trimesh,
    *,
    name: str,
    density: float = DEFAULT_DENSITY,
    decomposition: DecompositionConfig | None = None,
    source: str = "",
) -> RailObject:
    """Repair, decompose and measure an in-memory mesh (metres, z up).

    ``decomposition`` None: :func:`decomposition_for` the mesh, with the quality guard
    (:func:`hull_quality`; what it did or found is in :func:`mesh_notes`).
    """
    if not (np.isfinite(density) and density > 0):
        raise ConfigError(f"density must be a positive finite number in kg/m^3, got {density}")
    if not name:
        raise ConfigError("name must be a non-empty string")
    mesh = repair_mesh(mesh, label=source or name)
    hulls, notes = _guarded_hulls(mesh, decomposition)
    if notes:
        mesh.metadata[_NOTES_KEY] = mesh_notes(mesh) + notes
    volume, com = _mass_properties(mesh, hulls)
    obb_dims = np.sort(np.asarray(mesh.bounding_box_oriented.primitive.extents, dtype=np.float64))[::-1]
    return RailObject(
        name=name,
        mesh=mesh,
        hulls=hulls,
        mesh_hash=mesh_hash(mesh),
        obb_dims=obb_dims.copy(),
        com=com,
        mass=float(volume * density),
        density=float(density),
        source=source,
    )


def load_object(
    path: str | Path,
    *,
    units: float = 1.0,
    up: Literal["z", "y"] = "z",
    density: float = DEFAULT_DENSITY,
    decomposition: DecompositionConfig | None = None,
    name: str | None = None,
) -> RailObject:
    """Load a mesh file into a RailObject (name defaults to the file stem)."""
    path = Path(path)
    mesh = load_mesh(path, units=units, up=up)
    return object_from_mesh(
        mesh, name=name or path.stem, density=density, decomposition=decomposition, source=str(path)
    )


def redecomposed(obj: RailObject) -> RailObject:
    """``obj`` with the hulls of its second decomposition (:func:`second_decomposition`, cached like the first):
    the same mesh, mass and centre of mass; only the convex hulls the physics collides differ."""
    return dataclasses.replace(obj, hulls=decompose(obj.mesh, second_decomposition(obj.mesh)))


def object_from_parts(name: str, hulls: list[np.ndarray] | tuple[np.ndarray, ...], density: float = 600.0
                      ) -> RailObject:
    """An object whose convex parts are given (vertex arrays; mesh frame as given): its hulls are the parts, no
    decomposition (demo objects, prototypes)."""
    hulls = tuple(np.asarray(h, float) for h in hulls)
    mesh = cast(trimesh.Trimesh, trimesh.util.concatenate([trimesh.convex.convex_hull(h) for h in hulls]))
    volume = float(sum(trimesh.convex.convex_hull(h).volume for h in hulls))
    # content hash: stable poses are cached by it, so a resized demo object must not reuse old ones
    return RailObject(name=name, mesh=mesh, hulls=hulls, mesh_hash=mesh_hash(mesh),
                      obb_dims=np.sort(mesh.extents)[::-1].copy(), com=np.asarray(mesh.center_mass, float),
                      mass=volume * density, density=density)
