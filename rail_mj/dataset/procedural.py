"""The labelled procedural dataset: meshes in random poses plus ground-truth affordances.

ModelNet40 cannot be downloaded here, so objects are generated (see
:mod:`rail_mj.dataset.shapes`) in two families. ``core`` (the default, the published
figures) holds the paper's eight classes, four extra everyday classes,
defective look-alikes that do not work, and distractors. ``world`` holds the
shapes real meshes have and the core family lacks (armchairs, bar chairs, shell
chairs, stools, sofas, bowls of real proportions, long-handled pans, scoops,
goblets, open-front boxes, beds, desks, consoles, near misses such as ladles,
ashtrays, risers and cartons), and mixes in scan-like corruption (below).
``family="all"`` is both. Every object is written in a seeded random
orientation (or, with ``orientation="as_built"``, standing as built and turned
about its up), roughly centred at the origin, in metres with +z as the file's up
axis unless its label says otherwise (``units``, ``up``); ``functional_up`` in
its label is the file-frame unit vector that must point up for the object to
work (omitted when it affords none of the requested names), and ``nominal_up``
is the same vector for every object, defects and distractors included (their
as-built pose).

What each class affords and why is the ground truth (:mod:`rail_mj.dataset.ground_truth`); the labels
are :class:`~rail_mj.dataset.labels.LabelRecord` lines (:mod:`rail_mj.dataset.labels`).

Corruption (:data:`~rail_mj.dataset.ground_truth.CORRUPTIONS`) is applied to objects of either family with a
random stream of its own, so the object underneath is the clean one: ``noise``,
``holes``, ``open_shell`` and ``uneven_bottom`` change the mesh the way a scanner
does and leave the ground truth as it is; ``scale10`` (the file in units of
0.1 m, label ``units=0.1``) and ``y_up`` (the file +y up, label ``up="y"``) test
that the loader honours the label; ``scale10_unlabelled`` writes the file 10x
too large with ``units=1`` and labels the object that file describes (only for
classes whose 10x object affords nothing). The world family corrupts
:data:`~rail_mj.dataset.ground_truth.WORLD_CORRUPTION_RATE` of its objects with one or two of the first six;
``corrupt=`` overrides that for every object. The label lists what was applied.

CLI (:mod:`rail_mj.dataset.cli` hands every command but ``real`` to :func:`main`)::

    python -m rail_mj.dataset --out DIR [--family core|world|all] [--classes cup,bowl] [--per-class N]
                              [--seed S] [--affordances cup,chair] [--corrupt noise,y_up|none]
                              [--orientation random|as_built]
"""

from __future__ import annotations

import argparse
import math
import sys
import zlib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh
import trimesh.exchange.obj
from scipy.spatial import ConvexHull

from rail_mj.affordances import PAPER_AFFORDANCES
from rail_mj.affordances import label_key as normalize_affordance
from rail_mj.core.cli import EXIT_OK, object_bar, report_error
from rail_mj.core.errors import ConfigError, DatasetError
from rail_mj.core.runfiles import publish, staging_dir, write_synced
from rail_mj.dataset.ground_truth import (
    AFFORDANCES,
    CLASS_SPECS,
    CLASSES,
    CORRUPTIONS,
    FAMILIES,
    MIXED_CORRUPTIONS,
    SCALE10_UNLABELLED_CLASSES,
    WORLD_CLASSES,
    WORLD_CORRUPTION_RATE,
    family_classes,
    ground_truth_markdown,
)
from rail_mj.dataset.labels import LABELS_FILE, LabelRecord
from rail_mj.dataset.shapes import GENERATORS, GEOMETRIC_CORRUPTIONS, densify

__all__ = [
    "MAX_FACES",
    "plan_diameter",
    "upside_down_is_itself",
    "generate",
    "main",
]

MAX_FACES = 5000  # keeps CoACD fast
GRID = 1e-6  # written vertices lie on a 1 µm grid, so a reader that merges coincident vertices sees the same mesh


