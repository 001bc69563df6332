"""The labelled procedural dataset: meshes in random poses plus ground-truth affordances.

ModelNet40 cannot be downloaded here, so objects are generated (see
:mod:`rail_mj.shapes`): the paper's eight classes, four extra everyday classes,
defective look-alikes that do not work, and distractors. Every object is
written in a seeded random orientation, roughly centred at the origin, in
metres with +z as the file's up axis; ``functional_up`` in its label is the
mesh-frame unit vector that must point up for the object to work (omitted when
it affords none of the requested names), and ``nominal_up`` is the same vector
for every object, defects and distractors included (their as-built pose).

The ground truth is *physical*: an object affords a name when the imagination
test for that name would succeed on it in some stable pose (droplets or items
stay in a container, a sitting box stays on a seat, a box stays on a level
top, a food disc stays on a rimmed plate) **and** its dimensions fall in the
name's size envelope, which the affordance analyser checks first. Class size
ranges are kept clear of every envelope boundary so no answer depends on the
random instance. ``python -m rail_mj.dataset --matrix`` prints the matrix, the
definitions and the reasons for the cross cases (kept in docs/ground_truth.md).

CLI::

    python -m rail_mj.dataset --out DIR [--classes cup,bowl] [--per-class N] [--seed S]
                              [--affordances cup,chair]
    python -m rail_mj.dataset real --out DIR    # the real-mesh development set, see rail_mj.realset
"""

from __future__ import annotations

import argparse
import json
import sys
import zlib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator
from scipy.spatial import ConvexHull

from rail_mj.affordances import PAPER_AFFORDANCES, get
from rail_mj.affordances import label_key as normalize_affordance
from rail_mj.errors import DatasetError
from rail_mj.runfiles import publish, staging_dir, write_synced
from rail_mj.shapes import BASKET_AGENT_MIN, BASKET_GAP, GENERATORS

__all__ = [
    "AFFORDANCES",
    "PAPER_AFFORDANCES",
    "ClassSpec",
    "CLASS_SPECS",
    "CLASSES",
    "PAPER_CLASSES",
    "EXTRA_CLASSES",
    "DEFECTS",
    "DISTRACTORS",
    "CROSS_REASONS",
    "LabelRecord",
    "ground_truth",
    "ground_truth_markdown",
    "normalize_affordance",
    "plan_diameter",
    "generate",
    "read_labels",
    "main",
]

LABELS_FILE = "labels.jsonl"
MAX_FACES = 5000  # keeps CoACD fast
GRID = 1e-6  # written vertices lie on a 1 µm grid, so a reader that merges coincident vertices sees the same mesh

#: Physical definition and size envelope of every affordance name the matrix answers, by registry key. These
#: are the dataset's own words, apart from the registry's rules: the ground truth those rules are measured by.
AFFORDANCES: dict[str, str] = {get(name).key: text for name, text in {
    "cup": "open-top vessel that holds liquid poured from above (droplets stay inside) and is held in one hand: "
    "rim Ø <= 12.5 cm, 6-16 cm tall, height >= 0.6 x rim Ø.",
    "bowl": "open-top vessel that holds liquid or food: rim Ø 12.5-35 cm, inner depth >= 4 cm, "
    "height <= 0.55 x rim Ø (wide and shallow).",
    "vase": "vessel that holds water and upright stems: opening 4-12 cm, 15-80 cm tall, height >= 1.5 x opening.",
    "basket": f"open-top container that holds solid items (agents Ø >= {100 * BASKET_AGENT_MIN:.1f} cm) dropped in and is carried: "
    "gaps narrower than the items are allowed, opening >= 12.5 cm, 4-35 cm deep, footprint <= 60 cm.",
    "bathtub": "water-tight open-top basin a lying person fits in: inner length >= 1.2 m, 0.35-0.8 m tall.",
    "plate": "flat level food surface with a raised rim that keeps a food disc on it: largest side 15-32 cm, 1-4 cm tall.",
    "table": "level rigid top on which a box placed from above stays: top 0.55-1.1 m above the ground, >= 0.5 m across, "
    "free space above.",
    "chair": "level seat for one person on which a sitting box stays: seat 0.38-0.55 m high, 0.3-0.7 m across, "
    ">= 0.8 m free above the seat; a backrest is optional.",
    "stool": "seat for one person usable without a backrest (sitting-box test): seat 0.38-0.85 m high (dining to bar), "
    "0.25-0.7 m across.",
    "bench": "seat for two or more (sitting-box test at two places side by side): seat 0.38-0.55 m high, >= 0.9 m long.",
    "shelf": "two or more level surfaces stacked >= 20 cm apart, each holding a box placed on it; top surface above 1.1 m "
    "or below others so it is not a table.",
    "tray": "rimmed flat surface carried with items on it: largest side 15-60 cm, height <= 4.5 cm and <= 0.2 x largest side.",
    "pot": "water-tight open-top cooking vessel: rim Ø 15-45 cm, 10-30 cm tall, height >= 0.55 x rim Ø.",
    "trash_bin": "open-top container for waste standing on the floor: opening >= 18 cm, 30-90 cm tall.",
    "pen_holder": "open-top container with a closed bottom that holds pens upright: opening 4-12.5 cm, 7-16 cm tall.",
}.items()}


