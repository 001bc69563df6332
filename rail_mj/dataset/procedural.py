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
orientation, roughly centred at the origin, in metres with +z as the file's up
axis unless its label says otherwise (``units``, ``up``); ``functional_up`` in
its label is the file-frame unit vector that must point up for the object to
work (omitted when it affords none of the requested names), and ``nominal_up``
is the same vector for every object, defects and distractors included (their
as-built pose).

The ground truth is *physical*: an object affords a name when the imagination
test for that name would succeed on it in its as-built pose, the one pose its
label names (droplets or items stay in a container, a sitting box stays on a
seat, a box stays on a level top, a food disc stays on a rimmed plate) **and**
its dimensions fall in the name's size envelope, which the affordance analyser
checks first. Uses that need another pose (a bathtub on its side as a table, an
open-front cubby on its back as a basket) do not count. Class size ranges are
kept clear of every envelope boundary so no answer depends on the random
instance. ``python -m rail_mj.dataset --matrix`` prints the matrix, the
definitions and the reasons for the cross cases (kept in docs/ground_truth.md).

Corruption (:data:`CORRUPTIONS`) is applied to objects of either family with a
random stream of its own, so the object underneath is the clean one: ``noise``,
``holes``, ``open_shell`` and ``uneven_bottom`` change the mesh the way a scanner
does and leave the ground truth as it is; ``scale10`` (the file in units of
0.1 m, label ``units=0.1``) and ``y_up`` (the file +y up, label ``up="y"``) test
that the loader honours the label; ``scale10_unlabelled`` writes the file 10x
too large with ``units=1`` and labels the object that file describes (only for
classes whose 10x object affords nothing). The world family corrupts
:data:`WORLD_CORRUPTION_RATE` of its objects with one or two of the first six;
``corrupt=`` overrides that for every object. The label lists what was applied.

CLI::

    python -m rail_mj.dataset --out DIR [--family core|world|all] [--classes cup,bowl] [--per-class N]
                              [--seed S] [--affordances cup,chair] [--corrupt noise,y_up|none]
    python -m rail_mj.dataset real --out DIR    # the real-mesh development set, see rail_mj.dataset.realset
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
from rail_mj.core.errors import DatasetError
from rail_mj.core.runfiles import publish, staging_dir, write_synced
from rail_mj.dataset.shapes import BASKET_AGENT_MIN, BASKET_GAP, GENERATORS, GEOMETRIC_CORRUPTIONS, densify

__all__ = [
    "AFFORDANCES",
    "PAPER_AFFORDANCES",
    "ClassSpec",
    "CLASS_SPECS",
    "CLASSES",
    "WORLD_CLASSES",
    "ALL_CLASSES",
    "FAMILIES",
    "family_classes",
    "CORRUPTIONS",
    "MIXED_CORRUPTIONS",
    "WORLD_CORRUPTION_RATE",
    "SCALE10_UNLABELLED_CLASSES",
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
    "bathtub": "water-tight open-top basin a lying person fits in: inner length >= 1.2 m, inner depth >= 0.25 m, "
    "0.35-0.8 m tall.",
    "plate": "flat level food surface with a raised rim that keeps a food disc on it: largest side 15-32 cm, 1-4 cm tall.",
    "table": "level rigid top on which a box placed from above stays: top 0.55-1.1 m above the ground, >= 0.5 m across, "
    "free space above.",
    "chair": "level seat for one person on which a sitting box stays, the feet supported: seat 0.38-0.55 m high, "
    "or up to 0.85 m with a footrest 0.4-0.55 m below it (a bar chair); 0.3-0.7 m across (between any arms), "
    ">= 0.8 m free above the seat; a backrest is optional.",
    "stool": "seat for one person usable without a backrest (sitting-box test): seat 0.38-0.85 m high (dining to bar), "
    "0.25-0.7 m across.",
    "bench": "seat for two or more (sitting-box test at two places side by side): seat 0.38-0.55 m high, >= 0.9 m long.",
    "bed": "level surface a person lies on (a lying box stays on it): >= 1.8 m long and >= 0.8 m wide, 0.15-0.9 m "
    "above the ground, free space above.",
    "shelf": "two or more level surfaces stacked >= 20 cm apart, each holding a box placed on it; top surface above 1.1 m "
    "or below others so it is not a table.",
    "cupboard": "enclosure that stores items on its own level floor or boards, reached through an opening at the front "
    "and roofed over (a box pushed in from the front stays inside): inner height >= 15 cm, depth >= 12 cm; doors optional.",
    "tray": "rimmed flat surface carried with items on it: largest side 15-60 cm, height <= 4.5 cm and <= 0.2 x largest side.",
    "pot": "water-tight open-top cooking vessel: rim Ø 15-45 cm, 10-30 cm tall, height >= 0.55 x rim Ø.",
    "trash_bin": "open-top container for waste standing on the floor: opening >= 18 cm, 30-90 cm tall.",
    "pen_holder": "open-top container with a closed bottom that holds pens upright: opening 4-12.5 cm, 7-16 cm tall.",
}.items()}


