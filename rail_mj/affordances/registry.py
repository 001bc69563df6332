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

import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import replace
from pathlib import Path

from rail_mj.affordances.envelope import Envelope
from rail_mj.affordances.files import FileRow, entry_point_rows, read
from rail_mj.affordances.kinds.container import ContainerParams, Droplets
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
    "load_files",
    "unload_all",
    "ensure_entry_points",
    "PAPER_AFFORDANCES",
    "known_affordances",
    "PERSON_HEIGHT",
    "FIGURE_HEIGHTS",
]

#: Largest droplet radius standing for a liquid, m: drops 9 mm across leak through 1 cm slots and holes.
LIQUID_RADIUS = 0.0045

#: Droplets of a liquid: small enough to leak through a basket's slots, the same size in any vessel.
_LIQUID = Droplets(max_radius=LIQUID_RADIUS)


def _rows() -> tuple[Affordance, ...]:
    inf = math.inf
    return (
        Affordance("cup", "container", "A cup holds a small amount of liquid in an upward-facing cavity that can be "
                   "filled from above and keeps the liquid while resting on a table; it is held in one hand (rim at "
                   "most 12.5 cm across, 6-16 cm tall, taller than about half its width).",
                   (0.06, 0.2), (0.03, 0.15), aliases=("mug",), paper=True,
                   params=ContainerParams(droplets=_LIQUID, holds_water=True),
                   # the rim's 12.5 cm is the width's bound (a handle lengthens the box, never widens it): a
                   # 13 cm bowl 7 cm deep is no cup
                   envelope=Envelope(height=(0.06, 0.16), width=(0.03, 0.125), length=(0.03, 0.2),
                                     aspect=(0.5, inf))),
        Affordance("bowl", "container", "A bowl holds food or liquid in a wide, open, upward-facing cavity reachable "
                   "from above (rim 12.5-35 cm across, up to 50 cm long with a handle, at least 4 cm deep, height at "
                   "most 0.55 of the rim).",
                   # a saucepan's 15-22 cm pan and its 16-22 cm handle make 31-44 cm; the rim bounds the width
                   (0.125, 0.5), (0.04, 0.2), paper=True,
                   params=ContainerParams(droplets=_LIQUID, holds_water=True),
                   envelope=Envelope(height=(0.04, 0.2), width=(0.125, 0.4), length=(0.125, 0.5),
                                     aspect=(0.0, 0.55))),
        Affordance("vase", "container", "A vase holds water and flower stems in a deep cavity with an opening at the "
                   "top, often narrower than its body (15-80 cm tall, clearly taller than wide, its body rarely over "
                   "23 cm across).", (0.15, 0.85), (0.03, 0.23), paper=True,
                   params=ContainerParams(droplets=Droplets(scale=0.035, max_radius=LIQUID_RADIUS),
                                           holds_water=True),
                   envelope=Envelope(height=(0.15, 0.8), width=(0.03, 0.23), aspect=(1.2, inf))),
        Affordance("pot", "container", "A pot holds food or soil in an open cavity, filled from above (rim 15-45 cm, "
                   "10-30 cm tall).", (0.15, 0.5), (0.1, 0.45), params=ContainerParams(droplets=_LIQUID),
                   envelope=Envelope(height=(0.1, 0.3), width=(0.15, 0.5), aspect=(0.4, inf))),
        Affordance("pen holder", "container", "A pen holder keeps pens upright in an open cavity filled from above "
                   "(opening 4-12.5 cm, 7-16 cm tall).", (0.07, 0.2), (0.04, 0.15),
                   aliases=("pencil holder", "pencil cup"),
                   envelope=Envelope(height=(0.07, 0.16), width=(0.04, 0.15))),
        Affordance("trash bin", "container", "A trash bin collects waste dropped through its top opening and keeps "
                   "it inside (opening at least 18 cm, 30-90 cm tall).", (0.3, 1.0), (0.18, 0.8),
                   aliases=("trash can", "garbage can", "bin"),
                   envelope=Envelope(height=(0.3, 0.9), width=(0.18, 0.8))),
        Affordance("basket", "container", "A basket carries items in an open, often perforated cavity whose holes are "
                   "smaller than the items (opening over 12.5 cm, 4-35 cm deep, footprint at most 60 cm, not taller "
                   "than wide).", (0.125, 0.65), (0.04, 0.6), paper=True,
                   params=ContainerParams(droplets=Droplets(min_radius=0.012)),
                   envelope=Envelope(height=(0.04, 0.35), width=(0.125, 0.6), length=(0.125, 0.65),
                                     aspect=(0.0, 1.0))),
        Affordance("bathtub", "container", "A bathtub holds enough water for a person to bathe in a long open basin "
                   "on the floor (over 1.2 m long inside, 0.35-0.8 m tall).", (1.25, 2.5), (0.35, 1.2),
                   aliases=("bath tub", "tub"), paper=True,
                   # a person lies in one basin, knees bent in a short one; a console on its back, whose
                   # compartments hold water, parts it into basins 0.6-0.9 m long
                   params=ContainerParams(droplets=Droplets(scale=0.05, max_radius=LIQUID_RADIUS),
                                          holds_water=True, basin_length=1.0),
                   envelope=Envelope(height=(0.35, 0.8), width=(0.5, 2.5), length=(1.25, 2.5))),
        Affordance("plate", "dish", "A plate holds food on a low, level, nearly flat surface (15-32 cm across, 1-4 cm "
                   "tall).", (0.15, 0.32), (0.01, 0.045), aliases=("dish",), paper=True,
                   envelope=Envelope(height=(0.01, 0.045), length=(0.15, 0.32))),
        Affordance("table", "surface", "A table holds items on a level top surface 0.55-1.1 m high and at least "
                   "0.5 m across, with free space above it and room for a person's feet under its edge.",
                   (0.55, 3.0), (0.3, 1.6), paper=True, params=SurfaceParams(legroom=True),
                   # the top's depth against its height is no rule: a desk or a console is 0.55-0.6 m deep and
                   # 0.6-0.77 m high; a bathtub on its side, which is as deep, has no room under its edge
                   envelope=Envelope(height=(0.55, 1.12), width=(0.5, 3.0), rest=(0.54, 1.12))),
        Affordance("chair", "seat", "A chair lets one person sit: a level seat 0.3-0.7 m across, 0.38-0.55 m "
                   "high, up to 0.77 m for a counter or bar chair (feet on a rung, a back behind), usually with a "
                   "backrest.",
                   (0.4, 1.3), (0.3, 0.9), paper=True,
                   # arms and a back make an armchair's box 0.9 m wide around a 0.5 m seat. Counter and bar chairs
                   # seat a person at 0.6-0.77 m (24-30 in), their feet on a rung (the seat kind's body)
                   envelope=Envelope(rest=(0.36, 0.78))),
        # sizes as a chair's: an armchair or a bar chair is a stool too
        Affordance("stool", "seat", "A stool lets one person sit on a level seat 0.38-0.85 m high, without a "
                   "backrest.", (0.3, 1.3), (0.25, 0.9), envelope=Envelope(rest=(0.36, 0.87))),
        Affordance("bench", "seat", "A bench lets people sit side by side on a long level seat 0.38-0.55 m high.",
                   # a bed's headboard makes its smallest side 0.9-1.2 m
                   (0.9, 3.0), (0.25, 1.3), envelope=Envelope(rest=(0.36, 0.57)), params=SeatParams(persons=2)),
        Affordance("bed", "lie", "A bed lets a person lie down on a large level surface a little above the floor.",
                   (1.6, 2.6), (0.2, 1.2), envelope=Envelope(length=(1.6, 2.6), rest=(0.15, 0.9))),
        Affordance("tray", "dish", "A tray carries items on a flat level base with a low rim (15-60 cm across, at "
                   "most 4.5 cm tall).", (0.15, 0.6), (0.01, 0.045),
                   envelope=Envelope(height=(0.01, 0.045), length=(0.15, 0.6))),
        Affordance("shelf", "storage", "A shelf stores items on level boards reached horizontally from the front.",
                   (0.5, 2.5), (0.15, 0.8), aliases=("bookshelf",)),
        Affordance("cupboard", "storage", "A cupboard stores items inside an enclosure on level boards, reached "
                   "through an opening at the front.", (0.5, 2.5), (0.3, 1.0), aliases=("cabinet",)),
        # the bucket's height/width keeps a bowl (at most 0.55) and a tall narrow bin out
        Affordance("bucket", "container", "A bucket carries water or soil in an open, upward-facing cavity with a "
                   "flat base, filled from above and keeping its load while standing (opening 15-40 cm across, "
                   "15-45 cm tall, about as tall as wide).", (0.15, 0.45), (0.14, 0.4), aliases=("pail",),
                   params=ContainerParams(droplets=_LIQUID, holds_water=True),
                   envelope=Envelope(height=(0.15, 0.45), width=(0.14, 0.4), aspect=(0.6, 2.0))),
        Affordance("jar", "container", "A jar stores food or liquid in a standing cavity with a wide mouth at the "
                   "top, filled from above and keeping its contents (5-16 cm across, 7-30 cm tall, at least as "
                   "tall as wide).", (0.07, 0.3), (0.05, 0.16), aliases=("mason jar", "jam jar"),
                   params=ContainerParams(droplets=_LIQUID, holds_water=True),
                   envelope=Envelope(height=(0.07, 0.3), width=(0.05, 0.16), aspect=(1.0, inf))),
        Affordance("saucer", "dish", "A saucer holds a cup or a little food on a small, low dish with a shallow "
                   "well inside a rim (10-18 cm across, 1-3.5 cm tall).", (0.1, 0.18), (0.01, 0.035),
                   envelope=Envelope(height=(0.01, 0.035), length=(0.1, 0.18))),
        Affordance("nightstand", "surface", "A nightstand holds a lamp, a book or a glass beside a bed on a level top "
                   "0.4-0.75 m high, 0.25-0.55 m deep and at most 0.8 m long, lower and smaller than a table.",
                   (0.35, 0.8), (0.25, 0.55),
                   aliases=("night stand", "bedside table", "night table", "bedside cabinet"),
                   envelope=Envelope(height=(0.4, 0.76), width=(0.25, 0.55), length=(0.3, 0.8),
                                     rest=(0.39, 0.77))),
        # a surface on the counter: the item rests on its top, a few cm up, with no rim to keep it below
        Affordance("cutting board", "surface", "A cutting board holds food to be cut on a flat, level, rimless top "
                   "that lies on the counter (20-60 cm long, 12-40 cm wide, 0.8-5 cm thick).", (0.2, 0.6),
                   (0.008, 0.05), aliases=("chopping board", "carving board"),
                   envelope=Envelope(height=(0.008, 0.05), width=(0.12, 0.4), length=(0.2, 0.6),
                                     rest=(0.008, 0.05))),
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


def load(path: str | os.PathLike[str]) -> tuple[Affordance, ...]:
    """Register the rows of the affordance file at ``path`` (:mod:`rail_mj.affordances.files`) and return
    them; a file loaded before (the same resolved path) is not read again."""
    key = str(Path(path).resolve())
    if key not in _LOADED:
        entries = read(path)
        register(entries, str(path))
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


#: A person's height (m): the registry's sizes are those of things a person uses.
PERSON_HEIGHT = 1.7

#: Heights (m) of the figures a request may name as its agent. A figure uses furniture, dishes and vessels made
#: at its own scale, so a doll's chair is a chair scaled by 0.3 / 1.7. Any other agent is an item a person
#: carries (an apple, a pen, a book, water) and keeps a person's scale.
FIGURE_HEIGHTS: dict[str, float] = {
    "person": PERSON_HEIGHT, "man": 1.75, "woman": 1.65, "child": 1.1, "kid": 1.1, "baby": 0.6,
    "doll": 0.3, "teddy": 0.3, "teddy bear": 0.3, "action figure": 0.15, "figurine": 0.1,
}