@dataclass(frozen=True)
class ClassSpec:
    """One object class: what it affords and the size ranges its generator keeps to (m, build frame)."""

    name: str
    group: Literal["paper", "extra", "defect", "distractor"]
    affords: frozenset[str]
    height: tuple[float, float]  # z extent in the natural pose
    plan: tuple[float, float]  # largest distance between two points seen from above (handles included)
    mimics: str = ""  # for defects: the class they look like


def _spec(name: str, group: str, affords: Iterable[str], height: tuple[float, float], plan: tuple[float, float], mimics: str = "") -> ClassSpec:
    return ClassSpec(name, group, frozenset(affords), height, plan, mimics)  # type: ignore[arg-type]


#: Every class, by name.
CLASS_SPECS: dict[str, ClassSpec] = {
    s.name: s
    for s in (
        _spec("cup", "paper", {"cup", "pen_holder"}, (0.08, 0.14), (0.06, 0.17)),
        _spec("bowl", "paper", {"bowl", "basket"}, (0.05, 0.10), (0.13, 0.25)),
        _spec("vase", "paper", {"vase"}, (0.18, 0.45), (0.06, 0.22)),
        _spec("basket", "paper", {"basket"}, (0.10, 0.18), (0.20, 0.44)),
        _spec("bathtub", "paper", {"bathtub"}, (0.5, 0.6), (1.56, 2.0)),
        _spec("plate", "paper", {"plate", "tray"}, (0.015, 0.03), (0.18, 0.28)),
        _spec("table", "paper", {"table"}, (0.6, 0.8), (0.75, 1.75)),
        _spec("chair", "paper", {"chair", "stool"}, (0.4, 1.0), (0.55, 0.7)),
        _spec("pot", "extra", {"pot", "basket"}, (0.12, 0.22), (0.24, 0.39)),
        _spec("trash_bin", "extra", {"trash_bin"}, (0.4, 0.65), (0.22, 0.47)),
        _spec("tray", "extra", {"tray"}, (0.02, 0.04), (0.44, 0.62)),
        _spec("bench", "extra", {"bench"}, (0.42, 0.93), (1.04, 1.65)),
        _spec("cup_no_bottom", "defect", set(), (0.08, 0.14), (0.06, 0.17), "cup"),
        _spec("bowl_holed", "defect", set(), (0.05, 0.10), (0.13, 0.25), "bowl"),
        _spec("chair_high_seat", "defect", set(), (1.15, 1.75), (0.55, 0.7), "chair"),
        _spec("table_tilted", "defect", set(), (0.5, 1.0), (0.8, 1.5), "table"),
        _spec("vase_closed", "defect", set(), (0.18, 0.45), (0.06, 0.22), "vase"),
        _spec("solid_cylinder", "distractor", set(), (0.05, 0.2), (0.05, 0.15)),
        _spec("solid_box", "distractor", set(), (0.05, 0.25), (0.07, 0.44)),
        _spec("sphere", "distractor", set(), (0.05, 0.25), (0.05, 0.25)),
        _spec("cone", "distractor", set(), (0.05, 0.25), (0.05, 0.2)),
        _spec("torus", "distractor", set(), (0.02, 0.08), (0.12, 0.38)),
        _spec("rack", "distractor", {"shelf"}, (1.2, 1.8), (0.65, 1.08)),
    )
}

