"""The procedural dataset's ground truth: the affordance matrix of every class, and why each cell is what it is.

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

Each class has a :class:`ClassSpec` (family, group, what it affords, size ranges) in :data:`CLASS_SPECS`;
the core family is the default (the published figures), the world family holds the shapes real meshes
have. The corruptions (:data:`CORRUPTIONS`, applied by :func:`rail_mj.dataset.procedural.generate`) leave
the truth as it is, except ``scale10_unlabelled`` (:data:`CORRUPTION_NOTES`). An object's functional up
is its as-built (build frame) +z; the generator writes it into the label.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal

from rail_mj.affordances import PAPER_AFFORDANCES, get
from rail_mj.affordances import label_key as normalize_affordance
from rail_mj.core.errors import DatasetError
from rail_mj.dataset.shapes import BASKET_AGENT_MIN, BASKET_GAP, GEOMETRIC_CORRUPTIONS

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
    "CORRUPTION_NOTES",
    "ground_truth",
    "ground_truth_markdown",
    "normalize_affordance",
]

#: Physical definition and size envelope of every affordance name the matrix answers, by registry key. These
#: are the dataset's own words, apart from the registry's rules: the ground truth those rules are measured by.
AFFORDANCES: dict[str, str] = {get(name).key: text for name, text in {
    "cup": "open-top vessel that holds liquid poured from above (droplets stay inside) and is held in one hand: "
    "rim Ø <= 12.5 cm, 6-16 cm tall, height >= 0.6 x rim Ø.",
    "bowl": "open-top vessel that holds liquid or food: rim Ø 12.5-35 cm, inner depth >= 4 cm, "
    "height <= 0.55 x rim Ø (wide and shallow).",
    "vase": "vessel that holds water and upright stems: opening 4-12 cm, 15-80 cm tall, height >= 1.5 x opening.",
    "basket": f"open-top container that holds solid items (agents Ø >= {100 * BASKET_AGENT_MIN:.1f} cm) dropped in and "
    "is carried: gaps narrower than the items are allowed, opening >= 12.5 cm, 4-35 cm deep, footprint <= 60 cm.",
    "bathtub": "water-tight open-top basin a lying person fits in: inner length >= 1.2 m, inner depth >= 0.25 m, "
    "0.35-0.8 m tall.",
    "plate": "flat level food surface with a raised rim that keeps a food disc on it: largest side 15-32 cm, 1-4 cm "
    "tall.",
    "table": "level rigid top on which a box placed from above stays: top 0.55-1.1 m above the ground, >= 0.5 m "
    "across, free space above.",
    "chair": "level seat for one person on which a sitting box stays, the feet supported: seat 0.38-0.55 m high, "
    "or up to 0.85 m with a footrest 0.4-0.55 m below it (a bar chair); 0.3-0.7 m across (between any arms), "
    ">= 0.8 m free above the seat; a backrest is optional.",
    "stool": "seat for one person usable without a backrest (sitting-box test): seat 0.38-0.85 m high (dining to bar), "
    "0.25-0.7 m across.",
    "bench": "seat for two or more (sitting-box test at two places side by side): seat 0.38-0.55 m high, >= 0.9 m "
    "long.",
    "bed": "level surface a person lies on (a lying box stays on it): >= 1.8 m long and >= 0.8 m wide, 0.15-0.9 m "
    "above the ground, free space above.",
    "shelf": "two or more level surfaces stacked >= 20 cm apart, each holding a box placed on it; top surface above "
    "1.1 m or below others so it is not a table.",
    "cupboard": "enclosure that stores items on its own level floor or boards, reached through an opening at the front "
    "and roofed over (a box pushed in from the front stays inside): inner height >= 15 cm, depth >= 12 cm; doors "
    "optional.",
    "tray": "rimmed flat surface carried with items on it: largest side 15-60 cm, height <= 4.5 cm and <= 0.2 x "
    "largest side.",
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


def _spec(name: str, group: str, affords: Iterable[str], height: tuple[float, float], plan: tuple[float, float],
          mimics: str = "") -> ClassSpec:
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
        _spec("lounge_chair", "seat", {"chair", "stool"}, (0.48, 0.98), (0.85, 1.32)),
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
    "goblet": "1.2-1.45 m tall with a 0.6-0.9 m rim on a stem: taller than any vessel but a vase, whose opening is <= "
    "12 cm",
    "ladle": "a 0.7-1 m cup on a 2-3 m pole: no level surface, too tall for a trash bin, too small inside for a "
    "bathtub",
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
    ("bowl", "cup"): "false: it holds liquid, but a rim of 13-25 cm is too wide to hold in one hand and it is too "
    "shallow to carry full (height <= 0.5 x Ø).",
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
    ("table_tilted", "table"): "false: the top is 30° off level whenever the four feet stand; no stable pose has it "
    "level.",
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
    ("armchair", "table"): "false: the rolled arms (0.57-0.66 m) are 14-21 cm wide and round, no level top 0.5 m "
    "across.",
    ("armchair", "bench"): "false: one seat, 0.48-0.58 m wide, shorter than a bench's 0.9 m.",
    ("bar_chair", "chair"): "true: a seat 0.64-0.78 m high with footrest rungs 0.43-0.5 m below it (a bar chair).",
    ("bar_chair", "stool"): "true: a seat 0.64-0.78 m high, inside a stool's dining-to-bar 0.38-0.85 m.",
    ("bar_chair", "table"): "false: the seat is at table height but 0.4-0.46 m across, under a table's 0.5 m.",
    ("shell_chair", "chair"): "true: a level cushion Ø 0.5-0.6 m at 0.39-0.45 m inside the shell, open above its "
    "front.",
    ("shell_chair", "stool"): "true: the sitting box stays on the cushion; a stool needs no backrest.",
    ("shell_chair", "trash_bin"): "false: the shell is cut below the cushion at the front: items and droplets run off "
    "the front, there is no basin.",
    ("shell_chair", "basket"): "false: no basin (cut open at the front), and its 0.68-0.77 m exceed a basket's 60 cm.",
    ("lounge_chair", "chair"): "true: a seat 0.5-0.6 m square reclined 10-20 deg, its front edge 0.37-0.42 m up (a "
    "chair's seat height, under the knees), and a back at 100-125 deg to it: a person sits in it reclined, the trunk "
    "on the back, as in an easy chair.",
    ("lounge_chair", "stool"): "true: the sitting body stays on the seat; a stool needs no backrest (as chair -> "
    "stool).",
    ("lounge_chair", "bench"): "false: one seat, 0.5-0.6 m wide, narrower than a bench's 0.9 m.",
    ("lounge_chair", "table"): "false: no level top; the seat is reclined and 0.37-0.42 m up, below the table range.",
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
    ("saucepan", "bowl"): "true: a 15-22 cm open vessel, 5.8-10 cm deep inside, height <= 0.48 x rim: it holds food "
    "and liquid as a bowl does; the long handle is not part of the rim.",
    ("saucepan", "basket"): "true: it keeps dropped items inside and is carried by its handle, 31-44 cm long in all, "
    "inside a basket's 60 cm (as bowl -> basket; a real-set label that says otherwise disagrees with the definition).",
    ("saucepan", "pot"): "false: height <= 0.48 x rim, shallower than a pot's 0.55 (a deep one is a handle_pot).",
    ("saucepan", "cup"): "false: a 15-22 cm rim, wider than a cup's 12.5 cm.",
    ("handle_pot", "pot"): "true: Ø 16-21 cm, 11-17 cm tall, height >= 0.62 x rim, water-tight.",
    ("handle_pot", "basket"): "true: as pot -> basket: it keeps dropped items inside and is carried by its handle.",
    ("handle_pot", "bowl"): "false: height >= 0.62 x rim, deeper than a bowl's 0.55.",
    ("handle_pot", "vase"): "false: a 16-21 cm opening, wider than a vase's 12 cm.",
    ("scoop", "bowl"): "true: a flat-bottomed round dipper Ø 13-17 cm, 4.9-7.1 cm deep inside, height <= 0.48 x rim, "
    "on a short handle: it holds liquid as a bowl does.",
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
    ("cubby", "basket"): "false: as built its opening faces sideways. On its back it would hold dropped items, but "
    "that is another pose, which the ground truth does not count (as a bathtub on its side is no table).",
    ("cubby", "shelf"): "false: its top (0.26-0.34 m) is neither above 1.1 m nor below other boards.",
    ("cubby", "stool"): "false: 0.26-0.34 m high, below a seat's 0.38 m.",
    ("wall_shelf_box", "cupboard"): "true: an enclosure with its own floor, roofed, open at the front, 16-24 cm high "
    "inside.",
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
    ("riser", "basket"): "false: open at the bottom (a hollow box) or at front, back and bottom (a U): items fall "
    "through.",
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
        "Generated by `python -m rail_mj.dataset --matrix` from `rail_mj/dataset/ground_truth.py`; "
        "do not edit by hand.",
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
        "clean one). The world family corrupts "
        + f"{100 * WORLD_CORRUPTION_RATE:.0f} % of its objects with one or two of "
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


def family_classes(family: str) -> tuple[str, ...]:
    """The classes of a family (``core``, ``world`` or ``all``), in matrix order."""
    if family not in FAMILIES:
        raise DatasetError(f"unknown family {family!r}; valid families: {', '.join(FAMILIES)}")
    return FAMILIES[family]