Family = Literal["core", "world"]


@dataclass(frozen=True)
class ClassSpec:
    """One object class: what it affords and the size ranges its generator keeps to (m, build frame)."""

    name: str
    group: Literal["paper", "extra", "defect", "distractor", "seat", "vessel", "storage", "furniture", "near_miss"]
    affords: frozenset[str]
    height: tuple[float, float]  # z extent in the natural pose
    plan: tuple[float, float]  # largest distance between two points seen from above (handles included)
    mimics: str = ""  # for defects and near misses: the class they look like
    family: Family = "core"


def _spec(name: str, group: str, affords: Iterable[str], height: tuple[float, float], plan: tuple[float, float], mimics: str = "") -> ClassSpec:
    family = "core" if group in ("paper", "extra", "defect", "distractor") else "world"
    return ClassSpec(name, group, frozenset(affords), height, plan, mimics, family)  # type: ignore[arg-type]


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
        # the world family: one class or more for each kind of miss on real meshes (issue 13)
        _spec("armchair", "seat", {"chair", "stool"}, (0.77, 0.9), (0.99, 1.26)),
        _spec("bar_chair", "seat", {"chair", "stool"}, (0.92, 1.16), (0.55, 0.76)),
        _spec("shell_chair", "seat", {"chair", "stool"}, (0.68, 0.9), (0.68, 0.77)),
        _spec("stool", "seat", {"chair", "stool"}, (0.43, 0.5), (0.3, 0.53)),
        _spec("ottoman", "seat", {"chair", "stool"}, (0.4, 0.46), (0.41, 0.6)),
        _spec("sofa", "seat", {"bench"}, (0.77, 0.9), (1.48, 2.37)),
        _spec("bowl_real", "vessel", {"bowl", "basket"}, (0.056, 0.148), (0.13, 0.28)),
        _spec("saucepan", "vessel", {"bowl", "basket"}, (0.065, 0.165), (0.3, 0.45)),
        _spec("handle_pot", "vessel", {"pot", "basket"}, (0.11, 0.23), (0.31, 0.44)),
        _spec("scoop", "vessel", {"bowl", "basket"}, (0.06, 0.165), (0.2, 0.33)),
        _spec("goblet", "vessel", {"cup", "pen_holder"}, (0.12, 0.145), (0.07, 0.095)),
        _spec("plate_real", "vessel", {"plate", "tray"}, (0.02, 0.032), (0.2, 0.28)),
        _spec("cubby", "storage", {"cupboard"}, (0.26, 0.34), (0.36, 0.51)),
        _spec("wall_shelf_box", "storage", {"cupboard"}, (0.2, 0.26), (0.47, 0.74)),
        _spec("bed", "furniture", {"bed", "bench"}, (0.9, 1.2), (2.2, 2.78)),
        _spec("desk", "furniture", {"table"}, (0.72, 0.77), (1.2, 1.8)),
        _spec("console", "furniture", {"table", "cupboard"}, (0.6, 0.72), (1.3, 1.9)),
        _spec("ladle", "near_miss", set(), (0.19, 0.355), (0.13, 0.3), "bowl"),
        _spec("ashtray", "near_miss", set(), (0.025, 0.036), (0.1, 0.12), "bowl"),
        _spec("riser", "near_miss", set(), (0.08, 0.22), (0.23, 0.48), "basket"),
        _spec("carton", "near_miss", set(), (0.12, 0.34), (0.14, 0.49), "bowl"),
    )
}

