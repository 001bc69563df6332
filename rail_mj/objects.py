"""Objects: mesh loading and repair, CoACD convex decomposition (cached), RailObject construction.

Every mesh entering rail_mj goes through :func:`load_mesh` (files) or
:func:`object_from_mesh` (in-memory meshes); both repair and validate it the
same way, so the mesh frame is always metres, z up.

Meshes over :data:`FACE_BUDGET` faces are decimated (quadric decimation, trimesh's
``simplify_quadric_decimation`` backed by fast-simplification) before any step whose cost
grows faster than the face count; :func:`mesh_notes` says what was done. Meshes over
:data:`MAX_FACES` faces or files over :data:`MAX_FILE_BYTES` are refused at once.
"""

from __future__ import annotations

import hashlib
import io
import json
import re
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from rail_mj.errors import ConfigError, DecompositionError, MeshError
from rail_mj.paths import cache_dir
from rail_mj.types import RailObject

__all__ = [
    "SUPPORTED_EXTENSIONS",
    "DEFAULT_DENSITY",
    "MAX_EXTENT",
    "MIN_EXTENT",
    "MJX_MAX_HULL_VERTICES",
    "FACE_BUDGET",
    "MAX_FACES",
    "MAX_FILE_BYTES",
    "DecompositionConfig",
    "load_mesh",
    "repair_mesh",
    "mesh_notes",
    "mesh_hash",
    "decompose",
    "reduce_hull",
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


def _decimate(mesh: trimesh.Trimesh, label: str) -> trimesh.Trimesh:
    """``mesh`` decimated to :data:`FACE_BUDGET` faces (quadric error, fast-simplification) and cleaned."""
    try:
        small = mesh.simplify_quadric_decimation(face_count=FACE_BUDGET)
    except Exception as exc:  # fast-simplification reports failures as assorted types
        raise _fail(
            label,
            f"has {len(mesh.faces):,} faces, over the face budget of {FACE_BUDGET:,}, and decimating it failed "
            f"({type(exc).__name__}: {exc}); decimate it first, e.g. with Blender's Decimate modifier",
        ) from exc
    out = trimesh.Trimesh(
        vertices=np.asarray(small.vertices, dtype=np.float64), faces=np.asarray(small.faces, dtype=np.int64),
        process=False,
    )
    _clean(out)
    if len(out.faces) == 0:
        raise _fail(label, f"has no faces left after decimating its {len(mesh.faces):,} faces to {FACE_BUDGET:,}")
    return out


def repair_mesh(mesh: trimesh.Trimesh, *, label: str = "mesh") -> trimesh.Trimesh:
    """Validate and repair a mesh (returns a new one); raise MeshError naming ``label``.

    Repairs: merge duplicate vertices, drop degenerate and duplicate faces and
    unreferenced vertices, decimate to :data:`FACE_BUDGET` faces when over it,
    make winding consistent and normals outward.
    Rejects: no faces, more than :data:`MAX_FACES` faces, non-finite vertices,
    flat meshes, absurd sizes. What was changed beyond cleaning is listed by
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
    if largest > MAX_EXTENT:
        raise _fail(
            label,
            f"is too large: largest extent {largest:.4g} m > {MAX_EXTENT:g} m; if the file is in "
            "millimetres or centimetres pass units=0.001 or units=0.01 (metres per mesh unit)",
        )
    if largest < MIN_EXTENT:
        raise _fail(
            label,
            f"is too small: largest extent {largest:.4g} m < {MIN_EXTENT * 1000:g} mm; pass units= the number "
            "of metres per mesh unit (1.0 if the file is already in metres; check it was not scaled twice)",
        )
    if len(out.faces) > FACE_BUDGET:
        n_faces = len(out.faces)
        out = _decimate(out, label)
        notes.append(f"decimated from {n_faces:,} to {len(out.faces):,} faces (face budget {FACE_BUDGET:,})")
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


def _cache_key(digest: str, config: DecompositionConfig) -> str:
    payload = json.dumps({"mesh": digest, "config": asdict(config)}, sort_keys=True)
    return hashlib.sha256(payload.encode()).hexdigest()


def _preprocess_mode(mesh: trimesh.Trimesh, config: DecompositionConfig) -> str:
    if config.preprocess_mode != "auto":
        return config.preprocess_mode
    return "off" if mesh.is_volume else "on"


def _run_coacd(mesh: trimesh.Trimesh, config: DecompositionConfig) -> list[np.ndarray]:
    import coacd

    coacd.set_log_level("error")
    try:
        parts = coacd.run_coacd(
            coacd.Mesh(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int32)),
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
    except Exception as exc:  # CoACD surfaces C++ failures as assorted Python errors
        raise DecompositionError(f"CoACD failed ({type(exc).__name__}: {exc})") from exc
    return [np.asarray(v, dtype=np.float64) for v, _ in parts]


def decompose(mesh: trimesh.Trimesh, config: DecompositionConfig | None = None) -> tuple[np.ndarray, ...]:
    """Convex hulls of ``mesh`` (mesh frame), each with <= ``config.max_hull_vertices`` vertices.

    Cached as .npz under ``cache_dir("hulls")``, keyed by the mesh arrays and the config.
    """
    config = config or DecompositionConfig()
    path = cache_dir("hulls") / f"{_cache_key(mesh_hash(mesh), config)}.npz"
    if path.exists():
        try:
            with np.load(path) as data:
                return tuple(data[f"hull{i}"] for i in range(len(data.files)))
        except (OSError, ValueError, KeyError, zipfile.BadZipFile):
            path.unlink(missing_ok=True)  # a damaged cache entry is recomputed, not trusted
    if config.convex_shortcut and mesh.is_convex:
        raw = [np.asarray(mesh.vertices, dtype=np.float64)]
    else:
        raw = _run_coacd(mesh, config)
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
    """Repair, decompose and measure an in-memory mesh (metres, z up)."""
    if not (np.isfinite(density) and density > 0):
        raise ConfigError(f"density must be a positive finite number in kg/m^3, got {density}")
    if not name:
        raise ConfigError("name must be a non-empty string")
    mesh = repair_mesh(mesh, label=source or name)
    hulls = decompose(mesh, decomposition)
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
