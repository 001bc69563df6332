"""The affordance registry: one row per named use, read by everything that asks "what is a cup?".

A row holds the canonical name, its aliases, the kind of physics that imagines
it (:mod:`rail_mj.affordances.kinds`), the interaction-based definition, the
real-world size ranges of the stage-1 dimension check, the pose envelope, and
whether the paper evaluates it. How a requested name becomes a row (spelling,
plurals, aliases) lives in :mod:`rail_mj.affordances.names`. A new affordance is a new
row here, plus a kind file only when its physics is new.

The dataset's ground truth (:mod:`rail_mj.dataset.ground_truth`) reads the names from here
but keeps its own per-class truth: it is what these rules are measured against.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Literal

from rail_mj.affordances.envelope import Envelope, Range
from rail_mj.core.errors import ConfigError

__all__ = [
    "KindName",
    "LIQUID_RADIUS",
    "Droplets",
    "Affordance",
    "REGISTRY",
    "PAPER_AFFORDANCES",
    "known_affordances",
    "PERSON_HEIGHT",
    "FIGURE_HEIGHTS",
]

KindName = Literal["container", "seat", "lie", "surface", "dish", "storage"]

#: Largest droplet radius standing for a liquid, m: drops 9 mm across leak through 1 cm slots and holes.
LIQUID_RADIUS = 0.0045


@dataclass(frozen=True)
class Droplets:
    """Sizing of a container's droplet agents: radius = ``scale`` × the middle OBB dim, clipped to
    [``min_radius``, ``max_radius``] m; at the default scale the 3x3x3 grid spans ~30% of that dim."""

    scale: float = 0.045
    min_radius: float = 0.004
    max_radius: float = 0.05


#: Droplets of a liquid: small enough to leak through a basket's slots, the same size in any vessel.
_LIQUID = Droplets(max_radius=LIQUID_RADIUS)


@dataclass(frozen=True)
class Affordance:
    """One registry row."""

    name: str  # canonical: lower case, words separated by one space
    kind: KindName
    ibd: str  # interaction-based definition
    largest: Range  # plausible range of the largest OBB dim, m
    smallest: Range  # plausible range of the smallest OBB dim, m
    envelope: Envelope = Envelope()
    aliases: tuple[str, ...] = ()
    paper: bool = False  # one of the paper's eight
    droplets: Droplets = Droplets()  # container kind only
    persons: int = 1  # seat kind only: people who sit on it side by side (1: a seat for one)
    legroom: bool = False  # surface kind only: used from beside it, so a person's feet go under its top's edge
    #: container kind only: it holds liquid, so a pose has a basin on the spill map (water poured in stays; an
    #: upturned desk's knee hole, walled but for its open front, lets it run out), at least ``basin_length`` (m)
    #: long at its spill level
    holds_water: bool = False
    basin_length: float = 0.0
    #: seat kind only: a seat higher than this (m, the sitter's bottom) has a back rising behind the sitter (a bar
    #: chair; a high seat without one is a stool, or a table's top)
    perch: float = math.inf
    #: size of the agent the row is for relative to the person its sizes are for (:meth:`scaled`; 1 = a person's)
    scale: float = 1.0

    @property
    def key(self) -> str:
        """The name as an identifier: label files, the ground-truth matrix, CLI lists (``trash_bin``)."""
        return self.name.replace(" ", "_")

    def dims_fit(self, dims: Sequence[float]) -> bool:
        """Whether OBB dims lie in the plausible size ranges (the stage-1 dimension check)."""
        return self.largest[0] <= max(dims) <= self.largest[1] and self.smallest[0] <= min(dims) <= self.smallest[1]

    def pose_fits(self, half: Sequence[float], rim: float | None = None) -> tuple[bool, str]:
        """Whether a pose's box (half extents) is inside the envelope, a vessel's aspect at its ``rim`` (the
        pose's spill level, m) when given; the reason when it is not."""
        bad = self.envelope.violation(half, rim)
        if bad is None:
            return True, ""
        name, value, (lo, hi) = bad
        return False, f"in this pose its {name} is {value:.3f}; a {self.name} has {lo:g}-{hi:g}"

    def scaled(self, factor: float) -> Affordance:
        """The row for an agent ``factor`` times the size of the one it is for ("put the doll on the chair": a
        chair for a doll). The dimension check and the envelope's lengths (height, width, length, rest) scale
        together and ``scale`` records the product; the aspect ratio stays, and so do the droplets (water is
        water at any scale)."""
        if isinstance(factor, bool) or not isinstance(factor, (int, float)) or not (math.isfinite(factor)
                                                                                    and factor > 0):
            raise ConfigError(f"an agent scale must be a positive finite number; got {factor!r}")
        if factor == 1:
            return self

        def times(r: Range) -> Range:
            return r[0] * factor, r[1] * factor

        env = self.envelope
        envelope = Envelope(height=times(env.height), width=times(env.width), length=times(env.length),
                            aspect=env.aspect, rest=times(env.rest))
        return replace(self, largest=times(self.largest), smallest=times(self.smallest), envelope=envelope,
                       perch=self.perch * factor, basin_length=self.basin_length * factor, scale=self.scale * factor)


def _rows() -> tuple[Affordance, ...]:
    inf = math.inf
    return (
        Affordance("cup", "container", "A cup holds a small amount of liquid in an upward-facing cavity that can be "
                   "filled from above and keeps the liquid while resting on a table; it is held in one hand (rim at "
                   "most 12.5 cm across, 6-16 cm tall, taller than about half its width).",
                   (0.06, 0.2), (0.03, 0.15), aliases=("mug",), paper=True, droplets=_LIQUID,
                   holds_water=True,
                   # the rim's 12.5 cm is the width's bound (a handle lengthens the box, never widens it): a
                   # 13 cm bowl 7 cm deep is no cup
                   envelope=Envelope(height=(0.06, 0.16), width=(0.03, 0.125), length=(0.03, 0.2),
                                     aspect=(0.5, inf))),
        Affordance("bowl", "container", "A bowl holds food or liquid in a wide, open, upward-facing cavity reachable "
                   "from above (rim 12.5-35 cm across, up to 50 cm long with a handle, at least 4 cm deep, height at "
                   "most 0.55 of the rim).",
                   # a saucepan's 15-22 cm pan and its 16-22 cm handle make 31-44 cm; the rim bounds the width
                   (0.125, 0.5), (0.04, 0.2), paper=True, droplets=_LIQUID,
                   holds_water=True,
                   envelope=Envelope(height=(0.04, 0.2), width=(0.125, 0.4), length=(0.125, 0.5),
                                     aspect=(0.0, 0.55))),
        Affordance("vase", "container", "A vase holds water and flower stems in a deep cavity with an opening at the "
                   "top, often narrower than its body (15-80 cm tall, clearly taller than wide, its body rarely over "
                   "23 cm across).", (0.15, 0.85), (0.03, 0.23), paper=True,
                   droplets=Droplets(scale=0.035, max_radius=LIQUID_RADIUS),
                   holds_water=True,
                   envelope=Envelope(height=(0.15, 0.8), width=(0.03, 0.23), aspect=(1.2, inf))),
        Affordance("pot", "container", "A pot holds food or soil in an open cavity, filled from above (rim 15-45 cm, "
                   "10-30 cm tall).", (0.15, 0.5), (0.1, 0.45), droplets=_LIQUID,
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
                   "than wide).", (0.125, 0.65), (0.04, 0.6), paper=True, droplets=Droplets(min_radius=0.012),
                   envelope=Envelope(height=(0.04, 0.35), width=(0.125, 0.6), length=(0.125, 0.65),
                                     aspect=(0.0, 1.0))),
        Affordance("bathtub", "container", "A bathtub holds enough water for a person to bathe in a long open basin "
                   "on the floor (over 1.2 m long inside, 0.35-0.8 m tall).", (1.25, 2.5), (0.35, 1.2),
                   aliases=("bath tub", "tub"), paper=True, droplets=Droplets(scale=0.05, max_radius=LIQUID_RADIUS),
                   # a person lies in one basin, knees bent in a short one; a console on its back, whose
                   # compartments hold water, parts it into basins 0.6-0.9 m long
                   holds_water=True, basin_length=1.0,
                   envelope=Envelope(height=(0.35, 0.8), width=(0.5, 2.5), length=(1.25, 2.5))),
        Affordance("plate", "dish", "A plate holds food on a low, level, nearly flat surface (15-32 cm across, 1-4 cm "
                   "tall).", (0.15, 0.32), (0.01, 0.045), aliases=("dish",), paper=True,
                   envelope=Envelope(height=(0.01, 0.045), length=(0.15, 0.32))),
        Affordance("table", "surface", "A table holds items on a level top surface 0.55-1.1 m high and at least "
                   "0.5 m across, with free space above it and room for a person's feet under its edge.",
                   (0.55, 3.0), (0.3, 1.6), paper=True, legroom=True,
                   # the top's depth against its height is no rule: a desk or a console is 0.55-0.6 m deep and
                   # 0.6-0.77 m high; a bathtub on its side, which is as deep, has no room under its edge
                   envelope=Envelope(height=(0.55, 1.12), width=(0.5, 3.0), rest=(0.54, 1.12))),
        Affordance("chair", "seat", "A chair lets one person sit: a level seat 0.3-0.7 m across, 0.38-0.55 m "
                   "high, up to 0.77 m for a counter or bar chair (feet on a rung, a back behind), usually with a "
                   "backrest.",
                   (0.4, 1.3), (0.3, 0.9), paper=True,
                   # a seat for one by the seat kind's second-sitter test, not by the box: arms and a back
                   # make an armchair's box 0.9 m wide around a 0.5 m seat. Counter and bar chairs seat a person
                   # at 0.6-0.77 m (24-30 in), with a back; a pelvis on an armchair's 0.79 m back is no sitter
                   envelope=Envelope(rest=(0.36, 0.78)), perch=0.57),
        # sizes as a chair's: an armchair or a bar chair is a stool too
        Affordance("stool", "seat", "A stool lets one person sit on a level seat 0.38-0.85 m high, without a "
                   "backrest.", (0.3, 1.3), (0.25, 0.9), envelope=Envelope(rest=(0.36, 0.87))),
        Affordance("bench", "seat", "A bench lets people sit side by side on a long level seat 0.38-0.55 m high.",
                   # a bed's headboard makes its smallest side 0.9-1.2 m
                   (0.9, 3.0), (0.25, 1.3), envelope=Envelope(rest=(0.36, 0.57)), persons=2),
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
                   droplets=_LIQUID,
                   holds_water=True,
                   envelope=Envelope(height=(0.15, 0.45), width=(0.14, 0.4), aspect=(0.6, 2.0))),
        Affordance("jar", "container", "A jar stores food or liquid in a standing cavity with a wide mouth at the "
                   "top, filled from above and keeping its contents (5-16 cm across, 7-30 cm tall, at least as "
                   "tall as wide).", (0.07, 0.3), (0.05, 0.16), aliases=("mason jar", "jam jar"), droplets=_LIQUID,
                   holds_water=True,
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

def known_affordances() -> list[str]:
    """The registered canonical names, sorted."""
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
