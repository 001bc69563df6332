"""Meshes: read, repair, decompose into convex hulls (CoACD in child processes), hull quality, the object.

:mod:`~rail_mj.mesh.read` reads mesh files, :mod:`~rail_mj.mesh.repair` cleans, decimates and checks
meshes, :mod:`~rail_mj.mesh.decomposition` makes and caches convex hulls, :mod:`~rail_mj.mesh.quality`
judges them, and :mod:`~rail_mj.mesh.object` builds a :class:`~rail_mj.core.types.RailObject`.
"""

from rail_mj.mesh.decomposition import (
    DENSE_DECOMPOSITION,
    DENSE_FACES,
    GUARD_DECOMPOSITION,
    MJX_MAX_HULL_VERTICES,
    DecompositionConfig,
    decompose,
    decomposition_for,
    mesh_hash,
    reduce_hull,
    second_decomposition,
)
from rail_mj.mesh.object import DEFAULT_DENSITY, load_object, object_from_mesh, object_from_parts, redecomposed
from rail_mj.mesh.quality import MAX_EXCESS, MAX_MISSING, HullQuality, hull_quality
from rail_mj.mesh.read import MAX_FILE_BYTES, SUPPORTED_EXTENSIONS, load_mesh
from rail_mj.mesh.repair import FACE_BUDGET, MAX_EXTENT, MAX_FACES, MIN_EXTENT, mesh_notes, repair_mesh

__all__ = [
    "SUPPORTED_EXTENSIONS",
    "DEFAULT_DENSITY",
    "MAX_EXTENT",
    "MIN_EXTENT",
    "MJX_MAX_HULL_VERTICES",
    "FACE_BUDGET",
    "MAX_FACES",
    "MAX_FILE_BYTES",
    "DENSE_FACES",
    "DENSE_DECOMPOSITION",
    "GUARD_DECOMPOSITION",
    "MAX_EXCESS",
    "MAX_MISSING",
    "DecompositionConfig",
    "decomposition_for",
    "second_decomposition",
    "load_mesh",
    "repair_mesh",
    "mesh_notes",
    "mesh_hash",
    "decompose",
    "reduce_hull",
    "HullQuality",
    "hull_quality",
    "object_from_mesh",
    "object_from_parts",
    "load_object",
    "redecomposed",
]
