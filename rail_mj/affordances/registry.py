"""The affordance registry: one row per named use, read by everything that asks "what is a cup?".

A row (:class:`rail_mj.affordances.row.Affordance`) holds the canonical name,
its aliases, the kind of physics that imagines it (:mod:`rail_mj.affordances.kinds`)
and that kind's own parameters, the interaction-based definition, the real-world
size ranges of the stage-1 dimension check, the pose envelope, and whether the
paper evaluates it. How a requested name becomes a row (spelling, plurals, aliases)
lives in :mod:`rail_mj.affordances.names`. A new affordance is a new row here, plus
a kind file only when its physics is new (docs/new_affordance.md).

Rows also come from affordance files (TOML, parsed by :mod:`rail_mj.affordances.files`): :func:`load`
registers a file's rows after the built-in ones, and installed packages' ``rail_mj.affordances`` entry
points are loaded once, on the first lookup (:func:`ensure_entry_points`). A name or alias that clashes with
a registered row is an error naming both, unless the new row says ``override = true``; :func:`unload_all`
goes back to the built-in rows.

The dataset's ground truth (:mod:`rail_mj.dataset.ground_truth`) reads the names from here
but keeps its own per-class truth: it is what these rules are measured against.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

from rail_mj.affordances.envelope import Envelope
from rail_mj.affordances.files import FileRow, entry_point_rows, parse, read
from rail_mj.affordances.kinds.container import LIQUID_RADIUS, ContainerParams, Droplets
from rail_mj.affordances.kinds.seat import SeatParams
from rail_mj.affordances.kinds.surface import SurfaceParams
from rail_mj.affordances.row import Affordance
from rail_mj.core.errors import AffordanceFileError

__all__ = [
    "LIQUID_RADIUS",
    "REGISTRY",
    "BY_NAME",
    "SOURCES",
    "register",
    "load",
    "load_text",
    "trial",
    "load_files",
    "unload_all",
    "ensure_entry_points",
    "PAPER_AFFORDANCES",
    "known_affordances",
    "PERSON_HEIGHT",
    "FIGURE_HEIGHTS",
]

#: A person's height (m): the registry's sizes are those of things a person uses.
PERSON_HEIGHT = 1.7

#: Droplets of a liquid: drops of water (LIQUID_RADIUS), small enough to leak through a basket's slots, the same
#: size in any vessel (a vase's narrow neck or a bathtub).
_LIQUID = Droplets(max_radius=LIQUID_RADIUS)

#: A hand's grip (m): the widest rim or body one hand holds round (a cup's, a jar's, a pen holder's widest), the
#: narrowest a vessel held by its handles or in both hands has (a bowl, a basket, a pot, a bucket).
_GRIP = 0.125
#: A cup's height (m): an espresso cup's 6 cm to a tall mug's 16 cm, deep enough to drink from; a pencil cup's too.
_CUP_HEIGHT = (0.06, 0.16)
#: The line between a wide, shallow vessel and a deep one, as wall height / rim width: a bowl's wall is at most
#: 0.55 of its rim (a deep cereal bowl), a cup's or a bucket's higher.
_BOWL_DEPTH = 0.55
#: The span of two arms carrying a thing before the body (m): a basket's or a tray's widest.
_ARMS = 0.6
#: A dish's rim (m): a finger high, 1-4.5 cm from its foot to its rim (a plate's, a tray's, a saucer's, a soap
#: dish's); a vessel (a bowl, a basket) is deeper than the deepest dish.
_DISH = (0.01, 0.045)
#: A plate's diameter (m): a side plate's 15 cm to a charger's 32 cm. A saucer is smaller than a side plate; a
#: cupboard is at least a plate deep.
_PLATE = (0.15, 0.32)
#: A saucer's diameter (m): under a cup's foot (10 cm) to a side plate's size.
_SAUCER = (0.1, _PLATE[0])
#: A tray's side (m): carried in two hands, 15 cm (a tray for one cup) to the span of the arms.
_TRAY = (0.15, _ARMS)
#: A table's lowest top (m): a seated person's elbow over a low table (0.55 m); a coffee table is lower.
_TABLE_LOW = 0.55
#: A standing person's hip height (m; Pheasant, Bodyspace: about 0.9 m): the highest rim one drops waste into or
#: steps over into a bath.
_HIP = 0.9
#: Seat heights (m): the lowest a person sits on, a 5th-percentile woman's popliteal height (0.36 m), and the
#: highest whose feet stand on the floor, a 95th-percentile man's with shoes (0.57 m; Pheasant, Bodyspace).
_SEAT_LOW, _KNEE = 0.36, 0.57
#: A seat's box (m): 0.4-1.3 m at its largest (a stool to an armchair's high back), 0.3-0.9 m at its smallest
#: (a seat's width to an armchair's arms).
_SEAT_LARGEST, _SEAT_SMALLEST = (0.4, 1.3), (0.3, 0.9)
#: Storage furniture's largest side (m): a wall cabinet's 0.5 m to the highest board a person reaches (2.5 m).
_FURNITURE = (0.5, 2.5)

# Every size below is a typical range of real objects of the class (catalogue sizes), m, or a ratio for the
# aspect (height / width): a prior, never a veto (rail_mj.affordances.prior). A bound left out is one the
# physics decides (droplets that do not fit an opening, a seat too small for the sitter) or one another bound
# implies (a box's length is never below its width). A row whose envelope leaves the box free states its OBB's
# largest / smallest dims instead; no row states both.


def _rows() -> tuple[Affordance, ...]:
    inf = math.inf
    return (
        Affordance("cup", "container", "A cup holds a small amount of liquid in an upward-facing cavity that can be "
                   "filled from above and keeps the liquid while resting on a table; it is held in one hand (rim at "
                   "most 12.5 cm across, 6-16 cm tall, taller than 0.55 of its width).",
                   aliases=("mug",), paper=True, params=ContainerParams(droplets=_LIQUID, holds_water=True),
                   # held in one hand (its rim the width; a handle lengthens the box, never widens it)
                   envelope=Envelope(height=_CUP_HEIGHT, width=(0.0, _GRIP), aspect=(_BOWL_DEPTH, inf))),
        Affordance("bowl", "container", "A bowl holds food or liquid in a wide, open, upward-facing cavity reachable "
                   "from above (rim 12.5-40 cm across, up to 50 cm long with a handle, at least 4.5 cm deep, height at "
                   "most 0.55 of the rim).", paper=True, params=ContainerParams(droplets=_LIQUID, holds_water=True),
                   # a rim wider than a hand's grip up to a serving bowl's 40 cm (a saucepan's handle lengthens
                   # its box, never widens it: to 50 cm, a 28 cm pan's 22 cm handle); deeper than a dish, to 20 cm
                   # deep; wide and shallow
                   envelope=Envelope(height=(_DISH[1], 0.2), width=(_GRIP, 0.4), length=(0.0, 0.5),
                                     aspect=(0.0, _BOWL_DEPTH))),
        Affordance("vase", "container", "A vase holds water and flower stems in a deep cavity with an opening at the "
                   "top, often narrower than its body (15-80 cm tall, clearly taller than wide, its body rarely over "
                   "23 cm across).", paper=True,
                   params=ContainerParams(droplets=_LIQUID, holds_water=True, stems=True),
                   # a bud vase's 15 cm to a floor vase's 80 cm; a body an arm holds (23 cm); taller than wide (1.2)
                   envelope=Envelope(height=(0.15, 0.8), width=(0.0, 0.23), aspect=(1.2, inf))),
        Affordance("pot", "container", "A pot holds food or soil in an open cavity, filled from above (rim 12.5-50 cm, "
                   "10-30 cm tall).", params=ContainerParams(droplets=_LIQUID),
                   # a cooking or flower pot: a rim wider than a hand's grip to 50 cm on a hob or a sill, 10-30 cm
                   # deep, 0.4 of its rim at least
                   envelope=Envelope(height=(0.1, 0.3), width=(_GRIP, 0.5), aspect=(0.4, inf))),
        Affordance("pen holder", "container", "A pen holder keeps pens upright in an open cavity filled from above "
                   "(at most 12.5 cm across, 6-16 cm tall).", aliases=("pencil holder", "pencil cup"),
                   # a cup for pens, a cup's size: a pen's 14 cm stands in it up to half its length
                   envelope=Envelope(height=_CUP_HEIGHT, width=(0.0, _GRIP))),
        Affordance("trash bin", "container", "A trash bin collects waste dropped through its top opening and keeps "
                   "it inside (opening at least 18 cm, 30-90 cm tall).", aliases=("trash can", "garbage can", "bin"),
                   # stands on the floor, its opening from a desk bin's knee height (30 cm) to a hip's,
                   # wider than a hand's full (18 cm) and narrower than a wheelie bin (80 cm)
                   envelope=Envelope(height=(0.3, _HIP), width=(0.18, 0.8))),
        Affordance("basket", "container", "A basket carries items in an open, often perforated cavity whose holes are "
                   "smaller than the items (opening over 12.5 cm, 4.5-35 cm deep, footprint at most 60 cm, not taller "
                   "than wide).", paper=True,
                   # items, not liquid: 2.4 cm across at least, larger than a basket's weave or slots
                   params=ContainerParams(droplets=Droplets(min_radius=0.012)),
                   # carried in the arms: wider than a hand's grip, its footprint no longer than their span, deeper
                   # than a dish (a bread basket) to 35 cm (a laundry basket) deep, not taller than wide
                   envelope=Envelope(height=(_DISH[1], 0.35), width=(_GRIP, _ARMS), length=(0.0, _ARMS),
                                     aspect=(0.0, 1.0))),
        Affordance("bathtub", "container", "A bathtub holds enough water for a person to bathe in a long open basin "
                   "on the floor (over 1 m long inside, 0.35-0.9 m tall).", aliases=("bath tub", "tub"), paper=True,
                   # the basin a bather sits in with legs stretched: their buttock-heel length, 0.6 of stature
                   # (Pheasant, Bodyspace); a console on its back, whose compartments hold water, parts it into
                   # basins 0.6-0.9 m long. The basin decides how long a tub is at least: no bound on its box
                   params=ContainerParams(droplets=_LIQUID, holds_water=True,
                                          basin_length=0.6 * PERSON_HEIGHT),  # Bodyspace
                   # a person lies in it: a rim at knee to hip height, wider than the hips (0.5 m), no longer than
                   # a lying one (2.5 m)
                   envelope=Envelope(height=(0.35, _HIP), width=(0.5, inf), length=(0.0, 2.5))),
        Affordance("plate", "dish", "A plate holds food on a low, level, nearly flat surface (15-32 cm across either "
                   "way, 1-4.5 cm tall).", aliases=("dish",), paper=True,
                   # round or oval: at least a side plate's 15 cm across its narrower way too
                   envelope=Envelope(height=_DISH, width=(_PLATE[0], inf), length=_PLATE)),
        Affordance("table", "surface", "A table holds items on a level top surface 0.55-1.12 m high and at least "
                   "0.5 m across, with free space above it and room for a person's feet under its edge.",
                   paper=True, params=SurfaceParams(legroom=True),
                   # its top at a seated person's elbow to a standing one's (a bar table's 1.12 m), wide enough
                   # for a place setting (0.5 m); the top's depth against its height is no rule: a desk or a
                   # console is 0.55-0.6 m deep and 0.6-0.77 m high
                   envelope=Envelope(height=(_TABLE_LOW, 1.12), width=(0.5, inf))),
        Affordance("chair", "seat", "A chair lets one person sit: a level seat 0.3-0.7 m across, 0.38-0.55 m "
                   "high, up to 0.77 m for a counter or bar chair (feet on a rung, a back behind), usually with a "
                   "backrest.",
                   # arms and a back make an armchair's box 0.9 m wide around a 0.5 m seat and 1.3 m high with a
                   # high back
                   _SEAT_LARGEST, _SEAT_SMALLEST, paper=True,
                   # counter and bar chairs seat a person at 0.6-0.77 m (24-30 in), their feet on a rung (the seat
                   # kind's body)
                   envelope=Envelope(rest=(_SEAT_LOW, 0.78))),
        # an armchair or a bar chair is a stool too
        Affordance("stool", "seat", "A stool lets one person sit on a level seat 0.38-0.85 m high, without a "
                   # a footstool is lower and smaller than any chair: 0.3 m at its largest, a 0.25 m seat
                   "backrest.", (0.3, _SEAT_LARGEST[1]), (0.25, _SEAT_SMALLEST[1]),
                   envelope=Envelope(rest=(_SEAT_LOW, 0.87))),  # up to a bar stool's 0.87 m
        Affordance("bench", "seat", "A bench lets people sit side by side on a long level seat 0.38-0.55 m high.",
                   # two people side by side (0.9 m) to a long garden bench (3 m); a bed's headboard makes its
                   # smallest side 0.9-1.2 m, a backless bench's is its 0.25 m seat
                   (0.9, 3.0), (0.25, 1.3), envelope=Envelope(rest=(_SEAT_LOW, _KNEE)), params=SeatParams(persons=2)),
        Affordance("bed", "lie", "A bed lets a person lie down on a large level surface a little above the floor.",
                   # a lying person (1.6 m, a child's bed) to a king size (2.6 m); a mattress on the floor (0.2 m)
                   # to a headboard (1.2 m); the sleeper a little above the floor to a high bed (0.15-0.9 m)
                   (1.6, 2.6), (0.2, 1.2), envelope=Envelope(rest=(0.15, 0.9))),
        Affordance("tray", "dish", "A tray carries items on a flat level base with a low rim (15-60 cm across either "
                   "way, at most 4.5 cm tall).",
                   # a cup's tray is 15 cm across its narrower way too
                   envelope=Envelope(height=_DISH, width=(_TRAY[0], inf), length=_TRAY)),
        Affordance("shelf", "storage", "A shelf stores items on level boards reached horizontally from the front.",
                   # a paperback's depth (0.15 m) to a storage rack's (0.8 m)
                   _FURNITURE, (0.15, 0.8), aliases=("bookshelf",)),
        Affordance("cupboard", "storage", "A cupboard stores items inside an enclosure on level boards, reached "
                   "through an opening at the front.",
                   # at least a plate's depth, within an arm's reach (1 m)
                   _FURNITURE, (_PLATE[1], 1.0), aliases=("cabinet",)),
        Affordance("bucket", "container", "A bucket carries water or soil in an open, upward-facing cavity with a "
                   "flat base, filled from above and keeping its load while standing (opening 12.5-40 cm across, "
                   "15-45 cm tall, about as tall as wide).", aliases=("pail",),
                   params=ContainerParams(droplets=_LIQUID, holds_water=True),
                   # carried by a handle beside the leg: 15-45 cm tall, wider than a hand's grip to 40 cm across;
                   # deeper than a bowl and at most twice as tall as wide, which keeps a tall narrow bin out
                   envelope=Envelope(height=(0.15, 0.45), width=(_GRIP, 0.4), aspect=(_BOWL_DEPTH, 2.0))),
        Affordance("jar", "container", "A jar stores food or liquid in a standing cavity with a wide mouth at the "
                   "top, filled from above and keeping its contents (at most 12.5 cm across, 7-30 cm tall, at least as "
                   "tall as wide).", aliases=("mason jar", "jam jar"),
                   params=ContainerParams(droplets=_LIQUID, holds_water=True),
                   # a spice jar's 7 cm to a storage jar's 30 cm, a hand's grip wide, as tall as wide
                   envelope=Envelope(height=(0.07, 0.3), width=(0.0, _GRIP), aspect=(1.0, inf))),
        Affordance("saucer", "dish", "A saucer holds a cup or a little food on a small, low dish with a shallow "
                   "well inside a rim (10-15 cm across either way, 1-4.5 cm tall).",
                   # round: a cup's foot across either way; a dish's rim high
                   envelope=Envelope(height=_DISH, width=(_SAUCER[0], inf), length=_SAUCER)),
        Affordance("nightstand", "surface", "A nightstand holds a lamp, a book or a glass beside a bed on a level top "
                   "0.4-0.76 m high, 0.25-0.55 m deep and at most 0.8 m long, lower and smaller than a table.",
                   aliases=("night stand", "bedside table", "night table", "bedside cabinet"),
                   # its top at a lying person's reach beside a bed's mattress (0.4-0.76 m), a lamp's foot deep
                   # (0.25 m) to an arm's reach (0.55 m), no longer than a bed's side allows (0.8 m)
                   envelope=Envelope(height=(0.4, 0.76), width=(0.25, 0.55), length=(0.0, 0.8))),
        # a surface on the counter: the item rests on its top, a few cm up, with no rim to keep it below
        Affordance("cutting board", "surface", "A cutting board holds food to be cut on a flat, level, rimless top "
                   "that lies on the counter (20-60 cm long, 12-40 cm wide, 0.8-5 cm thick).",
                   aliases=("chopping board", "carving board"),
                   # a board for a hand and a knife: 0.8-5 cm thick, 12-40 cm wide, 20-60 cm long
                   envelope=Envelope(height=(0.008, 0.05), width=(0.12, 0.4), length=(0.2, 0.6))),
        # a low table in front of a sofa: its top is about a sofa seat's height (0.4-0.46 m, 16-18 in), low ones
        # 0.3 m, lower than a table's; 0.5-1.6 m long (a small round one to two thirds of a 2.3 m sofa), at least
        # a tray across (0.45 m).
        # One sits behind it, not at it with knees under its edge: no legroom
        Affordance("coffee table", "surface", "A coffee table holds cups, books or a tray in front of a sofa on a "
                   "level top 0.3-0.55 m high, at least 0.45 m across, lower than a table.",
                   aliases=("cocktail table", "sofa table"),
                   envelope=Envelope(height=(0.3, _TABLE_LOW), width=(0.45, 1.2), length=(0.5, 1.6))),
        # a bar of soap is 7-10 cm long, 5-6.5 cm wide, 2-3 cm thick; its dish is a little longer (9-16 cm),
        # a dish's rim high, ribbed or with a shallow well
        Affordance("soap dish", "dish", "A soap dish holds a bar of soap on a small, low dish with a shallow well or "
                   "ribs inside a rim (9-16 cm long, 1-4.5 cm tall).",
                   aliases=("soap holder", "soap tray"),
                   envelope=Envelope(height=_DISH, length=(0.09, 0.16))),
    )


#: Every affordance by canonical name. Row order counts: PAPER_AFFORDANCES (the dataset's default request)
#: follows it, and of two alternatives equally close in size the earlier row wins.
REGISTRY: dict[str, Affordance] = {a.name: a for a in _rows()}

#: The paper's eight, in registry order (cup, bowl, vase, basket, bathtub, plate, table, chair).
PAPER_AFFORDANCES: tuple[str, ...] = tuple(a.name for a in REGISTRY.values() if a.paper)

#: Every registered name and alias -> its row (the index the name lookup reads).
BY_NAME: dict[str, Affordance] = {**{alias: a for a in REGISTRY.values() for alias in a.aliases}, **REGISTRY}

#: Where each registered row came from: ``built-in``, an affordance file's path, or an entry point.
SOURCES: dict[str, str] = dict.fromkeys(REGISTRY, "built-in")

_BUILT_IN = (dict(REGISTRY), dict(BY_NAME), dict(SOURCES))
#: The rows of each loaded affordance file, by resolved path: loading a file again is a no-op.
_LOADED: dict[str, tuple[Affordance, ...]] = {}
#: The entry points' state: ``pending`` (not looked at yet), ``loading`` or ``done``.
_ENTRY_POINTS = {"state": "pending"}


def _snapshot() -> tuple[dict, dict, dict]:
    return dict(REGISTRY), dict(BY_NAME), dict(SOURCES)


def _restore(saved: tuple[dict, dict, dict]) -> None:
    for table, content in zip((REGISTRY, BY_NAME, SOURCES), saved):
        table.clear()
        table.update(content)


def _clash(source: str, row: Affordance, n: str, holder: Affordance, sources: dict[str, str], hint: str) -> str:
    what = "name" if n == row.name else "alias"
    role = "the name" if n == holder.name else "an alias"
    return (f"{source}: affordance {row.name!r}: its {what} {n!r} is already {role} of the affordance "
            f"{holder.name!r} ({sources[holder.name]}); {hint}")


def _add(entry: FileRow, source: str, table: dict[str, Affordance], index: dict[str, Affordance],
         sources: dict[str, str]) -> None:
    """Add one row to copies of the registry's tables, by the clash rule (see the module's doc)."""
    row = entry.row
    rename = "give it another name, or set override = true in its row to replace that one"
    old = table.get(row.name)
    if old is not None:  # the same name: the whole row is replaced
        if not entry.override:
            raise AffordanceFileError(_clash(source, row, row.name, old, sources, rename))
        for n in (old.name, *old.aliases):
            if index.get(n) is old:
                del index[n]
    for n in (row.name, *row.aliases):
        holder = index.get(n)
        if holder is None:
            continue
        if n == holder.name:
            raise AffordanceFileError(_clash(source, row, n, holder, sources, (
                f"an alias never replaces a row; give a row named {n!r} with override = true to replace it"
                if entry.override else "choose another alias")))
        if not entry.override:
            raise AffordanceFileError(_clash(source, row, n, holder, sources, rename))
        shrunk = replace(holder, aliases=tuple(a for a in holder.aliases if a != n))  # the alias moves over
        table[holder.name] = shrunk
        for a in (shrunk.name, *shrunk.aliases):
            index[a] = shrunk
        del index[n]
    table[row.name] = row
    index.update(dict.fromkeys(row.aliases, row))
    index[row.name] = row
    sources[row.name] = source


def register(entries: Iterable[FileRow], source: str) -> None:
    """Register rows after the ones registered before (all or none of them), by the clash rule: a name or alias
    already registered is an :class:`AffordanceFileError` naming both rows, unless the new row overrides it
    (a row of the same name is replaced; an alias it names moves to it). ``source`` names the rows' origin."""
    ensure_entry_points()
    table, index, sources = _snapshot()
    for entry in entries:
        _add(entry, source, table, index, sources)
    _restore((table, index, sources))


