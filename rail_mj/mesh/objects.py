"""Objects: mesh loading and repair, CoACD convex decomposition (cached), RailObject construction.

Every mesh entering rail_mj goes through :func:`load_mesh` (files) or
:func:`object_from_mesh` (in-memory meshes); both repair and validate it the
same way, so the mesh frame is always metres, z up.

Meshes over :data:`FACE_BUDGET` faces are decimated (closed ones by manifold3d, so they stay
closed; others by quadric decimation, trimesh's ``simplify_quadric_decimation`` backed by
fast-simplification) before any step whose cost grows faster than the face count;
:func:`mesh_notes` says what was done. Meshes over :data:`MAX_FACES` faces or files over
:data:`MAX_FILE_BYTES` are refused at once.

Decomposition: a mesh of separate bodies is decomposed body by body; meshes over
:data:`DENSE_FACES` faces get faster CoACD settings (:func:`decomposition_for`); every object's
hulls pass a quality guard (:func:`hull_quality`: volume ratio, cavities kept open, surface
covered) in :func:`object_from_mesh`.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import re
import signal
import subprocess
import sys
import zipfile
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from rail_mj.core.errors import ConfigError, DecompositionError, DecompositionTimeout, MeshError
from rail_mj.core.paths import cache_dir
from rail_mj.core.types import RailObject

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
    "MAX_EXCESS",
    "MAX_MISSING",
    "DecompositionConfig",
    "decomposition_for",
    "load_mesh",
    "repair_mesh",
    "mesh_notes",
    "mesh_hash",
    "decompose",
    "reduce_hull",
    "HullQuality",
    "hull_quality",
    "object_from_mesh",
    "load_object",
]

SUPPORTED_EXTENSIONS: tuple[str, ...] = (".obj", ".stl", ".ply", ".off", ".glb", ".gltf")
#: kg/m^3; a household-object average (wood ~500-700, plastic shells less) — mass matters for tipping.
DEFAULT_DENSITY = 500.0
#: Largest allowed extent after scaling, metres.
MAX_EXTENT = 10.0
#: Smallest allowed largest-extent after scaling, metres.
MIN_EXTENT = 0.005
#: MJX's convex collision caps hull vertices at 64.
MJX_MAX_HULL_VERTICES = 64
#: Meshes with more faces are decimated to this many before repair and decomposition. CoACD's time
#: grows faster than the face count (default config, a torus, CPU s on 2 cores: 5k faces 3.2, 10k 5.1,
#: 20k 8.5, 50k 24), oriented bounds and winding repair too, and 32 hulls of <= 64 vertices keep none
#: of the extra detail. Household models and the procedural dataset (< 3k faces) stay below it.
FACE_BUDGET = 20_000
#: Meshes with more faces are refused: reading, cleaning and decimating cost ~3 s of CPU and ~0.6 GB
#: per million faces here (2M: 5.3 s, 1.2 GB), so this many take ~12 s and ~2.5 GB before CoACD.
MAX_FACES = 4_000_000
#: Larger files are refused before parsing: MAX_FACES faces as binary STL (50 bytes a face) fit under it.
MAX_FILE_BYTES = 256 * 2**20
# manifold3d's simplification gives up (quadric decimation takes over) past this tolerance, a fraction
# of the largest extent: beyond it the surface may move more than CoACD's own concavity tolerance.
_MAX_SIMPLIFY_TOLERANCE = 0.02
#: Meshes with more faces are dense (scans, CAD exports): :func:`decomposition_for` gives them faster
#: settings. The procedural dataset stays at or under it (``rail_mj.dataset.procedural.MAX_FACES``), so its hulls
#: and their cache keys are those of the defaults.
DENSE_FACES = 5_000
#: The quality guard (:func:`object_from_mesh`): most of :attr:`HullQuality.excess` and
#: :attr:`HullQuality.missing` that hulls may have. The procedural dataset's default hulls reach
#: 0.04 and 0.23 (a sphere's 64-vertex hull); one hull of a cup gives 0.73 excess.
MAX_EXCESS = 0.25
MAX_MISSING = 0.3
# Fewest faces DecompositionConfig.max_faces may ask for: below it decimation erases whole features.
_MIN_COACD_FACES = 500
# A face is loose when its piece (faces joined by shared edges) has fewer faces than a tetrahedron;
# a mesh with more than this fraction of loose faces is refused as a triangle soup.
_MIN_PIECE_FACES = 4
_MAX_LOOSE_FRACTION = 0.5
# A mesh is flat when its smallest extent is below this fraction of its largest.
_FLAT_RATIO = 1e-6
# Hulls with less volume than this (m^3) are slivers MuJoCo cannot give inertia.
_MIN_HULL_VOLUME = 1e-12

# trimesh.Trimesh.metadata key under which repair_mesh records what it did to the mesh.
_NOTES_KEY = "rail_mj_notes"
_FORMATS = "OBJ, STL (binary or ASCII), PLY, OFF, GLB, GLTF"
# Formats trimesh reads as text: it decodes non-UTF-8 text with charset_normalizer, an optional
# module rail_mj does not install, so such files are transcoded here first.
_TEXT_FORMATS = ("obj", "off", "gltf")

_Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class DecompositionConfig:
    """CoACD parameters and the hull vertex cap.

    The defaults decompose a ~5.9k-face mug with a handle in ~7 s of CPU into
    25 hulls that leave its cavity free (``benchmarks/coacd_time.py``);
    CoACD's own defaults (resolution 2000, 150 MCTS iterations, remeshing)
    took ~2 minutes here. ``mcts_max_depth=1`` is a trap: worse cuts and a
    ~50x slower merge.
    """

    threshold: float = 0.05  # concavity tolerance; larger = fewer, coarser hulls (0.08 let hulls into a cup)
    max_convex_hull: int = 32  # hull cap (CoACD merges down to it)
    max_hull_vertices: int = MJX_MAX_HULL_VERTICES
    # "auto": remesh (CoACD's manifold preprocessing) only when the repaired mesh is not a closed
    # volume — remeshing at low resolution thickens thin walls into the cavity and triples the time
    preprocess_mode: Literal["auto", "on", "off"] = "auto"
    preprocess_resolution: int = 30
    resolution: int = 500  # surface samples per cut evaluation
    mcts_nodes: int = 10
    mcts_iterations: int = 30
    mcts_max_depth: int = 2
    seed: int = 0
    convex_shortcut: bool = True  # a convex mesh is its own (reduced) hull, no CoACD call
    # CoACD sees at most this many faces: the mesh is decimated for it alone (the object keeps the
    # repaired mesh); None: CoACD sees the mesh as repaired (<= FACE_BUDGET faces)
    max_faces: int | None = None
    # CPU seconds one CoACD run may take before it is stopped with a DecompositionTimeout: a 10k-piece
    # triangle soup ran for minutes per run. The worst real mesh here took 26 s of wall time cold.
    time_limit_s: float = 150.0

    def __post_init__(self) -> None:
        if not 0.0 < self.threshold <= 1.0:
            raise ConfigError(f"threshold must be in (0, 1], got {self.threshold}")
        if self.max_convex_hull < 1:
            raise ConfigError(f"max_convex_hull must be >= 1, got {self.max_convex_hull}")
        if not 4 <= self.max_hull_vertices <= MJX_MAX_HULL_VERTICES:
            raise ConfigError(
                f"max_hull_vertices must be in [4, {MJX_MAX_HULL_VERTICES}] (MJX limit), got {self.max_hull_vertices}"
            )
        if self.preprocess_mode not in ("auto", "on", "off"):
            raise ConfigError(f"preprocess_mode must be one of 'auto', 'on', 'off', got {self.preprocess_mode!r}")
        for name in ("preprocess_resolution", "resolution", "mcts_nodes", "mcts_iterations", "mcts_max_depth"):
            if getattr(self, name) < 1:
                raise ConfigError(f"{name} must be >= 1, got {getattr(self, name)}")
        if not (np.isfinite(self.time_limit_s) and self.time_limit_s > 0):
            raise ConfigError(f"time_limit_s must be a positive number of seconds, got {self.time_limit_s}")
        if self.max_faces is not None and self.max_faces < _MIN_COACD_FACES:
            raise ConfigError(f"max_faces must be None or >= {_MIN_COACD_FACES}, got {self.max_faces}")


#: :func:`decomposition_for` meshes of more than :data:`DENSE_FACES` faces.
DENSE_DECOMPOSITION = DecompositionConfig(threshold=0.07, mcts_iterations=15, max_faces=3_000)


def _fail(label: str, problem: str) -> MeshError:
    return MeshError(f"{label}: {problem}")


def _not_valid(label: str, fmt: str, why: str) -> MeshError:
    return _fail(label, f"is not a valid {fmt.upper()} file: {why}; accepted formats: {_FORMATS}")


def _too_many_faces(label: str, n_faces: int) -> MeshError:
    return _fail(
        label,
        f"has {n_faces:,} faces, over the limit of {MAX_FACES:,} (meshes over {FACE_BUDGET:,} faces are "
        f"decimated to {FACE_BUDGET:,}, up to that limit); decimate it first, e.g. with Blender's Decimate "
        "modifier or MeshLab's quadric edge collapse",
    )


def _binary_stl_faces(head: bytes, size: int) -> int | None:
    """The triangle count of a binary STL (80-byte header, uint32 count, 50 bytes a triangle), else None."""
    if size < 84:
        return None
    n = int.from_bytes(head[80:84], "little")
    return n if size == 84 + 50 * n else None


def _declared_faces(path: Path, fmt: str, size: int) -> int | None:
    """The face count a file's header declares (binary STL, PLY, OFF), read without parsing the body."""
    with path.open("rb") as f:
        head = f.read(65536)
    if fmt == "stl":
        return _binary_stl_faces(head, size)
    if fmt == "ply":
        match = re.search(rb"^element\s+face\s+(\d+)", head.split(b"end_header")[0], re.MULTILINE)
        return int(match.group(1)) if match else None
    if fmt == "off":
        lines = (line.split(b"#")[0].split() for line in head.splitlines())
        tokens = [t for line in lines for t in line][:4]
        if len(tokens) == 4 and tokens[0].endswith(b"OFF") and tokens[2].isdigit():
            return int(tokens[2])
    return None