#: The core family (the default, and the published figures), in matrix order.
CLASSES: tuple[str, ...] = tuple(n for n, s in CLASS_SPECS.items() if s.family == "core")
#: The world family: shapes real meshes have that the core family lacks.
WORLD_CLASSES: tuple[str, ...] = tuple(n for n, s in CLASS_SPECS.items() if s.family == "world")
ALL_CLASSES: tuple[str, ...] = CLASSES + WORLD_CLASSES
#: The classes of each family name ``generate(family=...)``, ``--family`` take.
FAMILIES: dict[str, tuple[str, ...]] = {"core": CLASSES, "world": WORLD_CLASSES, "all": ALL_CLASSES}

#: Every corruption, in the order they are applied: the geometric ones (rail_mj.dataset.shapes), then the file's frame.
CORRUPTIONS: tuple[str, ...] = (*GEOMETRIC_CORRUPTIONS, "scale10", "y_up", "scale10_unlabelled")
#: The corruptions the world family mixes in; each leaves the ground truth as it is.
MIXED_CORRUPTIONS: tuple[str, ...] = CORRUPTIONS[:-1]
#: Fraction of world objects that get one or two of MIXED_CORRUPTIONS (a fixed draw per object).
WORLD_CORRUPTION_RATE = 0.6
#: Classes whose 10x object affords none of the names (checked against every definition), by the reason:
#: the only ones ``scale10_unlabelled`` may be applied to, so their label stays a class-level answer.
SCALE10_UNLABELLED_CLASSES: dict[str, str] = {
    "goblet": "1.2-1.45 m tall with a 0.6-0.9 m rim on a stem: taller than any vessel but a vase, whose opening is <= 12 cm",
    "ladle": "a 0.7-1 m cup on a 2-3 m pole: no level surface, too tall for a trash bin, too small inside for a bathtub",
    "vase": "1.8-4.5 m tall with a 0.4-0.9 m opening: beyond every vessel's height range",
    "vase_closed": "a closed 1.8-4.5 m column",
    "cup_no_bottom": "a 0.8-1.4 m tube open at both ends holds nothing",
    "sphere": "a 0.5-2.5 m ball has no level surface",
    "cone": "a 0.5-2.5 m cone has no level surface",
}
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
    ("bench", "bed"): "false: 0.3-0.4 m deep, narrower than a bed's 0.8 m.",
    ("table", "bed"): "false: at most 1.4 m long, shorter than a bed's 1.8 m.",
    ("bathtub", "bed"): "false: the floor inside is 1.2-1.6 m long, shorter than a bed's 1.8 m.",
    ("rack", "cupboard"): "false: open on every side and between the boards: no enclosure.",
    # the world family
    ("armchair", "chair"): "true: an upholstered seat 0.41-0.46 m high and 0.48-0.58 m between the arms; the "
    "0.72-0.94 m overall width is arms, not seat.",
    ("armchair", "stool"): "true: the sitting box stays on the seat; a stool needs no backrest (as chair -> stool).",
    ("armchair", "table"): "false: the rolled arms (0.57-0.66 m) are 14-21 cm wide and round, no level top 0.5 m across.",
    ("armchair", "bench"): "false: one seat, 0.48-0.58 m wide, shorter than a bench's 0.9 m.",
    ("bar_chair", "chair"): "true: a seat 0.64-0.78 m high with footrest rungs 0.43-0.5 m below it (a bar chair).",
    ("bar_chair", "stool"): "true: a seat 0.64-0.78 m high, inside a stool's dining-to-bar 0.38-0.85 m.",
    ("bar_chair", "table"): "false: the seat is at table height but 0.4-0.46 m across, under a table's 0.5 m.",
    ("shell_chair", "chair"): "true: a level cushion Ø 0.5-0.6 m at 0.39-0.45 m inside the shell, open above its front.",
    ("shell_chair", "stool"): "true: the sitting box stays on the cushion; a stool needs no backrest.",
    ("shell_chair", "trash_bin"): "false: the shell is cut below the cushion at the front: items and droplets run off "
    "the front, there is no basin.",
    ("shell_chair", "basket"): "false: no basin (cut open at the front), and its 0.68-0.77 m exceed a basket's 60 cm.",
    ("stool", "chair"): "true: a seat 0.43-0.5 m high and 0.3-0.38 m across; a chair needs no backrest (as the core "
    "chairs without one).",
    ("stool", "stool"): "true: a backless seat 0.43-0.5 m high and 0.3-0.38 m across on splayed legs.",
    ("stool", "table"): "false: the seat is below the table range and under 0.5 m across.",
    ("ottoman", "chair"): "true: an upholstered round pouf 0.4-0.46 m high and 0.4-0.6 m across; no backrest needed.",
    ("ottoman", "stool"): "true: the sitting box stays on its top.",
    ("ottoman", "table"): "false: 0.4-0.46 m high, below the table range.",
    ("sofa", "bench"): "true: 2-3 seat cushions, a seat 1.0-1.8 m long at 0.41-0.46 m: two people sit side by side.",
    ("sofa", "chair"): "false: the seat (1.0-1.8 m) is wider than a chair's 0.7 m, as a bench's is.",
    ("sofa", "stool"): "false: wider than a one-person seat.",
    ("sofa", "bed"): "false: the seat is 0.62-0.68 m deep, narrower than a bed's 0.8 m, and at most 1.8 m long.",
    ("bowl_real", "bowl"): "true: Ø 13-28 cm, 5.6-14.7 cm tall (width/height 1.9-3.5), >= 4.4 cm deep inside: the "
    "13 x 6.4 cm scanned bowl is one. Real bowls reach width/height 1.5, but deeper than 1.82 a vessel leaves the bowl "
    "definition (height <= 0.55 x rim) for the pot's (>= 0.55) and a cup's, so the class stops at 1.9.",
    ("bowl_real", "basket"): "true: as a bowl: it keeps dropped items inside and is carried.",
    ("bowl_real", "cup"): "false: a rim of 13-28 cm is wider than a cup's 12.5 cm, and the height is <= 0.53 x rim.",
    ("bowl_real", "pot"): "false: height <= 0.53 x rim, shallower than a pot's 0.55.",
    ("bowl_real", "plate"): "false: 5.6-14.7 cm tall, over a plate's 4 cm.",
    ("saucepan", "bowl"): "true: a 15-22 cm open vessel, 5.8-10 cm deep inside, height <= 0.48 x rim: it holds food and "
    "liquid as a bowl does; the long handle is not part of the rim.",
    ("saucepan", "basket"): "true: it keeps dropped items inside and is carried by its handle, 31-44 cm long in all, "
    "inside a basket's 60 cm (as bowl -> basket; a real-set label that says otherwise disagrees with the definition).",
    ("saucepan", "pot"): "false: height <= 0.48 x rim, shallower than a pot's 0.55 (a deep one is a handle_pot).",
    ("saucepan", "cup"): "false: a 15-22 cm rim, wider than a cup's 12.5 cm.",
    ("handle_pot", "pot"): "true: Ø 16-21 cm, 11-17 cm tall, height >= 0.62 x rim, water-tight.",
    ("handle_pot", "basket"): "true: as pot -> basket: it keeps dropped items inside and is carried by its handle.",
    ("handle_pot", "bowl"): "false: height >= 0.62 x rim, deeper than a bowl's 0.55.",
    ("handle_pot", "vase"): "false: a 16-21 cm opening, wider than a vase's 12 cm.",
    ("scoop", "bowl"): "true: a flat-bottomed round dipper Ø 13-17 cm, 4.9-7.1 cm deep inside, height <= 0.48 x rim, on a short "
    "handle: it holds liquid as a bowl does.",
    ("scoop", "basket"): "true: as a bowl: it keeps dropped items inside and is carried.",
    ("scoop", "cup"): "false: a 13-17 cm rim, wider than a cup's 12.5 cm.",
    ("goblet", "cup"): "true: a 5.6-9.4 cm rim, 12-14.5 cm tall, taller than 0.6 x its rim; droplets stay in its bowl "
    "and one hand holds it by the stem.",
    ("goblet", "pen_holder"): "true: an open bowl 5.8-10.8 cm deep with a closed bottom keeps pens upright.",
    ("goblet", "vase"): "false: 12-14.5 cm tall, below a vase's 15 cm.",
    ("goblet", "bowl"): "false: the rim (<= 9.4 cm) is below a bowl's 12.5 cm.",
    ("plate_real", "plate"): "true: Ø 20-28 cm, 2-3.2 cm tall, a flat well inside a raised rim, on a foot ring.",
    ("plate_real", "tray"): "true: as plate -> tray: a rimmed flat surface of 20-28 cm.",
    ("plate_real", "bowl"): "false: under 3 cm deep inside, a bowl needs 4 cm.",
    ("cubby", "cupboard"): "true: an enclosure with its own floor, roofed, open at the front; 22-32 cm high "
    "inside. On a side wall it is one too; its label names the as-built pose.",
    ("cubby", "basket"): "false: as built its opening faces sideways. On its back it would hold dropped items, but that "
    "is another pose, which the ground truth does not count (as a bathtub on its side is no table).",
    ("cubby", "shelf"): "false: its top (0.26-0.34 m) is neither above 1.1 m nor below other boards.",
    ("cubby", "stool"): "false: 0.26-0.34 m high, below a seat's 0.38 m.",
    ("wall_shelf_box", "cupboard"): "true: an enclosure with its own floor, roofed, open at the front, 16-24 cm high inside.",
    ("wall_shelf_box", "basket"): "false: as built its opening faces sideways (see cubby -> basket).",
    ("wall_shelf_box", "shelf"): "false: its top (0.2-0.26 m) is neither above 1.1 m nor below other boards.",
    ("bed", "bed"): "true: a mattress 1.86-2.09 m long and 0.91-1.61 m wide, its top 0.42-0.52 m high.",
    ("bed", "bench"): "true: two people sit side by side on its edge: a level top 0.42-0.52 m high, >= 0.9 m long.",
    ("bed", "bathtub"): "false: no basin: the mattress is its top and water runs off its sides.",
    ("bed", "table"): "false: the mattress top (0.42-0.52 m) is below the table range.",
    ("bed", "chair"): "false: 0.95-1.65 m wide, wider than a one-person seat.",
    ("desk", "table"): "true: a level top 1.1-1.6 x 0.55-0.8 m at 0.72-0.77 m, free above.",
    ("desk", "bathtub"): "false: no basin: pedestals and panels stand under a flat top.",
    ("desk", "cupboard"): "false: the drawer pedestals are closed blocks, and the knee hole has no floor of its own.",
    ("console", "table"): "true: a level top 0.52-0.6 m deep at 0.6-0.72 m. A TV console under 0.5 m deep or 0.55 m "
    "high is no table by the definition.",
    ("console", "cupboard"): "true: 2-4 open compartments with their own floor and roof, reached from the front.",
    ("console", "shelf"): "false: its top is a table top (<= 1.1 m), which the shelf definition leaves to tables.",
    ("console", "bench"): "false: the top (>= 0.6 m) is above a bench seat (<= 0.55 m).",
    ("ladle", "bowl"): "false: its cup is 6.7-10 cm across, below a bowl's 12.5 cm.",
    ("ladle", "cup"): "false: 20-35 cm tall with its handle, and its cup is shallower (<= 0.5 x rim) than a cup's 0.6.",
    ("ladle", "pen_holder"): "false: 20-35 cm tall, and its round cup does not stand.",
    ("ashtray", "bowl"): "false: Ø 10-12 cm and 1.5-2.4 cm deep inside, under a bowl's 12.5 cm rim and 4 cm depth.",
    ("ashtray", "basket"): "false: 1.5-2.4 cm deep inside, a basket needs 4 cm.",
    ("ashtray", "plate"): "false: 10-12 cm across, below a plate's 15 cm.",
    ("ashtray", "cup"): "false: 2.5-3.6 cm tall, below a cup's 6 cm.",
    ("riser", "basket"): "false: open at the bottom (a hollow box) or at front, back and bottom (a U): items fall through.",
    ("riser", "table"): "false: 0.08-0.22 m high, far below a table top.",
    ("riser", "tray"): "false: its top has no rim.",
    ("carton", "bowl"): "false: closed on every side: nothing can be put in.",
    ("carton", "basket"): "false: closed on every side.",
    ("carton", "stool"): "false: at most 34 cm high, below a seat's 38 cm.",
}