@contextmanager
def trial(entries: Iterable[FileRow], source: str) -> Iterator[None]:
    """Register rows for the block only (a stage-0 row being proven on its prototypes): afterwards the registry is
    as it was before, whatever happened in the block."""
    saved = _snapshot()
    try:
        register(entries, source)
        yield
    finally:
        _restore(saved)


def load(path: str | os.PathLike[str]) -> tuple[Affordance, ...]:
    """Register the rows of the affordance file at ``path`` (:mod:`rail_mj.affordances.files`) and return
    them; a file loaded before (the same resolved path) is not read again."""
    key = str(Path(path).resolve())
    if key not in _LOADED:
        entries = read(path)
        register(entries, str(path))
        _LOADED[key] = tuple(e.row for e in entries)
    return _LOADED[key]


def load_text(text: str, source: str) -> tuple[Affordance, ...]:
    """Register the rows of an affordance file's ``text`` (e.g. a model's stage-0 row), ``source`` naming it in
    errors; the same text registered before is not registered again."""
    key = "text:" + hashlib.sha256(text.encode()).hexdigest()
    if key not in _LOADED:
        entries = parse(text, source)
        register(entries, source)
        _LOADED[key] = tuple(e.row for e in entries)
    return _LOADED[key]


def load_files(paths: Sequence[str | os.PathLike[str]]) -> None:
    """:func:`load` each file, in order (a later file may override an earlier one's rows)."""
    for path in paths:
        load(path)