CLASSES: tuple[str, ...] = tuple(CLASS_SPECS)
PAPER_CLASSES: tuple[str, ...] = tuple(n for n, s in CLASS_SPECS.items() if s.group == "paper")
EXTRA_CLASSES: tuple[str, ...] = tuple(n for n, s in CLASS_SPECS.items() if s.group == "extra")
DEFECTS: tuple[str, ...] = tuple(n for n, s in CLASS_SPECS.items() if s.group == "defect")
DISTRACTORS: tuple[str, ...] = tuple(n for n, s in CLASS_SPECS.items() if s.group == "distractor")

#: Why the non-obvious cells of the matrix are what they are, by (class, affordance).
CROSS_REASONS: dict[tuple[str, str], str] = {
    ("cup", "bowl"): "false: rim Ø <= 12 cm is below the bowl envelope and a cup is deeper than 0.55 x its rim.",
    ("bowl", "cup"): "false: it holds liquid, but a rim of 13-25 cm is too wide to hold in one hand and it is too shallow "
    "to carry full (height <= 0.5 x Ø).",
    ("cup", "pen_holder"): "true: an open 6-12 cm vessel 8-14 cm tall with a bottom holds pens upright.",
    ("cup", "basket"): "false: the opening (<= 12 cm) is too small for a basket's load.",
    ("vase", "cup"): "false: 18-45 cm tall, beyond a cup's 16 cm; the narrow neck is not drunk from.",
    ("vase", "pen_holder"): "false: 18-45 cm tall, pens would disappear inside.",
    ("bowl", "basket"): "true: a bowl also keeps solid items dropped into it and is carried; size in the envelope.",
    ("basket", "bowl"): f"false: the {100 * BASKET_GAP:.0f} cm slots let liquid out (they only stop items >= "
    f"{100 * BASKET_AGENT_MIN:.1f} cm).",
    ("bowl", "plate"): "false: 5-10 cm tall, more than a plate's 4 cm.",
    ("plate", "bowl"): "false: 1.5-3 cm tall, inner depth under the 4 cm a bowl needs: piled droplets spill over.",
    ("plate", "tray"): "true: a rimmed flat surface of 18-28 cm carries items; inside the tray envelope.",
    ("tray", "plate"): "false: 36-50 cm long, larger than a plate (<= 32 cm).",
    ("tray", "basket"): "false: 2-4 cm high rim, shallower than a basket's 4 cm.",
    ("pot", "basket"): "true: an open 16-30 cm vessel keeps dropped items inside and is carried by its lugs.",
    ("pot", "bowl"): "false: height >= 0.6 x Ø, too deep for the bowl envelope.",
    ("bowl", "pot"): "false: height <= 0.5 x Ø and <= 10 cm, too shallow for a pot.",
    ("trash_bin", "basket"): "false: 40-65 cm tall, deeper than a carried basket (<= 35 cm).",
    ("basket", "trash_bin"): "false: 10-18 cm tall, below a floor bin's 30 cm.",
    ("chair", "stool"): "true: the sitting box stays on the seat; a stool needs no backrest.",
    ("chair", "bench"): "false: one seat, 0.4-0.5 m wide, shorter than a bench's 0.9 m.",
    ("chair", "table"): "false: the seat (0.4-0.5 m high) is below the table envelope (0.55-1.1 m).",
    ("table", "chair"): "false: the top is 0.6-0.8 m high, above a chair seat (<= 0.55 m).",
    ("table", "stool"): "false: the top is >= 0.75 m across, wider than a one-person seat (<= 0.7 m).",
    ("table", "shelf"): "false: one level surface; a shelf needs two or more stacked.",
    ("table", "bench"): "false: the top is above a bench seat (<= 0.55 m).",
    ("bench", "chair"): "false: the sitting box would stay, but a 1.0-1.6 m seat is outside a chair's 0.7 m width.",
    ("bench", "stool"): "false: 1.0-1.6 m long, wider than a one-person seat.",
    ("bench", "table"): "false: the seat (0.42-0.48 m) is below the table envelope.",
    ("rack", "shelf"): "true: 3-5 open level shelves 30-45 cm apart.",
    ("rack", "table"): "false: the top shelf is 1.2-1.8 m high, above the table envelope.",
    ("rack", "chair"): "false: shelves are <= 45 cm apart, no 0.8 m headroom to sit; the top is too high.",
    ("bathtub", "bench"): "false: the 5-8 cm rim is no seat surface.",
    ("bathtub", "basket"): "false: 1.4-1.8 m long, far beyond a carried basket.",
    ("cup_no_bottom", "cup"): "false: an open tube; poured droplets fall through to the ground.",
    ("cup_no_bottom", "pen_holder"): "false: no bottom; pens slide out when it is lifted.",
    ("bowl_holed", "bowl"): "false: the 4-6 cm base hole lets liquid and droplets out.",
    ("bowl_holed", "basket"): f"false: the base hole is larger than {100 * BASKET_AGENT_MIN:.1f} cm items.",
    ("chair_high_seat", "chair"): "false: the seat is 1.15-1.25 m high, no one sits there.",
    ("chair_high_seat", "stool"): "false: 1.15-1.25 m is above even a bar stool (<= 0.85 m).",
    ("table_tilted", "table"): "false: the top is 30° off level whenever the four feet stand; no stable pose has it level.",
    ("vase_closed", "vase"): "false: sealed at the top, nothing can be put in.",
    ("solid_box", "table"): "false: 5-25 cm sides, far below table height and size.",
    ("solid_box", "stool"): "false: at most 25 cm high, below a seat's 38 cm.",
    ("solid_cylinder", "plate"): "false: no raised rim and 5-20 cm tall.",
    ("torus", "plate"): "false: a ring, no surface inside to hold food.",
}