def _stl_source(path: Path, label: str, size: int) -> io.BytesIO | None:
    """Check the file is binary or ASCII STL; UTF-8 bytes for trimesh where ASCII STL is in another encoding."""
    with path.open("rb") as f:
        head = f.read(84)
    if _binary_stl_faces(head, size) is not None:
        return None
    if head.lstrip()[:5].lower() == b"solid":
        return _text_source(path, label, "stl", kind="ASCII STL")
    raise _not_valid(
        label,
        "stl",
        "it is neither binary STL (an 80-byte header and a triangle count n, 84 + 50 n bytes in all; "
        f"this file has {size:,} bytes) nor ASCII STL (text starting with 'solid')",
    )


def _text_source(path: Path, label: str, fmt: str, *, kind: str | None = None) -> io.BytesIO | None:
    """Refuse binary data in a text format; UTF-8 bytes for trimesh where the file is in another encoding."""
    data = path.read_bytes()
    if b"\x00" in data[:65536]:
        raise _not_valid(label, fmt, f"it holds binary data (NUL bytes), and {kind or fmt.upper()} is a text format")
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        # Latin-1 maps every byte to a character; the geometry itself is ASCII in any encoding.
        return io.BytesIO(data.decode("latin-1").encode("utf-8"))
    return None


def _read(path: Path) -> trimesh.Trimesh:
    """Read a supported file into one unprocessed mesh, scene graphs flattened."""
    label = str(path)
    if not path.exists():
        raise _fail(label, f"file not found; give a path to an existing mesh file ({', '.join(SUPPORTED_EXTENSIONS)})")
    if not path.is_file():
        raise _fail(label, "not a regular file; give a path to a mesh file")
    ext = path.suffix.lower()
    if ext not in SUPPORTED_EXTENSIONS:
        raise _fail(label, f"unknown extension {ext or '(none)'!r}; supported: {', '.join(SUPPORTED_EXTENSIONS)}")
    fmt = ext[1:]
    try:
        size = path.stat().st_size
        with path.open("rb"):
            pass
        if size == 0:
            raise _fail(label, "empty file (0 bytes); a mesh file needs vertices and faces")
        if size > MAX_FILE_BYTES:
            raise _fail(
                label,
                f"is {size / 2**20:,.1f} MiB, over the {MAX_FILE_BYTES / 2**20:,.0f} MiB limit for mesh files "
                f"(meshes may have up to {MAX_FACES:,} faces); decimate it first, e.g. with Blender's Decimate "
                "modifier or MeshLab's quadric edge collapse",
            )
        declared = _declared_faces(path, fmt, size)
        if declared is not None and declared > MAX_FACES:
            raise _too_many_faces(label, declared)
        if fmt == "stl":
            source = _stl_source(path, label, size)
        elif fmt in _TEXT_FORMATS:
            source = _text_source(path, label, fmt)
        else:
            source = None
    except OSError as exc:
        raise _fail(label, f"cannot be read ({exc.strerror})") from exc
    try:
        if source is None:
            loaded = trimesh.load(str(path), file_type=fmt, process=False)
        else:
            resolver = trimesh.resolvers.FilePathResolver(str(path))
            loaded = trimesh.load(source, file_type=fmt, resolver=resolver, process=False)
    except ImportError as exc:
        raise _fail(
            label, f"needs the Python module {exc.name!r} to read this {fmt.upper()} file; install it with pip"
        ) from exc
    except Exception as exc:  # trimesh's loaders raise many unrelated types on garbage input
        raise _not_valid(label, fmt, f"{type(exc).__name__}: {exc}") from exc
    if isinstance(loaded, trimesh.Scene):
        meshes = [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)] if loaded.geometry else []
        if not meshes:
            raise _fail(label, "has no faces (a scene without triangle meshes); a mesh needs triangles")
        return trimesh.util.concatenate(meshes)
    if not isinstance(loaded, trimesh.Trimesh):
        raise _fail(label, f"has no faces (it holds a {type(loaded).__name__}); a mesh needs triangles")
    return loaded


