"""Mesh repair: cleaning, decimation of huge meshes, rejection of unusable ones, and the notes on what was done.

Meshes over :data:`FACE_BUDGET` faces are decimated (closed ones by manifold3d, so they stay
closed; others by quadric decimation, trimesh's ``simplify_quadric_decimation`` backed by
fast-simplification) before any step whose cost grows faster than the face count; a mesh of more than
:data:`MAX_PIECES` closed pieces is united into one surface (manifold3d);
:func:`mesh_notes` says what was done. Meshes over :data:`MAX_FACES` faces are refused at once.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
import trimesh
from scipy.spatial import KDTree

from rail_mj.core.errors import MeshError

__all__ = [
    "MAX_EXTENT",
    "MIN_EXTENT",
    "FACE_BUDGET",
    "MAX_FACES",
    "MAX_PIECES",
    "repair_mesh",
    "mesh_notes",
]

#: Largest allowed extent after scaling, metres.
MAX_EXTENT = 10.0
#: Smallest allowed largest-extent after scaling, metres.
MIN_EXTENT = 0.005
#: Meshes with more faces are decimated to this many before repair and decomposition. CoACD's time
#: grows faster than the face count (default config, a torus, CPU s on 2 cores: 5k faces 3.2, 10k 5.1,
#: 20k 8.5, 50k 24), oriented bounds and winding repair too, and 32 hulls of <= 64 vertices keep none
#: of the extra detail. Household models and the procedural dataset (< 3k faces) stay below it.
FACE_BUDGET = 20_000
#: Meshes with more faces are refused: reading, cleaning and decimating cost ~3 s of CPU and ~0.6 GB
#: per million faces here (2M: 5.3 s, 1.2 GB), so this many take ~12 s and ~2.5 GB before CoACD.
MAX_FACES = 4_000_000
#: A mesh of more closed pieces than this is united into one surface. Up to it the decomposition takes each piece
#: on its own (DecompositionConfig's default hull cap, 32: a convex piece is its own hull); past it CoACD took the
#: pieces as one surface, and a bowl exported, as collision geometry often is, as about forty overlapping convex
#: pieces ran out of CoACD's time budget. Their union is the surface a simulator collides with.
MAX_PIECES = 32
# manifold3d's simplification gives up (quadric decimation takes over) past this tolerance, a fraction
# of the largest extent: beyond it the surface may move more than CoACD's own concavity tolerance.
_MAX_SIMPLIFY_TOLERANCE = 0.02
# A face is loose when its piece (faces joined by shared edges) has fewer faces than a tetrahedron;
# a mesh with more than this fraction of loose faces is refused as a triangle soup.
_MIN_PIECE_FACES = 4
_MAX_LOOSE_FRACTION = 0.5
# A mesh is flat when its smallest extent is below this fraction of its largest.
_FLAT_RATIO = 1e-6
#: Vertices closer than this fraction of the mesh's largest extent are one vertex. Files that store float32 (STL,
#: glTF) or round to 7 significant digits keep two faces' copies of one vertex a few roundings apart (2^-23 of the
#: coordinate each: a robosuite can's lid and body, 2-8 nm apart at 4 cm, left 72 open edges, so CoACD remeshed it
#: and filled its lid's recess); a millionth of a 10 cm cup is 0.1 µm, far below any feature the physics resolves.
_WELD = 1e-6

# trimesh.Trimesh.metadata key under which repair_mesh records what it did to the mesh.
_NOTES_KEY = "rail_mj_notes"


def _fail(label: str, problem: str) -> MeshError:
    return MeshError(f"{label}: {problem}")


def _too_many_faces(label: str, n_faces: int) -> MeshError:
    return _fail(
        label,
        f"has {n_faces:,} faces, over the limit of {MAX_FACES:,} (meshes over {FACE_BUDGET:,} faces are "
        f"decimated to {FACE_BUDGET:,}, up to that limit); decimate it first, e.g. with Blender's Decimate "
        "modifier or MeshLab's quadric edge collapse",
    )


def _clean(mesh: trimesh.Trimesh) -> None:
    """Merge duplicate vertices (and those within :data:`_WELD` of each other), drop degenerate and duplicate faces
    and unreferenced vertices (in place)."""
    mesh.merge_vertices()
    _weld(mesh)
    mesh.update_faces(mesh.nondegenerate_faces() & mesh.unique_faces())
    mesh.remove_unreferenced_vertices()


def _weld(mesh: trimesh.Trimesh) -> None:
    """Make vertices within :data:`_WELD` of the largest extent of each other one (in place): trimesh's merge rounds
    coordinates to a grid, so two copies of a vertex a few nanometres apart that straddle a grid line stay apart."""
    vertices = np.asarray(mesh.vertices)
    tolerance = _WELD * float(np.ptp(vertices, axis=0).max())
    if tolerance <= 0.0:
        return
    pairs = KDTree(vertices).query_pairs(tolerance, output_type="ndarray")
    if len(pairs) == 0:
        return
    n = len(vertices)
    graph = scipy.sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, group = scipy.sparse.csgraph.connected_components(graph, directed=False)
    _, first = np.unique(group, return_index=True)  # each group's first vertex stands for it
    mesh.faces = first[group][np.asarray(mesh.faces)]


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

    Repairs: merge duplicate vertices (and weld those within a millionth of the largest extent), drop degenerate
    and duplicate faces and
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
    united = _united(out)
    if united is not None:
        notes.append(f"united {united[1]} overlapping closed pieces into {united[2]} (more than {MAX_PIECES})")
        out = united[0]
    trimesh.repair.fix_normals(out)
    if notes:
        out.metadata[_NOTES_KEY] = notes
    return out


def mesh_notes(mesh: trimesh.Trimesh) -> list[str]:
    """What :func:`repair_mesh` changed in ``mesh`` beyond cleaning it (e.g. decimation); empty if nothing."""
    return list(mesh.metadata.get(_NOTES_KEY, ()))


def _united(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, int, int] | None:
    """``mesh``'s pieces united by manifold3d when it has more than :data:`MAX_PIECES` and every one that can enclose
    anything is closed (a union of open surfaces is undefined; loose triangles are dropped, as the decomposition
    drops them); the union and the pieces' count before and after; None otherwise or when the union fails."""
    labels = _body_labels(mesh)
    found, sizes = np.unique(labels, return_counts=True)
    kept = found[sizes >= _MIN_PIECE_FACES]
    if len(kept) <= MAX_PIECES:
        return None
    pieces = [trimesh.Trimesh(mesh.vertices, mesh.faces[labels == k]) for k in kept]
    if not all(p.is_watertight for p in pieces):
        return None
    try:
        union = trimesh.boolean.union(pieces, engine="manifold")
    except (ValueError, RuntimeError, ImportError):
        return None
    if union is None or len(union.faces) == 0:
        return None
    _clean(union)
    return union, len(pieces), len(np.unique(_body_labels(union)))


def _body_labels(mesh: trimesh.Trimesh) -> np.ndarray:
    """Per face, the connected piece (faces joined by shared edges) it belongs to."""
    return trimesh.graph.connected_component_labels(mesh.face_adjacency, node_count=len(mesh.faces))
