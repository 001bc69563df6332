"""Mesh files: the formats read, the checks made before parsing (size, declared face count), reading to a trimesh.

Every mesh file entering rail_mj goes through :func:`load_mesh`, which converts it to metres, z up,
and repairs it (:func:`rail_mj.mesh.repair.repair_mesh`). Files over :data:`MAX_FILE_BYTES`, or whose
header declares more than :data:`~rail_mj.mesh.repair.MAX_FACES` faces, are refused before parsing.
"""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import Literal, cast

import numpy as np
import trimesh
import trimesh.resolvers

from rail_mj.core.errors import ConfigError, MeshError
from rail_mj.mesh.repair import MAX_FACES, _fail, _too_many_faces, repair_mesh

__all__ = ["SUPPORTED_EXTENSIONS", "MAX_FILE_BYTES", "load_mesh"]

SUPPORTED_EXTENSIONS: tuple[str, ...] = (".obj", ".stl", ".ply", ".off", ".glb", ".gltf")
#: Larger files are refused before parsing: MAX_FACES faces as binary STL (50 bytes a face) fit under it.
MAX_FILE_BYTES = 256 * 2**20
_FORMATS = "OBJ, STL (binary or ASCII), PLY, OFF, GLB, GLTF"
# Formats trimesh reads as text: it decodes non-UTF-8 text with charset_normalizer, an optional
# module rail_mj does not install, so such files are transcoded here first.
_TEXT_FORMATS = ("obj", "off", "gltf")

_Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def _not_valid(label: str, fmt: str, why: str) -> MeshError:
    return _fail(label, f"is not a valid {fmt.upper()} file: {why}; accepted formats: {_FORMATS}")


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
        return cast(trimesh.Trimesh, trimesh.util.concatenate(meshes))
    if not isinstance(loaded, trimesh.Trimesh):
        raise _fail(label, f"has no faces (it holds a {type(loaded).__name__}); a mesh needs triangles")
    return loaded


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