def _clean(mesh: trimesh.Trimesh) -> None:
    """Merge duplicate vertices, drop degenerate and duplicate faces and unreferenced vertices (in place)."""
    mesh.merge_vertices()
    mesh.update_faces(mesh.nondegenerate_faces() & mesh.unique_faces())
    mesh.remove_unreferenced_vertices()


def _simplify_closed(mesh: trimesh.Trimesh, face_count: int, *, strict: bool) -> trimesh.Trimesh | None:
    """A closed mesh simplified by manifold3d to at most ``face_count`` faces, still closed; None if it cannot.

    Manifold moves no surface by more than its tolerance and keeps the result a closed manifold;
    quadric decimation (fast-simplification) left non-manifold edges in 9 of 9 closed dense meshes
    tried (a 42k-face bowl: 12 at 20k faces), so CoACD then remeshed them, which filled cavities.
    The tolerance grows from 0.1% of the largest extent until the faces fit; where they do not fit
    by :data:`_MAX_SIMPLIFY_TOLERANCE`, the result there is returned unless ``strict``.
    """
    import manifold3d

    try:
        solid = manifold3d.Manifold(
            manifold3d.Mesh(
                vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
                tri_verts=np.asarray(mesh.faces, dtype=np.uint32),
            )
        )
    except (RuntimeError, ValueError):
        return None
    if solid.status() != manifold3d.Error.NoError:
        return None
    largest = float(np.ptp(mesh.vertices, axis=0).max())
    tolerance = 1e-3 * largest
    while solid.num_tri() > face_count:
        if tolerance > _MAX_SIMPLIFY_TOLERANCE * largest:
            if strict:
                return None
            break
        solid = solid.simplify(tolerance)
        tolerance *= 1.25
    out = solid.to_mesh()
    result = trimesh.Trimesh(
        vertices=np.asarray(out.vert_properties[:, :3], dtype=np.float64),
        faces=np.asarray(out.tri_verts, dtype=np.int64),
        process=False,
    )
    _clean(result)
    return result if len(result.faces) and result.is_volume else None


def _decimate(mesh: trimesh.Trimesh, label: str, face_count: int, *, strict: bool = True) -> trimesh.Trimesh:
    """``mesh`` cut to at most ``face_count`` faces and cleaned: a closed mesh by manifold3d so it stays
    closed (:func:`_simplify_closed`), any other (or one manifold3d refuses) by quadric decimation.
    Not ``strict``: a closed mesh stays closed even where that leaves it over ``face_count``."""
    if mesh.is_volume:
        closed = _simplify_closed(mesh, face_count, strict=strict)
        if closed is not None:
            return closed
    try:
        small = mesh.simplify_quadric_decimation(face_count=face_count)
    except Exception as exc:  # fast-simplification reports failures as assorted types
        raise _fail(
            label,
            f"has {len(mesh.faces):,} faces, over the face budget of {face_count:,}, and decimating it failed "
            f"({type(exc).__name__}: {exc}); decimate it first, e.g. with Blender's Decimate modifier",
        ) from exc
    out = trimesh.Trimesh(
        vertices=np.asarray(small.vertices, dtype=np.float64), faces=np.asarray(small.faces, dtype=np.int64),
        process=False,
    )
    _clean(out)
    if len(out.faces) == 0:
        raise _fail(label, f"has no faces left after decimating its {len(mesh.faces):,} faces to {face_count:,}")
    return out