def unload_all() -> None:
    """Back to the built-in rows alone: every file's and entry point's rows are unregistered, and the entry
    points are loaded again at the next lookup."""
    _restore(_BUILT_IN)
    _LOADED.clear()
    _ENTRY_POINTS["state"] = "pending"


def ensure_entry_points() -> None:
    """Register the rows of the installed ``rail_mj.affordances`` entry points, once (every lookup calls this).
    A broken entry point is an :class:`AffordanceFileError` naming it and its distribution, at every lookup
    until it is fixed; nothing of the entry points is registered then."""
    if _ENTRY_POINTS["state"] != "pending":
        return
    _ENTRY_POINTS["state"] = "loading"
    saved = _snapshot()
    try:
        for source, entries in entry_point_rows():
            register(entries, source)
    except BaseException:
        _restore(saved)
        _ENTRY_POINTS["state"] = "pending"
        raise
    _ENTRY_POINTS["state"] = "done"


def known_affordances() -> list[str]:
    """The registered canonical names, sorted."""
    ensure_entry_points()
    return sorted(REGISTRY)


#: A doll's or a teddy bear's height (m): the figure a child plays with, a fashion doll's 0.3 m.
_DOLL = 0.3
#: A child's height (m): a six-year-old's stature (WHO growth charts, 1.15 m).
_CHILD = 1.15

#: Heights (m) of the figures a request may name as its agent. A figure uses furniture, dishes and vessels made
#: at its own scale, so a doll's chair is a chair scaled by 0.3 / 1.7. Any other agent is an item a person
#: carries (an apple, a pen, a book, water) and keeps a person's scale. A man or a woman is a person: their mean
#: statures differ from a person's by 3%, well inside a size prior's width.
FIGURE_HEIGHTS: dict[str, float] = {
    "person": PERSON_HEIGHT, "man": PERSON_HEIGHT, "woman": PERSON_HEIGHT, "child": _CHILD, "kid": _CHILD,
    "baby": 0.6,  # a one-year-old's length (WHO growth charts, 0.75 m lying; 0.6 m sitting up)
    "doll": _DOLL, "teddy": _DOLL, "teddy bear": _DOLL,
    "action figure": 0.15,  # a 1:12 figure of a 1.8 m person
    "figurine": 0.1,  # a table-top figure, a hand high
}