def ground_truth(class_name: str, affordance: str) -> bool:
    """Whether an object of ``class_name`` affords ``affordance`` (see the module doc); the truth of a clean
    or truth-preserving corrupted object (``scale10_unlabelled`` objects afford nothing, see :func:`generate`)."""
    spec = CLASS_SPECS.get(class_name)
    if spec is None:
        raise DatasetError(f"unknown class {class_name!r}; valid classes: {', '.join(ALL_CLASSES)}")
    name = normalize_affordance(affordance)
    if name not in AFFORDANCES:
        raise DatasetError(f"no ground truth for affordance {affordance!r}; valid names: {', '.join(AFFORDANCES)}")
    return name in spec.affords


#: What each corruption does, what its label says, and why its ground truth is what it is.
CORRUPTION_NOTES: dict[str, tuple[str, str, str]] = {
    "uneven_bottom": ("the base warped by up to 1.5-3 mm (4-8 mm on objects over 50 cm: legs of different lengths), "
                      "a tilt plus a dome or dish, so the object rocks", "as clean",
                      "unchanged: a few degrees of rocking changes no seat, top or cavity"),
    "noise": ("vertices moved along their normals, sigma 0.1-0.25 mm (proportionally more above 30 cm)", "as clean",
              "unchanged: far below any wall's thickness"),
    "holes": ("2-4 missing surface patches (Ø 2-5 % of the largest extent), each on one side of a wall", "as clean",
              "unchanged: a scan that misses a patch of one side of a wall does not make the wall leak; "
              "nothing passes through"),
    "open_shell": ("the surface cut into 2-4 unwelded shells shifted 0.2-1.5 mm: open seams, not watertight",
                   "as clean", "unchanged: the cracks (<= 3 mm) are narrower than a droplet (8-9 mm)"),
    "scale10": ("the file's numbers are 10x the metres (decimetre file)", "units = 0.1",
                "unchanged: the label says the unit, a loader that honours it sees the real object"),
    "y_up": ("the file is +y up: file (x, y, z) = (x, z, -y) of the z-up mesh", "up = \"y\"; functional_up and "
             "nominal_up in the file's frame", "unchanged: the label says the axis"),
    "scale10_unlabelled": ("the file's numbers are 10x the metres", "units = 1 (wrong on purpose)",
                           "every name false: the ground truth follows the object the file and its label describe, "
                           "10x too large, since no rule can tell a 1.4 m goblet from a wrong unit. Applied only to "
                           "the classes whose 10x object affords nothing (below), so the answer stays one per class; "
                           "a 10x cup (a 1.4 m vessel) could be a trash bin, so cups are refused"),
}