def _check_not_too_large(label: str, largest: float) -> None:
    if largest > MAX_EXTENT:
        raise _fail(
            label,
            f"is too large: largest extent {largest:.4g} m > {MAX_EXTENT:g} m; if the file is in "
            "millimetres or centimetres pass units=0.001 or units=0.01 (metres per mesh unit)",
        )


def _check_not_a_soup(label: str, mesh: trimesh.Trimesh) -> None:
    """Refuse a mesh most of whose faces lie in pieces too small to enclose anything.

    Such a triangle soup has no surface to stand on or hold with, and CoACD runs for minutes on it. On the
    real-mesh set at most 1.5% of a mesh's faces are loose.
    """
    _, piece_of_face, piece_sizes = np.unique(_body_labels(mesh), return_inverse=True, return_counts=True)
    loose = piece_sizes[piece_of_face] < _MIN_PIECE_FACES
    if loose.mean() > _MAX_LOOSE_FRACTION:
        raise _fail(
            label,
            f"is a triangle soup: {int(loose.sum()):,} of its {len(mesh.faces):,} faces lie in pieces of fewer than "
            f"{_MIN_PIECE_FACES} faces joined by shared edges ({len(piece_sizes):,} pieces), which enclose nothing; "
            f"at most {_MAX_LOOSE_FRACTION:.0%} may; weld the vertices or export a connected surface",
        )


def repair_mesh(mesh: trimesh.Trimesh, *, label: str = "mesh") -> trimesh.Trimesh:
    """Validate and repair a mesh (returns a new one); raise MeshError naming ``label``.

    Repairs: merge duplicate vertices, drop degenerate and duplicate faces and
    unreferenced vertices, decimate to at most :data:`FACE_BUDGET` faces when over it,
    make winding consistent and normals outward.
    Rejects: no faces, more than :data:`MAX_FACES` faces, non-finite vertices,
    flat meshes, absurd sizes, triangle soups. What was changed beyond cleaning is listed by
    :func:`mesh_notes` on the result.
    """
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    notes = list(mesh.metadata.get(_NOTES_KEY, ()))
    if faces.size == 0 or vertices.size == 0:
        raise _fail(label, "has no faces; a mesh needs triangles, not only points or lines")
    if len(faces) > MAX_FACES:
        raise _too_many_faces(label, len(faces))
    if not np.isfinite(vertices).all():
        bad = int((~np.isfinite(vertices).all(axis=1)).sum())
        raise _fail(label, f"has {bad} vertices with NaN or inf coordinates; all coordinates must be finite")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise _fail(label, f"has faces that index vertices outside 0..{len(vertices) - 1}")
    # Too large is judged before cleaning: merging vertices at 1e30 m overflows trimesh's integer grid.
    _check_not_too_large(label, float(np.ptp(vertices[np.unique(faces)], axis=0).max()))
    out = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    _clean(out)
    if len(out.faces) == 0:
        raise _fail(label, "has no faces left after removing degenerate ones; every face is zero-area")
    # The size checks need only the vertices: they come before the costly steps, so a huge mesh in the
    # wrong units is refused at once.
    extents = out.extents
    largest, smallest = float(extents.max()), float(extents.min())
    if smallest <= _FLAT_RATIO * largest:
        raise _fail(
            label,
            f"is flat (extents {np.round(extents, 6).tolist()} m); an object needs volume in all three axes",
        )
    if largest < MIN_EXTENT:
        raise _fail(
            label,
            f"is too small: largest extent {largest:.4g} m < {MIN_EXTENT * 1000:g} mm; pass units= the number "
            "of metres per mesh unit (1.0 if the file is already in metres; check it was not scaled twice)",
        )
    if len(out.faces) > FACE_BUDGET:
        n_faces = len(out.faces)
        out = _decimate(out, label, FACE_BUDGET)
        notes.append(f"decimated from {n_faces:,} to {len(out.faces):,} faces (face budget {FACE_BUDGET:,})")
    _check_not_a_soup(label, out)
    trimesh.repair.fix_normals(out)
    if notes:
        out.metadata[_NOTES_KEY] = notes
    return out


def mesh_notes(mesh: trimesh.Trimesh) -> list[str]:
    """What :func:`repair_mesh` changed in ``mesh`` beyond cleaning it (e.g. decimation); empty if nothing."""
    return list(mesh.metadata.get(_NOTES_KEY, ()))


def load_mesh(path: str | Path, *, units: float = 1.0, up: Literal["z", "y"] = "z") -> trimesh.Trimesh:
    """Load, convert and repair one mesh file (OBJ, STL, PLY, OFF, GLB, GLTF).

    ``units`` is metres per mesh unit. ``up="y"`` rotates +90° about +x
    (right-handed), ``(x, y, z) -> (x, -z, y)``, so mesh +y becomes +z.
    Scenes (GLB/GLTF) are merged into one mesh with their node transforms.
    """
    path = Path(path)
    if not (np.isfinite(units) and units > 0):
        raise ConfigError(f"units must be a positive finite number of metres per mesh unit, got {units}")
    if up not in ("z", "y"):
        raise ConfigError(f"up must be 'z' or 'y', got {up!r}")
    mesh = _read(path)
    mesh = trimesh.Trimesh(
        vertices=np.asarray(mesh.vertices, dtype=np.float64) * units, faces=mesh.faces, process=False
    )
    if up == "y":
        mesh.apply_transform(_Y_UP_TO_Z_UP)
    return repair_mesh(mesh, label=str(path))