def ground_truth(class_name: str, affordance: str) -> bool:
    """Whether an object of ``class_name`` affords ``affordance`` (see the module doc)."""
    spec = CLASS_SPECS.get(class_name)
    if spec is None:
        raise DatasetError(f"unknown class {class_name!r}; valid classes: {', '.join(CLASSES)}")
    name = normalize_affordance(affordance)
    if name not in AFFORDANCES:
        raise DatasetError(f"no ground truth for affordance {affordance!r}; valid names: {', '.join(AFFORDANCES)}")
    return name in spec.affords


def ground_truth_markdown() -> str:
    """The ground-truth matrix, affordance definitions and cross-case reasons as Markdown."""
    names = list(AFFORDANCES)
    lines = [
        "# Ground truth of the procedural dataset",
        "",
        "Generated by `python -m rail_mj.dataset --matrix` from `rail_mj/dataset.py`; do not edit by hand.",
        "An object affords a name when the imagination test for it succeeds in some stable pose *and* its",
        "size is in the name's envelope. Class size ranges stay clear of every envelope boundary.",
        f"Baskets assume agents of Ø >= {100 * BASKET_AGENT_MIN:.1f} cm (slots are {100 * BASKET_GAP:.0f} cm).",
        "",
        "## Matrix (Y = affords)",
        "",
        "| class | group | " + " | ".join(names) + " |",
        "|---|---|" + "---|" * len(names),
    ]
    for spec in CLASS_SPECS.values():
        cells = ["Y" if n in spec.affords else "." for n in names]
        lines.append(f"| {spec.name} | {spec.group} | " + " | ".join(cells) + " |")
    lines += ["", "## Class sizes (natural pose)", "", "| class | height (m) | plan diameter (m) | looks like |", "|---|---|---|---|"]
    for spec in CLASS_SPECS.values():
        lines.append(f"| {spec.name} | {spec.height[0]:g}-{spec.height[1]:g} | {spec.plan[0]:g}-{spec.plan[1]:g} | {spec.mimics} |")
    lines += ["", "## Affordance definitions", ""]
    lines += [f"- **{n}**: {d}" for n, d in AFFORDANCES.items()]
    lines += ["", "## Cross cases", ""]
    lines += [f"- {c} -> {a}: {r}" for (c, a), r in CROSS_REASONS.items()]
    return "\n".join(lines) + "\n"


Vec3 = tuple[float, float, float]