def _matrix(classes: Sequence[str], names: Sequence[str]) -> list[str]:
    lines = ["| class | group | " + " | ".join(names) + " |", "|---|---|" + "---|" * len(names)]
    for c in classes:
        spec = CLASS_SPECS[c]
        lines.append(f"| {c} | {spec.group} | " + " | ".join("Y" if n in spec.affords else "." for n in names) + " |")
    return lines


def ground_truth_markdown() -> str:
    """The ground-truth matrix of both families, class sizes, affordance definitions, corruptions and
    cross-case reasons as Markdown."""
    names = list(AFFORDANCES)
    lines = [
        "# Ground truth of the procedural dataset",
        "",
        "Generated by `python -m rail_mj.dataset --matrix` from `rail_mj/dataset/procedural.py`; do not edit by hand.",
        "An object affords a name when the imagination test for it succeeds in its as-built pose (the one",
        "`functional_up` of its label) *and* its size is in the name's envelope. Uses that need another pose",
        "(a bathtub on its side as a table, an open-front cubby on its back as a basket) do not count.",
        "An object that is the same shape upside down (a pouf without feet, a console on a plinth; checked on",
        "its surface by `upside_down_is_itself`) lists the other up in `equivalent_ups`: either pose is it.",
        "Class size ranges stay clear of every envelope boundary.",
        f"Baskets assume agents of Ø >= {100 * BASKET_AGENT_MIN:.1f} cm (slots are {100 * BASKET_GAP:.0f} cm).",
        "The truth is written from the definitions below, not from the offline provider's rules",
        "(`rail_mj/affordances/registry.py`): those rules are what it measures.",
        "",
        "## Matrix (Y = affords)",
        "",
        "### core family (`--family core`, the default: the published figures)",
        "",
        *_matrix(CLASSES, names),
        "",
        "### world family (`--family world`: the shapes real meshes have)",
        "",
        *_matrix(WORLD_CLASSES, names),
        "",
        "## Class sizes (natural pose)",
        "",
        "| class | family | height (m) | plan diameter (m) | looks like |",
        "|---|---|---|---|---|",
    ]
    for spec in CLASS_SPECS.values():
        lines.append(f"| {spec.name} | {spec.family} | {spec.height[0]:g}-{spec.height[1]:g} | "
                     f"{spec.plan[0]:g}-{spec.plan[1]:g} | {spec.mimics} |")
    lines += ["", "## Affordance definitions", ""]
    lines += [f"- **{n}**: {d}" for n, d in AFFORDANCES.items()]
    lines += [
        "",
        "## Corruption",
        "",
        "Applied to objects of either family, each with a random stream of its own (the object underneath is the",
        "clean one). The world family corrupts " + f"{100 * WORLD_CORRUPTION_RATE:.0f} % of its objects with one or two of "
        + ", ".join(MIXED_CORRUPTIONS) + " (a fixed draw per object); `--corrupt a,b` applies exactly those to every",
        "object instead, `--corrupt none` nothing. A label lists what was applied in `corruptions`.",
        "",
        "| corruption | what it does to the file | label | ground truth |",
        "|---|---|---|---|",
    ]
    lines += [f"| {c} | {what} | {label} | {truth} |" for c, (what, label, truth) in CORRUPTION_NOTES.items()]
    lines += ["", "`scale10_unlabelled` is applied only to these classes (their 10x object affords nothing):", ""]
    lines += [f"- {c}: {why}." for c, why in SCALE10_UNLABELLED_CLASSES.items()]
    lines += ["", "## Cross cases", ""]
    lines += [f"- {c} -> {a}: {r}" for (c, a), r in CROSS_REASONS.items()]
    return "\n".join(lines) + "\n"