def mesh_hash(mesh: trimesh.Trimesh) -> str:
    """SHA-256 of the vertex (float64) and face (int64) arrays."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(mesh.vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    return h.hexdigest()


def reduce_hull(points: np.ndarray, max_vertices: int) -> np.ndarray:
    """Convex-hull vertices of ``points``, reduced to at most ``max_vertices``.

    Greedy farthest-point insertion: start from the 6 axis extremes, then add
    the point lying farthest outside the current hull until the cap, so the
    reduced hull is inscribed and its worst-case gap is minimised step by step.
    """
    points = np.asarray(points, dtype=np.float64)
    try:
        hull_pts = points[ConvexHull(points).vertices]
    except (QhullError, ValueError) as exc:
        raise DecompositionError(f"hull of {len(points)} points is degenerate (flat or too few points)") from exc
    if len(hull_pts) <= max_vertices:
        return hull_pts
    chosen = list(dict.fromkeys(int(i) for i in np.concatenate([hull_pts.argmin(0), hull_pts.argmax(0)])))
    while len(chosen) < 4:  # extremes coincide on tiny hulls: add the farthest from the centroid
        d = np.linalg.norm(hull_pts - hull_pts[chosen].mean(0), axis=1)
        d[chosen] = -1.0
        chosen.append(int(d.argmax()))
    while len(chosen) < max_vertices:
        try:
            eq = ConvexHull(hull_pts[chosen]).equations
        except QhullError:  # the seed points are coplanar: add the point farthest off their plane
            c = hull_pts[chosen]
            normal = np.linalg.svd(c - c.mean(0))[2][-1]
            dist = np.abs((hull_pts - c.mean(0)) @ normal)
        else:
            dist = (hull_pts @ eq[:, :3].T + eq[:, 3]).max(axis=1)
        dist[chosen] = -np.inf
        best = int(dist.argmax())
        if dist[best] <= 0.0:
            break
        chosen.append(best)
    return hull_pts[np.sort(chosen)]


def _cache_key(digest: str, config: DecompositionConfig, n_bodies: int) -> str:
    # Options left at None and a single body are left out of the key, so the meshes and configs that
    # existed before those options and the split into bodies keep their cache entries; the time limit
    # does not change the hulls it lets through.
    fields = {k: v for k, v in asdict(config).items() if v is not None and k != "time_limit_s"}
    payload = {"mesh": digest, "config": fields}
    if n_bodies > 1:
        payload["bodies"] = n_bodies
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def _preprocess_mode(mesh: trimesh.Trimesh, config: DecompositionConfig) -> str:
    if config.preprocess_mode != "auto":
        return config.preprocess_mode
    return "off" if mesh.is_volume else "on"


_WALL_PER_CPU = 4.0
_WALL_SLACK_S = 10.0


class _CoacdCrash(Exception):
    """The CoACD child process died (a signal, not a Python error)."""


def _coacd_child(vertices: np.ndarray, faces: np.ndarray, options: dict, time_limit_s: float) -> list[np.ndarray]:
    """One CoACD run in a child process (:mod:`rail_mj.mesh.coacd_child`): its hulls' vertices.

    The child may use ``time_limit_s`` seconds of CPU (a limit that holds however loaded the machine is),
    and :data:`_WALL_PER_CPU` times that plus :data:`_WALL_SLACK_S` of wall time, in case it stalls without
    spending CPU (CoACD's threads on a loaded machine take longer on the wall than on the CPU).
    """
    payload = io.BytesIO()
    np.savez(payload, vertices=vertices, faces=faces, options=json.dumps(options),
             cpu_limit_s=max(1, math.ceil(time_limit_s)))
    wall_s = _WALL_PER_CPU * time_limit_s + _WALL_SLACK_S

    def late(what: str) -> DecompositionTimeout:
        return DecompositionTimeout(
            f"CoACD did not finish within {what} on this mesh ({len(faces):,} faces); a mesh of many loose "
            "pieces or a triangle soup does this: repair or simplify it, or raise DecompositionConfig.time_limit_s"
        )

    try:
        proc = subprocess.run([sys.executable, str(Path(__file__).with_name("coacd_child.py"))],
                              input=payload.getvalue(), capture_output=True, check=False, timeout=wall_s)
    except subprocess.TimeoutExpired:
        raise late(f"{wall_s:g} s of wall time") from None
    if proc.returncode == -signal.SIGXCPU:
        raise late(f"{time_limit_s:g} s of CPU")
    if proc.returncode < 0:
        raise _CoacdCrash(f"killed by signal {-proc.returncode}")
    if proc.returncode != 0:
        why = proc.stderr.decode(errors="replace").strip().splitlines()
        raise DecompositionError(f"CoACD failed ({why[-1] if why else f'exit status {proc.returncode}'})")
    with np.load(io.BytesIO(proc.stdout)) as data:
        return [np.asarray(data[f"arr_{i}"], dtype=np.float64) for i in range(len(data.files))]


def _run_coacd(mesh: trimesh.Trimesh, config: DecompositionConfig) -> list[np.ndarray]:
    options = dict(
        threshold=config.threshold,
        max_convex_hull=config.max_convex_hull,
        preprocess_mode=_preprocess_mode(mesh, config),
        preprocess_resolution=config.preprocess_resolution,
        resolution=config.resolution,
        mcts_nodes=config.mcts_nodes,
        mcts_iterations=config.mcts_iterations,
        mcts_max_depth=config.mcts_max_depth,
        decimate=True,
        max_ch_vertex=max(config.max_hull_vertices, 8),
        seed=config.seed,
    )
    vertices, faces = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int32)
    try:
        return _coacd_child(vertices, faces, options, config.time_limit_s)
    except _CoacdCrash as crash:
        if options["preprocess_mode"] == "on":
            raise DecompositionError(f"CoACD crashed on this mesh ({crash}); repair or simplify the mesh") from None
        # the crashes seen come from CoACD's cutting of the mesh as given; its own remeshing avoids them
        try:
            return _coacd_child(vertices, faces, {**options, "preprocess_mode": "on"}, config.time_limit_s)
        except _CoacdCrash as again:
            raise DecompositionError(f"CoACD crashed on this mesh ({crash}), and again with its own remeshing "
                                     f"({again}); repair or simplify the mesh") from None


def _body_labels(mesh: trimesh.Trimesh) -> np.ndarray:
    """Per face, the connected piece (faces joined by shared edges) it belongs to."""
    return trimesh.graph.connected_component_labels(mesh.face_adjacency, node_count=len(mesh.faces))


def _bodies(mesh: trimesh.Trimesh, labels: np.ndarray) -> list[trimesh.Trimesh]:
    """The mesh's connected pieces, in the order of their first face.

    Each piece keeps only its own vertices, gathered in one pass: copying every vertex into each piece
    and pruning made a 10k-piece triangle soup quadratic (minutes).
    """
    _, first = np.unique(labels, return_index=True)
    pieces = []
    for label in labels[np.sort(first)]:
        faces = mesh.faces[labels == label]
        used, local = np.unique(faces, return_inverse=True)
        pieces.append(trimesh.Trimesh(mesh.vertices[used], local.reshape(faces.shape), process=False))
    return pieces


def _point_hull_volume(points: np.ndarray) -> float:
    try:
        return float(ConvexHull(points).volume)
    except (QhullError, ValueError):
        return 0.0


def _decompose_bodies(bodies: list[trimesh.Trimesh], config: DecompositionConfig) -> list[np.ndarray]:
    """Raw parts of a mesh made of separate bodies, each body decomposed on its own.

    CoACD given the bodies together treats them as one surface: on overlapping closed bodies
    (a teddy made of 15 convex pieces, a tray of 5 boxes) it ran for minutes or exhausted memory.
    A convex body is its own hull; the others share what the hull cap leaves, by their hull volume.
    """
    convex = [config.convex_shortcut and body.is_convex for body in bodies]
    weights = [_point_hull_volume(np.asarray(body.vertices)) for body in bodies]
    concave = sum(w for w, c in zip(weights, convex, strict=True) if not c)
    spare = config.max_convex_hull - len(bodies)
    raw: list[np.ndarray] = []
    for body, is_convex, weight in zip(bodies, convex, weights, strict=True):
        cap = 1 if is_convex or concave <= 0 else 1 + int(spare * weight / concave)
        if cap == 1:
            raw.append(np.asarray(body.vertices, dtype=np.float64))
        else:
            raw.extend(_run_coacd(body, replace(config, max_convex_hull=cap)))
    return raw


def decompose(mesh: trimesh.Trimesh, config: DecompositionConfig | None = None) -> tuple[np.ndarray, ...]:
    """Convex hulls of ``mesh`` (mesh frame), each with <= ``config.max_hull_vertices`` vertices.

    A mesh of separate bodies (no more than ``config.max_convex_hull``) is decomposed body by body.
    Cached as .npz under ``cache_dir("hulls")``, keyed by the mesh arrays and the config.
    """
    config = config or DecompositionConfig()
    labels = _body_labels(mesh)
    path = cache_dir("hulls") / f"{_cache_key(mesh_hash(mesh), config, len(np.unique(labels)))}.npz"
    if path.exists():
        try:
            with np.load(path) as data:
                return tuple(data[f"hull{i}"] for i in range(len(data.files)))
        except (OSError, ValueError, KeyError, zipfile.BadZipFile):
            path.unlink(missing_ok=True)  # a damaged cache entry is recomputed, not trusted
    if config.convex_shortcut and mesh.is_convex:
        raw = [np.asarray(mesh.vertices, dtype=np.float64)]
    else:
        target = mesh
        if config.max_faces is not None and len(mesh.faces) > config.max_faces:
            target = _decimate(mesh, "mesh", config.max_faces, strict=False)
            labels = _body_labels(target)
        if 1 < len(np.unique(labels)) <= config.max_convex_hull:
            raw = _decompose_bodies(_bodies(target, labels), config)
        else:
            raw = _run_coacd(target, config)
    hulls = []
    for points in raw:
        if len(points) < 4:
            continue
        try:
            if ConvexHull(points).volume < _MIN_HULL_VOLUME:
                continue
        except QhullError:
            continue  # a flat sliver: no volume, no contact surface worth keeping
        hulls.append(reduce_hull(points, config.max_hull_vertices))
    if not hulls:
        raise DecompositionError(
            f"decomposition gave no usable hull ({len(raw)} raw parts, all flat or tiny); "
            "check the mesh has volume or lower DecompositionConfig.threshold"
        )
    tmp = path.with_suffix(f".{np.random.default_rng().integers(1 << 62)}.tmp.npz")
    np.savez(tmp, **{f"hull{i}": h for i, h in enumerate(hulls)})
    tmp.replace(path)  # atomic: a concurrent reader never sees a half-written file
    return tuple(hulls)


# Probe rays per side of the grid :func:`hull_quality` casts from each of the six axis directions.
_PROBE_GRID = 32
# Surface points :func:`hull_quality` checks for a hull near them, and how near (fraction of the
# mesh's largest extent) counts as covered.
_SURFACE_SAMPLES = 2048
_COVER_TOL = 0.02
_MIN_FREE = 0.02


@dataclass(frozen=True)
class HullQuality:
    """How well the convex hulls stand for the mesh they were made from (:func:`hull_quality`).

    ``excess`` and ``missing`` need no closed surface, so they stand in for ``volume_ratio`` on
    open meshes.
    """

    n_hulls: int
    #: Volume of the union of the hulls over the mesh's volume; None when the mesh is not closed.
    volume_ratio: float | None
    #: The worst of six axis views (probe rays on a grid over the bounding box): the part of the free
    #: space in front of the mesh that hulls fill. ~1 when hulls fill a cup seen from above; ~0 when
    #: every cavity stays open.
    excess: float
    #: The fraction of the mesh's surface (area-weighted samples) farther than 2% of its largest
    #: extent from every hull: parts the hulls lost.
    missing: float


def _hull_intervals(
    hulls: tuple[np.ndarray, ...], equations: list[np.ndarray], origins: np.ndarray, axis: int, sign: float
) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit ray parameters (H, R) of the rays ``origins + t * sign * e_axis`` through each hull
    (inf where a ray misses it); only the rays over a hull's bounding box are tested against it."""
    enter = np.full((len(equations), len(origins)), np.inf)
    leave = np.full((len(equations), len(origins)), np.inf)
    across = [k for k in range(3) if k != axis]
    for i, (points, eq) in enumerate(zip(hulls, equations, strict=True)):
        lo, hi = points[:, across].min(axis=0), points[:, across].max(axis=0)
        rays = np.flatnonzero(((origins[:, across] >= lo) & (origins[:, across] <= hi)).all(axis=1))
        if len(rays) == 0:
            continue
        num = -(origins[rays] @ eq[:, :3].T + eq[:, 3])  # (R, P): a point is inside where n.p + d <= 0
        den = sign * eq[:, axis]  # (P,)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = num / den
        first = np.where(den < 0, t, -np.inf).max(axis=1)
        last = np.where(den > 0, t, np.inf).min(axis=1)
        outside = ((den == 0) & (num < 0)).any(axis=1)
        hit = (first <= last) & ~outside & (last >= 0)
        enter[i, rays[hit]] = np.maximum(first[hit], 0.0)
        leave[i, rays[hit]] = last[hit]
    return enter, leave


def _probe_origins(bounds: np.ndarray, axis: int, sign: float, n: int, margin: float) -> tuple:
    """Ray origins (n*n, 3) on a grid ``margin`` outside the bounding box, and the direction, for one view."""
    lo, hi = bounds
    a, b = [k for k in range(3) if k != axis]
    ua = lo[a] + (np.arange(n) + 0.5) * (hi[a] - lo[a]) / n
    ub = lo[b] + (np.arange(n) + 0.5) * (hi[b] - lo[b]) / n
    ga, gb = np.meshgrid(ua, ub, indexing="ij")
    origins = np.empty((n * n, 3))
    origins[:, a], origins[:, b] = ga.ravel(), gb.ravel()
    origins[:, axis] = lo[axis] - margin if sign > 0 else hi[axis] + margin
    direction = np.zeros(3)
    direction[axis] = sign
    return origins, direction


def _union_length(enter: np.ndarray, leave: np.ndarray) -> np.ndarray:
    """Per ray, the length of the union of the [enter, leave] intervals (inputs (H, R), inf where missed)."""
    order = np.argsort(enter, axis=0)
    start = np.take_along_axis(enter, order, axis=0)
    end = np.take_along_axis(leave, order, axis=0)
    hit = np.isfinite(start) & (end > start)
    start, end = np.where(hit, start, 0.0), np.where(hit, end, 0.0)
    reach = np.maximum.accumulate(end, axis=0)
    before = np.vstack([np.full((1, start.shape[1]), -np.inf), reach[:-1]])
    return np.maximum(0.0, end - np.maximum(start, before)).sum(axis=0)


def _axis_depths(mesh: trimesh.Trimesh, bounds: np.ndarray, axis: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Nearest and farthest mesh coordinate along ``axis`` on the rays of the n x n grid of
    :func:`_probe_origins` (NaN where a ray misses), by rasterising the triangles onto the grid."""
    a, b = [k for k in range(3) if k != axis]
    lo, hi = bounds
    step = np.array([(hi[a] - lo[a]) / n, (hi[b] - lo[b]) / n])
    tri = np.asarray(mesh.triangles, dtype=np.float64)
    uv = (tri[:, :, [a, b]] - np.array([lo[a], lo[b]])) / step - 0.5  # grid units: cell i is centred at i
    first = np.clip(np.ceil(uv.min(axis=1)), 0, n - 1).astype(np.int64)
    last = np.clip(np.floor(uv.max(axis=1)), 0, n - 1).astype(np.int64)
    span = np.maximum(last - first + 1, 0)
    span[(uv.max(axis=1) < 0).any(axis=1) | (uv.min(axis=1) > n - 1).any(axis=1)] = 0
    count = span[:, 0] * span[:, 1]
    near = np.full(n * n, np.inf)
    far = np.full(n * n, -np.inf)
    chunk = np.cumsum(count) // 2_000_000  # bounded memory for meshes of large triangles
    for c in np.unique(chunk):
        sel = np.flatnonzero((chunk == c) & (count > 0))
        t = np.repeat(sel, count[sel])
        k = np.arange(len(t)) - np.repeat(np.cumsum(count[sel]) - count[sel], count[sel])
        i = first[t, 0] + k // span[t, 1]
        j = first[t, 1] + k % span[t, 1]
        p0, p1, p2 = uv[t, 0], uv[t, 1], uv[t, 2]
        e1, e2 = p1 - p0, p2 - p0
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        q = np.column_stack([i, j]) - p0
        flat = det == 0  # a triangle seen edge-on covers no cell
        det[flat] = 1.0
        w1 = (q[:, 0] * e2[:, 1] - q[:, 1] * e2[:, 0]) / det
        w2 = (e1[:, 0] * q[:, 1] - e1[:, 1] * q[:, 0]) / det
        inside = ~flat & (w1 >= -1e-9) & (w2 >= -1e-9) & (w1 + w2 <= 1 + 1e-9)
        z = tri[t, 0, axis] + w1 * (tri[t, 1, axis] - tri[t, 0, axis]) + w2 * (tri[t, 2, axis] - tri[t, 0, axis])
        cell = (i * n + j)[inside]
        np.minimum.at(near, cell, z[inside])
        np.maximum.at(far, cell, z[inside])
    missed = ~np.isfinite(near)
    near[missed], far[missed] = np.nan, np.nan
    return near, far


def hull_quality(mesh: trimesh.Trimesh, hulls: tuple[np.ndarray, ...]) -> HullQuality:
    """Volume ratio, excess (filled cavities) and missing surface of ``hulls`` against ``mesh`` (:class:`HullQuality`)."""
    equations = [ConvexHull(h).equations for h in hulls]
    bounds = np.asarray(mesh.bounds, dtype=np.float64)
    extents = np.ptp(bounds, axis=0)
    margin = 0.01 * float(extents.max())
    excess = 0.0
    for axis in range(3):
        near, far = _axis_depths(mesh, bounds, axis, _PROBE_GRID)
        length = margin + float(extents[axis])
        for sign, depth in ((1.0, near - (bounds[0, axis] - margin)), (-1.0, (bounds[1, axis] + margin) - far)):
            t_mesh = np.where(np.isnan(depth), length, np.minimum(depth, length))
            # a view the mesh fills (a box seen face-on) has next to no free space: a sliver of hull
            # in it is no filled cavity, so the free space counts as at least 2% of the view's box
            free = max(float((t_mesh - margin).sum()), _MIN_FREE * len(t_mesh) * float(extents[axis]))
            origins, _ = _probe_origins(bounds, axis, sign, _PROBE_GRID, margin)
            enter, leave = _hull_intervals(hulls, equations, origins, axis, sign)
            front = _union_length(np.clip(enter, margin, t_mesh), np.clip(leave, margin, t_mesh))
            excess = max(excess, float(front.sum()) / free)
    points = trimesh.sample.sample_surface(mesh, _SURFACE_SAMPLES, seed=0)[0]
    outside = np.full(len(points), np.inf)
    for eq in equations:
        outside = np.minimum(outside, (points @ eq[:, :3].T + eq[:, 3]).max(axis=1))
    missing = float((outside > _COVER_TOL * float(extents.max())).mean())
    volume_ratio = None
    if mesh.is_volume:
        n = 2 * _PROBE_GRID
        origins, _ = _probe_origins(bounds, 2, 1.0, n, margin)
        enter, leave = _hull_intervals(hulls, equations, origins, 2, 1.0)
        cell = float(extents[0] * extents[1]) / (n * n)
        volume_ratio = float(_union_length(enter, leave).sum() * cell / mesh.volume)
    return HullQuality(n_hulls=len(hulls), volume_ratio=volume_ratio, excess=excess, missing=missing)


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


def decomposition_for(mesh: trimesh.Trimesh) -> DecompositionConfig:
    """The decomposition settings :func:`object_from_mesh` uses for ``mesh`` when given none.

    Meshes of at most :data:`DENSE_FACES` faces get the defaults. Denser ones (scans, CAD
    exports) get :data:`DENSE_DECOMPOSITION`: CoACD sees them cut to 3,000 faces, with a coarser
    concavity threshold (0.07) and half the MCTS iterations (15). On the real-mesh set's eight
    dense closed meshes (8k-66k faces) that took CoACD from 5-60 s of CPU to 2.4-10 s, with the
    same hull count (22-32 of 32), volume ratio within 6% and excess within 0.02
    (``benchmarks/coacd_time.py``). Fewer hulls (16) were slower (more merging) and filled more
    of the cavities (excess +0.03-0.07); CoACD's ``resolution`` at 250 changed neither time nor
    hulls. CoACD scales every mesh to a unit box, so an object's size in metres changes neither.
    The quality guard of :func:`object_from_mesh` redoes hulls from these settings with the
    defaults where they fail it.
    """
    return DecompositionConfig() if len(mesh.faces) <= DENSE_FACES else DENSE_DECOMPOSITION


def _guard_score(quality: HullQuality) -> float:
    """How far the worse of excess and missing is toward its limit (> 1: the guard fails)."""
    return max(quality.excess / MAX_EXCESS, quality.missing / MAX_MISSING)


def _guarded_hulls(
    mesh: trimesh.Trimesh, decomposition: DecompositionConfig | None
) -> tuple[tuple[np.ndarray, ...], list[str]]:
    """Hulls of ``mesh`` and notes on their quality.

    Hulls made with :func:`decomposition_for`'s faster settings that fail the guard (more than
    :data:`MAX_EXCESS` excess or :data:`MAX_MISSING` missing, :class:`HullQuality`) are made again
    with the defaults, and the better set is kept; hulls that still fail are noted.
    """
    config = decomposition or decomposition_for(mesh)
    hulls = decompose(mesh, config)
    quality = hull_quality(mesh, hulls)
    notes = []
    if _guard_score(quality) > 1.0 and decomposition is None and config != DecompositionConfig():
        try:
            again = decompose(mesh, DecompositionConfig())
        except DecompositionTimeout as late:  # the faster settings' hulls are kept, with why
            notes.append(f"hulls not made again with the default settings: {late}")
        else:
            again_quality = hull_quality(mesh, again)
            if _guard_score(again_quality) < _guard_score(quality):
                notes.append(
                    f"hulls made again with the default settings: the faster ones' excess {quality.excess:.2f}, "
                    f"missing {quality.missing:.2f}"
                )
                hulls, quality = again, again_quality
    if _guard_score(quality) > 1.0:
        notes.append(
            f"hull quality below the guard ({quality.n_hulls} hulls): they fill {quality.excess:.0%} of the free space "
            f"seen along an axis (limit {MAX_EXCESS:.0%}: a cavity may be closed) and leave {quality.missing:.0%} "
            f"of the surface uncovered (limit {MAX_MISSING:.0%}); pass a DecompositionConfig with a lower threshold"
        )
    return hulls, notes


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