class LabelRecord(BaseModel):
    """One line of ``labels.jsonl``. ``nominal_up`` is the mesh-frame vector that is up in the
    object's natural (as-built) pose, present for every object; ``functional_up`` equals it and is
    present only when the object affords at least one of the listed names."""

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True)

    mesh: str = Field(min_length=1)
    class_name: str = Field(alias="class", min_length=1)
    affordances: dict[str, bool]
    functional_up: Vec3 | None = None
    nominal_up: Vec3 | None = None
    units: float = Field(default=1.0, gt=0)
    up: Literal["z", "y"] = "z"  # the file's up axis, as rail_mj.objects.load_mesh takes it
    notes: str = ""

    @field_validator("affordances")
    @classmethod
    def _canonical_names(cls, v: dict[str, bool]) -> dict[str, bool]:
        out: dict[str, bool] = {}
        given: dict[str, str] = {}
        for name, label in v.items():
            key = normalize_affordance(name)
            if key in out:  # one would silently overwrite the other
                raise ValueError(f"{given[key]!r} and {name!r} both name the affordance {key!r}; label it once")
            out[key], given[key] = label, name
        return out

    @field_validator("functional_up", "nominal_up")
    @classmethod
    def _unit(cls, v: Vec3 | None) -> Vec3 | None:
        if v is None:
            return v
        n = float(np.linalg.norm(v))
        if abs(n - 1.0) > 1e-3:
            raise ValueError(f"must be a unit vector, got {list(v)} of length {n:.4f}")
        if abs(n - 1.0) < 1e-6:  # keep already-unit values as written so files round-trip byte for byte
            return tuple(float(x) for x in v)  # type: ignore[return-value]
        return tuple(float(x) / n for x in v)  # type: ignore[return-value]

    @model_validator(mode="after")
    def _up_iff_functional(self) -> "LabelRecord":
        if any(self.affordances.values()) and self.functional_up is None:
            raise ValueError("functional_up is required when any affordance is true")
        if not any(self.affordances.values()) and self.functional_up is not None:
            raise ValueError("functional_up must be omitted when no affordance is true")
        return self

    def mesh_path(self, root: str | Path) -> Path:
        """The mesh file, resolved against the dataset folder."""
        return Path(root) / self.mesh

    def to_json(self) -> str:
        return json.dumps(self.model_dump(mode="json", by_alias=True, exclude_none=True), ensure_ascii=False)


def plan_diameter(vertices: np.ndarray) -> float:
    """Largest distance between two points of the vertices' projection onto the xy plane."""
    xy = np.asarray(vertices, dtype=np.float64)[:, :2]
    hull = xy[ConvexHull(xy).vertices]
    return float(np.max(np.linalg.norm(hull[:, None] - hull[None], axis=-1)))


def _resolve_names(requested: str | Sequence[str] | None, valid: Sequence[str], what: str, norm: Callable[[str], str]) -> list[str]:
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


def generate(
    out_dir: str | Path,
    *,
    classes: str | Sequence[str] | None = None,
    per_class: int = 10,
    seed: int = 0,
    affordances: str | Sequence[str] | None = None,
    progress: Callable[[int, int, LabelRecord], None] | None = None,
) -> list[LabelRecord]:
    """Write ``per_class`` objects of each class to ``out_dir/meshes`` and their labels to ``out_dir/labels.jsonl``.

    Object ``<class>_<i>`` depends only on (seed, class, i), so subsets of classes reproduce the same
    meshes. ``affordances`` defaults to the paper's eight; ``progress(done, total, record)`` is
    called after each object. The files are built in a hidden staging folder inside ``out_dir`` and
    moved into place when all are written, ``labels.jsonl`` last: a run killed part way leaves no
    ``labels.jsonl`` (the old one is removed first), never one listing part of the objects.
    """
    class_names = _resolve_names(classes, CLASSES, "classes", str.strip)
    aff_names = _resolve_names(affordances if affordances is not None else PAPER_AFFORDANCES, list(AFFORDANCES), "affordances", normalize_affordance)
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
                posed = built.mesh.copy()
                posed.apply_transform(rot)
                posed.apply_translation(-posed.bounds.mean(axis=0))
                mesh = _snap_to_grid(posed)
                _check(name, built.mesh, mesh)
                rel = f"meshes/{name}_{i:03d}.obj"
                write_synced(stage / rel, trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_texture=False))
                up = tuple(round(float(x), 9) + 0.0 for x in rot[:3, 2])
                truth = {a: a in CLASS_SPECS[name].affords for a in aff_names}
                record = LabelRecord(
                    mesh=rel,
                    class_name=name,
                    affordances=truth,
                    functional_up=up if any(truth.values()) else None,
                    nominal_up=up,
                    notes=f"{built.notes}; written in a random orientation",
                )
                records.append(record)
                if progress is not None:
                    progress(len(records), total, record)
        write_synced(stage / LABELS_FILE, "".join(r.to_json() + "\n" for r in records))
        publish(stage, out, LABELS_FILE)
    return records