Vec3 = tuple[float, float, float]


class LabelRecord(BaseModel):
    """One line of ``labels.jsonl``. ``nominal_up`` is the vector, in the file's own frame (before the
    ``up`` change), that is up in the object's natural (as-built) pose, present for every object;
    ``functional_up`` equals it and is present only when the object affords at least one of the listed
    names. ``corruptions`` lists what was done to the file (omitted when nothing was)."""

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True)

    mesh: str = Field(min_length=1)
    class_name: str = Field(alias="class", min_length=1)
    affordances: dict[str, bool]
    functional_up: Vec3 | None = None
    #: other ups (file frame) that give the same shape as functional_up: an object that is itself turned upside
    #: down (a pouf without feet, a console on a plinth) is as functional either way up
    equivalent_ups: list[Vec3] | None = None
    nominal_up: Vec3 | None = None
    units: float = Field(default=1.0, gt=0)
    up: Literal["z", "y"] = "z"  # the file's up axis, as rail_mj.mesh.load_mesh takes it
    corruptions: list[str] | None = None  # what was done to the file (rail_mj.dataset.procedural.CORRUPTIONS); None: nothing
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
        if self.equivalent_ups is not None and self.functional_up is None:
            raise ValueError("equivalent_ups needs a functional_up")
        for v in self.equivalent_ups or []:
            if abs(float(np.linalg.norm(v)) - 1.0) > 1e-3:
                raise ValueError(f"equivalent_ups must be unit vectors, got {list(v)}")
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