def plan_diameter(vertices: np.ndarray) -> float:
    """Largest distance between two points of the vertices' projection onto the xy plane."""
    xy = np.asarray(vertices, dtype=np.float64)[:, :2]
    hull = xy[ConvexHull(xy).vertices]
    return float(np.max(np.linalg.norm(hull[:, None] - hull[None], axis=-1)))


def _resolve_names(
    requested: str | Sequence[str] | None, valid: Sequence[str], what: str, norm: Callable[[str], str]
) -> list[str]:
    if requested is None:
        return list(valid)
    if isinstance(requested, str):  # "cup,bowl" as the CLI takes it
        requested = requested.split(",")
    names = [norm(n) for n in requested if n.strip()]
    if not names:
        raise DatasetError(f"no {what} given; valid {what}: {', '.join(valid)}")
    unknown = [n for n in names if n not in valid]
    if unknown:
        raise DatasetError(f"unknown {what} {', '.join(map(repr, unknown))}; valid {what}: {', '.join(valid)}")
    return list(dict.fromkeys(names))


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)  # a normalised 4-D Gaussian is a uniform random rotation
    return trimesh.transformations.quaternion_matrix(q / np.linalg.norm(q))


def _snap_to_grid(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh with vertices rounded to :data:`GRID`, coincident ones merged and collapsed faces dropped."""
    v = np.round(np.asarray(mesh.vertices) / GRID) * GRID + 0.0
    uniq, inv = np.unique(v, axis=0, return_inverse=True)
    f = inv.reshape(-1)[np.asarray(mesh.faces)]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    out = trimesh.Trimesh(vertices=uniq, faces=f[keep], process=False)
    out.remove_unreferenced_vertices()
    return out


def _check(name: str, built: trimesh.Trimesh, written: trimesh.Trimesh) -> None:
    """Generator invariants: the built mesh is in the class's size ranges, the written one is a closed solid."""
    spec = CLASS_SPECS[name]
    problems = []
    lo, hi = built.bounds
    tol = 1e-3
    h, p = hi[2] - lo[2], plan_diameter(built.vertices)
    if not spec.height[0] - tol <= h <= spec.height[1] + tol:
        problems.append(f"height {h:.3f} m outside {spec.height}")
    if not spec.plan[0] - tol <= p <= spec.plan[1] + tol:
        problems.append(f"plan diameter {p:.3f} m outside {spec.plan}")
    if not written.is_watertight or not written.is_winding_consistent:
        problems.append("not watertight")
    if not written.volume > 0:
        problems.append(f"volume {written.volume:.3g} <= 0")
    if len(written.faces) > MAX_FACES:
        problems.append(f"{len(written.faces)} faces > {MAX_FACES}")
    if problems:
        raise DatasetError(f"generator for {name!r} made an invalid mesh: {'; '.join(problems)}")



def _resolve_classes(classes: str | Sequence[str] | None, family: str) -> list[str]:
    valid = family_classes(family)
    names = [n.strip() for n in (classes.split(",") if isinstance(classes, str) else classes or ()) if n.strip()]
    elsewhere = [n for n in names if n not in valid and n in CLASS_SPECS]
    if elsewhere:
        where = ", ".join(f"{n!r} is in family {CLASS_SPECS[n].family!r}" for n in elsewhere)
        raise DatasetError(f"classes not in family {family!r}: {where}; pass that family (or 'all'); "
                           f"valid classes of {family!r}: {', '.join(valid)}")
    return _resolve_names(classes, valid, "classes", str.strip)


def _resolve_corrupt(corrupt: str | Sequence[str] | None) -> tuple[str, ...] | None:
    """None (each family's default), () for none, or the named corruptions in the order they apply."""
    if corrupt is None:
        return None
    names = [n.strip() for n in (corrupt.split(",") if isinstance(corrupt, str) else corrupt) if n.strip()]
    if names == ["none"]:
        return ()
    valid = ", ".join(("none", *CORRUPTIONS))
    if not names or "none" in names:
        raise DatasetError(f"corrupt: give 'none' alone or corruption names; valid: {valid}")
    unknown = [n for n in names if n not in CORRUPTIONS]
    if unknown:
        raise DatasetError(f"unknown corruption {', '.join(map(repr, unknown))}; valid: {valid}")
    if {"scale10", "scale10_unlabelled"} <= set(names):
        raise DatasetError("corrupt: 'scale10' (labelled units) and 'scale10_unlabelled' (wrong units) exclude each "
                           "other; give one")
    return tuple(c for c in CORRUPTIONS if c in names)


def _check_unlabelled_scale(class_names: Sequence[str], forced: tuple[str, ...] | None) -> None:
    if forced and "scale10_unlabelled" in forced:
        refused = [n for n in class_names if n not in SCALE10_UNLABELLED_CLASSES]
        if refused:
            raise DatasetError(f"scale10_unlabelled labels the 10x object, which only these classes leave affording "
                               f"nothing: {', '.join(SCALE10_UNLABELLED_CLASSES)}; not {', '.join(refused)} "
                               "(pass --classes from that list, with --family all for the core ones)")


def _mixed_corruptions(name: str, i: int, seed: int) -> tuple[str, ...]:
    """The world family's fixed draw for object ``i``: none, or one or two of MIXED_CORRUPTIONS."""
    if CLASS_SPECS[name].family != "world":
        return ()
    rng = np.random.default_rng([seed, zlib.crc32(name.encode()), i, zlib.crc32(b"corruptions")])
    if rng.random() >= WORLD_CORRUPTION_RATE:
        return ()
    picked = set(rng.choice(len(MIXED_CORRUPTIONS), size=1 if rng.random() < 0.7 else 2, replace=False).tolist())
    return tuple(c for j, c in enumerate(MIXED_CORRUPTIONS) if j in picked)


#: Surface points :func:`upside_down_is_itself` checks, and the largest distance (fraction of the box diagonal) that
#: any may lie from the unturned surface: a pouf's 6 mm cushion lip stays within it, its 3-6 cm feet do not.
_SYMMETRY_POINTS = 2000
_SYMMETRY_TOL = 0.015


def upside_down_is_itself(mesh: trimesh.Trimesh) -> bool:
    """Whether the as-built (z-up) mesh turned upside down, by a half turn about its box's x or y axis, is the
    same shape: then no pose of it can tell its top from its bottom, and both are its functional pose."""
    lo, hi = mesh.bounds
    centre = (lo + hi) / 2
    # trimesh types the result as a union over its sample_color flag; without it there are 2 items
    points, _ = trimesh.sample.sample_surface(mesh, _SYMMETRY_POINTS, seed=0)  # pyright: ignore[reportAssignmentType]
    tol = _SYMMETRY_TOL * float(np.linalg.norm(hi - lo))
    for flip in ((1.0, -1.0, -1.0), (-1.0, 1.0, -1.0)):  # half turns about x and about y
        turned = (points - centre) * flip + centre
        _, dist, _ = trimesh.proximity.closest_point(mesh, turned)
        if float(np.max(dist)) < tol:
            return True
    return False


def _posed(mesh: trimesh.Trimesh, rot: np.ndarray) -> trimesh.Trimesh:
    """The mesh turned by ``rot``, centred on the origin and snapped to the grid."""
    posed = mesh.copy()
    posed.apply_transform(rot)
    posed.apply_translation(-posed.bounds.mean(axis=0))
    return _snap_to_grid(posed)


def generate(
    out_dir: str | Path,
    *,
    classes: str | Sequence[str] | None = None,
    per_class: int = 10,
    seed: int = 0,
    affordances: str | Sequence[str] | None = None,
    family: str = "core",
    corrupt: str | Sequence[str] | None = None,
    orientation: Literal["random", "as_built"] = "random",
    progress: Callable[[int, int, LabelRecord], None] | None = None,
) -> list[LabelRecord]:
    """Write ``per_class`` objects of each class to ``out_dir/meshes`` and their labels to ``out_dir/labels.jsonl``.

    ``classes`` defaults to every class of ``family`` (``core``, ``world`` or ``all``). Object
    ``<class>_<i>`` depends only on (seed, class, i), so subsets of classes reproduce the same meshes.
    ``corrupt`` is None for each family's default (the world family corrupts
    :data:`~rail_mj.dataset.ground_truth.WORLD_CORRUPTION_RATE` of its objects, the core family none),
    ``"none"``, or names of :data:`~rail_mj.dataset.ground_truth.CORRUPTIONS` applied to every object; a
    corruption draws from a stream of its own, so the object underneath is the clean one. ``affordances``
    defaults to the paper's eight. ``orientation`` ``"random"`` writes each object in a random orientation (labels
    ``oriented=False``); ``"as_built"`` stands it as built, turned about its up by the same draw's yaw (``oriented``),
    the way a real mesh file comes;
    ``progress(done, total, record)`` is called after each object. The files are built in a hidden
    staging folder inside ``out_dir`` and moved into place when all are written, ``labels.jsonl``
    last: a run killed part way leaves no ``labels.jsonl`` (the old one is removed first), never one
    listing part of the objects.
    """
    class_names = _resolve_classes(classes, family)
    aff_names = _resolve_names(affordances if affordances is not None else PAPER_AFFORDANCES, list(AFFORDANCES),
                               "affordances", normalize_affordance)
    forced = _resolve_corrupt(corrupt)
    _check_unlabelled_scale(class_names, forced)
    if isinstance(per_class, bool) or not isinstance(per_class, int) or per_class < 1:
        raise DatasetError(f"per_class must be a positive integer, got {per_class!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise DatasetError(f"seed must be a non-negative integer, got {seed!r}")
    out = Path(out_dir)
    total = len(class_names) * per_class
    records: list[LabelRecord] = []
    with staging_dir(out) as stage:
        (stage / "meshes").mkdir()
        for name in class_names:
            for i in range(per_class):
                rng = np.random.default_rng([seed, zlib.crc32(name.encode()), i])
                built = GENERATORS[name](rng)
                rot = _random_rotation(rng)
                if orientation == "as_built":  # the same draw (the stream goes on alike), its yaw alone
                    yaw = math.atan2(rot[1, 0], rot[0, 0])
                    rot = np.asarray(trimesh.transformations.rotation_matrix(yaw, [0, 0, 1]), dtype=np.float64)
                mesh = _posed(built.mesh, rot)
                _check(name, built.mesh, mesh)
                applied = forced if forced is not None else _mixed_corruptions(name, i, seed)
                notes = [f"{built.notes}; written " + ("in a random orientation" if orientation == "random"
                                                       else "as built, turned about its up")]
                up = np.asarray(rot[:3, 2], dtype=np.float64)
                units, up_axis = 1.0, "z"
                geometric = [c for c in applied if c in GEOMETRIC_CORRUPTIONS]
                if geometric:
                    work = densify(built.mesh)
                    for c in geometric:
                        own = np.random.default_rng([seed, zlib.crc32(name.encode()), i, zlib.crc32(c.encode())])
                        work, what = GEOMETRIC_CORRUPTIONS[c](work, own)
                        notes.append(what)
                    mesh = _posed(work, rot)
                    if len(mesh.faces) > MAX_FACES:
                        raise DatasetError(f"corrupting {name}_{i:03d} ({', '.join(geometric)}) made "
                                           f"{len(mesh.faces)} faces > {MAX_FACES}")
                same_upside_down = upside_down_is_itself(built.mesh)
                if "y_up" in applied:  # the file is +y up: the loader's (x, y, z) -> (x, -z, y) gives the mesh back
                    flipped = mesh.vertices[:, [0, 2, 1]] * [1.0, 1.0, -1.0] + 0.0
                    mesh = trimesh.Trimesh(vertices=flipped, faces=mesh.faces, process=False)
                    up, up_axis = up[[0, 2, 1]] * [1.0, 1.0, -1.0], "y"
                    notes.append("file written +y up (label up=y)")
                if "scale10" in applied or "scale10_unlabelled" in applied:
                    mesh = trimesh.Trimesh(vertices=mesh.vertices * 10.0, faces=mesh.faces, process=False)
                    if "scale10" in applied:
                        units = 0.1
                        notes.append("file numbers are 10x the metres (label units=0.1)")
                    else:
                        notes.append("file numbers are 10x the metres and the label says metres: the object is "
                                     "10x too large, and labelled as such (affords nothing)")
                rel = f"meshes/{name}_{i:03d}.obj"
                write_synced(stage / rel,
                             trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_texture=False))
                up_t = tuple(round(float(x), 9) + 0.0 for x in up)
                truth = {a: a in CLASS_SPECS[name].affords and "scale10_unlabelled" not in applied for a in aff_names}
                # populate_by_name: pyright sees only the field's alias "class" as the keyword
                record = LabelRecord(  # pyright: ignore[reportCallIssue]
                    mesh=rel,
                    class_name=name,  # pyright: ignore[reportCallIssue]
                    affordances=truth,
                    functional_up=up_t if any(truth.values()) else None,
                    equivalent_ups=([tuple(-v + 0.0 for v in up_t)]
                                    if same_upside_down and any(truth.values()) else None),
                    nominal_up=up_t,
                    units=units,
                    up=up_axis,
                    oriented=orientation == "as_built",
                    corruptions=list(applied) or None,
                    notes="; ".join(notes),
                )
                records.append(record)
                if progress is not None:
                    progress(len(records), total, record)
        write_synced(stage / LABELS_FILE, "".join(r.to_json() + "\n" for r in records))
        publish(stage, out, LABELS_FILE)
    return records


def _split(text: str | None) -> list[str] | None:
    return None if text is None else text.split(",")


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rail_mj.dataset`` (all but ``real``); returns the exit status (the rule of rail_mj.core.cli:
    0 written, 1 generation failed, 2 bad command line and nothing written, 130 interrupted; errors as
    ``error:`` on stderr)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(prog="python -m rail_mj.dataset",
                                     description="Generate the labelled procedural dataset.")
    parser.add_argument("--out", type=Path, help="output folder (meshes/ and labels.jsonl)")
    parser.add_argument("--family", default="core", choices=tuple(FAMILIES),
                        help="class family (default core, the published set; world: shapes of real meshes; all: both)")
    parser.add_argument("--classes", help=f"comma-separated classes of the family (default all of it); core: "
                        f"{','.join(CLASSES)}; world: {','.join(WORLD_CLASSES)}")
    parser.add_argument("--corrupt", help=f"'none' or comma-separated corruptions applied to every object (default: "
                        f"the world family mixes them in): {','.join(CORRUPTIONS)}")
    parser.add_argument("--per-class", type=int, default=10, help="objects per class (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--affordances",
                        help=f"comma-separated names (default the paper's eight); valid: {','.join(AFFORDANCES)}")
    parser.add_argument("--orientation", default="random", choices=("random", "as_built"),
                        help="random (default): each object in a random orientation; as_built: standing as built, "
                             "as a real mesh file comes (labels oriented=true)")
    parser.add_argument("--matrix", action="store_true", help="print the ground-truth matrix as Markdown and exit")
    args = parser.parse_args(argv)
    if args.matrix:
        sys.stdout.write(ground_truth_markdown())
        return EXIT_OK
    if args.out is None:
        return report_error(ConfigError("--out is required (or use --matrix)"))
    if args.per_class < 1:
        return report_error(ConfigError(f"--per-class must be >= 1, got {args.per_class}"))
    if args.seed < 0:
        return report_error(ConfigError(f"--seed must be >= 0, got {args.seed}"))
    try:  # bad names are command-line errors (exit 2); generate raises DatasetError for both kinds
        _check_unlabelled_scale(_resolve_classes(args.classes, args.family), _resolve_corrupt(args.corrupt))
        _resolve_names(args.affordances, list(AFFORDANCES), "affordances", normalize_affordance)
    except DatasetError as e:
        return report_error(ConfigError(str(e)))
    try:
        with object_bar() as tick:
            records = generate(args.out, classes=_split(args.classes), per_class=args.per_class, seed=args.seed,
                               affordances=_split(args.affordances), family=args.family, corrupt=args.corrupt,
                               orientation=args.orientation, progress=tick)
    except (DatasetError, KeyboardInterrupt) as e:
        return report_error(e)
    except OSError as e:
        return report_error(DatasetError(f"cannot write the dataset to {args.out}: {e.strerror or e}"))
    print(f"wrote {len(records)} objects to {args.out}")
    return EXIT_OK