def read_labels(path: str | Path) -> list[LabelRecord]:
    """Read ``labels.jsonl`` from a dataset folder (or the file itself); every mesh must exist."""
    p = Path(path)
    file = p / LABELS_FILE if p.is_dir() else p
    if not file.is_file():
        raise DatasetError(f"no labels file at {file}; expected a folder holding {LABELS_FILE} or the file itself")
    root = file.parent
    records = []
    for lineno, line in enumerate(file.read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip():
            continue
        try:
            data = json.loads(line)
        except json.JSONDecodeError as e:
            raise DatasetError(f"{file}:{lineno}: not valid JSON ({e.msg} at column {e.colno})") from e
        try:
            record = LabelRecord.model_validate(data)
        except ValidationError as e:
            errs = "; ".join(f"{'.'.join(map(str, err['loc'])) or 'record'}: {err['msg']}" for err in e.errors())
            fields = ", ".join(f.alias or n for n, f in LabelRecord.model_fields.items())
            raise DatasetError(f"{file}:{lineno}: bad label ({errs}); fields: {fields}") from e
        if not record.mesh_path(root).is_file():
            raise DatasetError(f"{file}:{lineno}: mesh file {record.mesh_path(root)} does not exist")
        records.append(record)
    if not records:
        raise DatasetError(f"{file} holds no label records")
    return records


def _split(text: str | None) -> list[str] | None:
    return None if text is None else text.split(",")


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status (the rule of rail_mj.cli: 0 written, 1 generation
    failed, 2 bad command line and nothing written, 130 interrupted; errors as ``error:`` on stderr)."""
    from rail_mj.cli import EXIT_OK, report_error
    from rail_mj.errors import ConfigError

    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["real"]:  # the real-mesh development set has its own options (rail_mj.realset)
        from rail_mj.realset import main as real_main

        return real_main(argv[1:])
    parser = argparse.ArgumentParser(prog="python -m rail_mj.dataset", description="Generate the labelled procedural dataset.")
    parser.add_argument("--out", type=Path, help="output folder (meshes/ and labels.jsonl)")
    parser.add_argument("--classes", help=f"comma-separated classes (default all): {','.join(CLASSES)}")
    parser.add_argument("--per-class", type=int, default=10, help="objects per class (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--affordances", help=f"comma-separated names (default the paper's eight); valid: {','.join(AFFORDANCES)}")
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
        _resolve_names(args.classes, CLASSES, "classes", str.strip)
        _resolve_names(args.affordances, list(AFFORDANCES), "affordances", normalize_affordance)
    except DatasetError as e:
        return report_error(ConfigError(str(e)))
    from tqdm import tqdm

    bar = tqdm(unit="obj", disable=None)

    def tick(done: int, total: int, record: LabelRecord) -> None:
        bar.total = total
        bar.set_postfix_str(record.mesh, refresh=False)
        bar.update(1)

    try:
        records = generate(args.out, classes=_split(args.classes), per_class=args.per_class, seed=args.seed,
                           affordances=_split(args.affordances), progress=tick)
    except (DatasetError, KeyboardInterrupt) as e:
        bar.close()
        return report_error(e)
    except OSError as e:
        bar.close()
        return report_error(DatasetError(f"cannot write the dataset to {args.out}: {e.strerror or e}"))
    bar.close()
    print(f"wrote {len(records)} objects to {args.out}")
    return EXIT_OK


if __name__ == "__main__":
    raise SystemExit(main())