def family_classes(family: str) -> tuple[str, ...]:
    """The classes of a family (``core``, ``world`` or ``all``), in matrix order."""
    if family not in FAMILIES:
        raise DatasetError(f"unknown family {family!r}; valid families: {', '.join(FAMILIES)}")
    return FAMILIES[family]


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
    points, _ = trimesh.sample.sample_surface(mesh, _SYMMETRY_POINTS, seed=0)
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
    progress: Callable[[int, int, LabelRecord], None] | None = None,
) -> list[LabelRecord]:
    """Write ``per_class`` objects of each class to ``out_dir/meshes`` and their labels to ``out_dir/labels.jsonl``.

    ``classes`` defaults to every class of ``family`` (``core``, ``world`` or ``all``). Object
    ``<class>_<i>`` depends only on (seed, class, i), so subsets of classes reproduce the same meshes.
    ``corrupt`` is None for each family's default (the world family corrupts
    :data:`WORLD_CORRUPTION_RATE` of its objects, the core family none), ``"none"``, or names of
    :data:`CORRUPTIONS` applied to every object; a corruption draws from a stream of its own, so the
    object underneath is the clean one. ``affordances`` defaults to the paper's eight;
    ``progress(done, total, record)`` is called after each object. The files are built in a hidden
    staging folder inside ``out_dir`` and moved into place when all are written, ``labels.jsonl``
    last: a run killed part way leaves no ``labels.jsonl`` (the old one is removed first), never one
    listing part of the objects.
    """
    class_names = _resolve_classes(classes, family)
    aff_names = _resolve_names(affordances if affordances is not None else PAPER_AFFORDANCES, list(AFFORDANCES), "affordances", normalize_affordance)
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
                mesh = _posed(built.mesh, rot)
                _check(name, built.mesh, mesh)
                applied = forced if forced is not None else _mixed_corruptions(name, i, seed)
                notes = [f"{built.notes}; written in a random orientation"]
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
                write_synced(stage / rel, trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_texture=False))
                up_t = tuple(round(float(x), 9) + 0.0 for x in up)
                truth = {a: a in CLASS_SPECS[name].affords and "scale10_unlabelled" not in applied for a in aff_names}
                record = LabelRecord(
                    mesh=rel,
                    class_name=name,
                    affordances=truth,
                    functional_up=up_t if any(truth.values()) else None,
                    equivalent_ups=([tuple(-v + 0.0 for v in up_t)]
                                    if same_upside_down and any(truth.values()) else None),
                    nominal_up=up_t,
                    units=units,
                    up=up_axis,
                    corruptions=list(applied) or None,
                    notes="; ".join(notes),
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
    """CLI entry point; returns the exit status (the rule of rail_mj.core.cli: 0 written, 1 generation
    failed, 2 bad command line and nothing written, 130 interrupted; errors as ``error:`` on stderr)."""
    from rail_mj.core.cli import EXIT_OK, object_bar, report_error
    from rail_mj.core.errors import ConfigError

    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["real"]:  # the real-mesh development set has its own options (rail_mj.dataset.realset)
        from rail_mj.dataset.realset import main as real_main

        return real_main(argv[1:])
    parser = argparse.ArgumentParser(prog="python -m rail_mj.dataset", description="Generate the labelled procedural dataset.")
    parser.add_argument("--out", type=Path, help="output folder (meshes/ and labels.jsonl)")
    parser.add_argument("--family", default="core", choices=tuple(FAMILIES),
                        help="class family (default core, the published set; world: shapes of real meshes; all: both)")
    parser.add_argument("--classes", help=f"comma-separated classes of the family (default all of it); core: "
                        f"{','.join(CLASSES)}; world: {','.join(WORLD_CLASSES)}")
    parser.add_argument("--corrupt", help=f"'none' or comma-separated corruptions applied to every object (default: "
                        f"the world family mixes them in): {','.join(CORRUPTIONS)}")
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
        _check_unlabelled_scale(_resolve_classes(args.classes, args.family), _resolve_corrupt(args.corrupt))
        _resolve_names(args.affordances, list(AFFORDANCES), "affordances", normalize_affordance)
    except DatasetError as e:
        return report_error(ConfigError(str(e)))
    try:
        with object_bar() as tick:
            records = generate(args.out, classes=_split(args.classes), per_class=args.per_class, seed=args.seed,
                               affordances=_split(args.affordances), family=args.family, corrupt=args.corrupt,
                               progress=tick)
    except (DatasetError, KeyboardInterrupt) as e:
        return report_error(e)
    except OSError as e:
        return report_error(DatasetError(f"cannot write the dataset to {args.out}: {e.strerror or e}"))
    print(f"wrote {len(records)} objects to {args.out}")
    return EXIT_OK
