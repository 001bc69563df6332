"""``container``: a 3×3×3 grid of droplet spheres dropped from above the opening.

Success: most droplets rest inside the box, below the rim and off the ground,
none came through the object, and the object stays upright. The analyser also
asks that they sit in a cavity: their mean centre at least :data:`MIN_DEPTH` of
the box height below the rim, and walls all round most of them (the enclosure
probe's horizontal rays meet the object every way but in sectors narrower than
:data:`~rail_mj.core.profile.OPEN_SECTOR` directions). A row's :class:`ContainerParams`
size its droplets and say whether it holds water, and whether flower stems must stand upright in it (a vase:
a stem on the floor of the poured water, leaning on the rim, within
:data:`~rail_mj.affordances.kinds.base.NEAR_AXIS_DEG` of vertical).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import ClassVar, cast

import rail_mj.core.profile as profile
from rail_mj.affordances.kinds.base import (
    MAX_OBJECT_TILT_DEG,
    MOST,
    NEAR_AXIS_DEG,
    SCORING_HEADER,
    SIDES,
    WATER_DENSITY,
    AgentShape,
    Kind,
    clearance,
    register_kind,
    side_offset,
    via,
)
from rail_mj.affordances.row import Affordance, KindParams
from rail_mj.core.profile import (
    AgentLayout,
    CandidateInteraction,
    MotionPlan,
    PoseCandidates,
    ScoringCode,
    ViaPose,
)

__all__ = ["LIQUID_RADIUS", "MIN_DEPTH", "MAX_OPEN", "Droplets", "ContainerParams", "Container"]

#: A drop of water's radius (m): 8 mm across, the largest a falling drop holds together; it leaks through 1 cm
#: slots and holes. The smallest droplet agent, and a liquid's only size.
LIQUID_RADIUS = 0.004


@dataclass(frozen=True)
class Droplets:
    """Sizing of a container's droplet agents: radius = ``scale`` × the middle OBB dim, clipped to
    [``min_radius``, ``max_radius``] m; at the default scale the 3x3x3 grid spans ~30% of that dim."""

    scale: float = 0.045  # the grid spans ~30% of the opening: a pour narrower than it, as from a jug
    min_radius: float = LIQUID_RADIUS  # no agent smaller than a drop of water
    # items grow with the opening: a basket's or a bin's size prior bounds them (a fruit, 10 cm across at most)
    max_radius: float = math.inf


@dataclass(frozen=True)
class ContainerParams(KindParams):
    """A container row's own fields: its droplets, and whether it holds water."""

    #: each field in words, for a model writing a row (rail_mj.llm.prompts)
    DOCS: ClassVar[dict[str, str]] = {
        "droplets.scale": "droplet radius as a fraction of the object's middle OBB dim (the 3x3x3 grid then spans "
                          "~7 radii)",
        "droplets.min_radius": "smallest droplet radius, m (a drop of water: 0.004)",
        "droplets.max_radius": "largest droplet radius, m (what the object carries: a fruit 0.05; inf: no cap; "
                               "0.004 makes the droplets a liquid)",
        "holds_water": "true: it holds liquid, so a pose needs a basin that keeps water poured in",
        "basin_length": "least length of that basin at its spill level, m",
        "stems": "true: it holds flower stems upright in its water (a vase)",
    }

    droplets: Droplets = Droplets()
    #: it holds liquid, so a pose has a basin on the spill map (water poured in stays; an upturned desk's knee
    #: hole, walled but for its open front, lets it run out), at least ``basin_length`` (m) long at its spill level
    holds_water: bool = False
    basin_length: float = 0.0
    #: it holds flower stems upright in its water (a vase): see :func:`_stem_lean`
    stems: bool = False

    def scaled(self, factor: float) -> ContainerParams:
        """The basin's least length scales; the droplets do not (water is water at any scale)."""
        return replace(self, basin_length=self.basin_length * factor)


#: Horizontal offset (units of h) of the above_<side> plans from the pose's opening (or its box centre, in a pose
#: without a basin): a handle the basin map missed shifts the box centre off the cavity's axis by a fraction of
#: the half size, so the grid must move by about that much, not onto the rim.
_OFFSET = 0.3

#: Least depth of the droplets' mean centre below the rim, as a fraction of the pose's box height. A closed box
#: whose decomposed top is slightly grooved holds droplets just under its top (a few % of its height); a cavity
#: holds them near its floor, even a goblet's bowl on its stem (about a third of the height below the rim).
MIN_DEPTH = 0.2

#: Largest fraction of the droplets inside that may lie open to one side: a cavity walls most of its droplets
#: all round.
MAX_OPEN = MOST

#: Droplets in a grid of this many per side (the paper's 3 x 3 x 3 droplets).
_GRID = 3

_BODY = '''    """Fraction of droplets inside the box below the rim and off the ground, minus {min_frac}; -1 if tipped,
    or if a droplet leaked through to the ground under the object."""
    e = object_half_extents
    h = e[:, None, :]
    inside = (np.abs(agent_pos[:, :, 0]) < h[:, :, 0]) & (np.abs(agent_pos[:, :, 1]) < h[:, :, 1])
    inside = inside & (agent_pos[:, :, 2] < h[:, :, 2]) & (contacts_ground == 0)
    frac = np.mean(inside, axis=1)
    # a droplet on the ground under the middle of the object came through it: the container leaks
    rel = agent_pos - object_pos[:, None, :]  # the object may have slid under the droplets' impacts
    under = (rel[:, :, 0] / h[:, :, 0]) ** 2 + (rel[:, :, 1] / h[:, :, 1]) ** 2 < {beneath!r}
    leaked = np.any(under & (contacts_ground > 0), axis=1)
    ok = (object_tilt < {max_tilt:.4f}) & ~leaked
    return np.where(ok, frac - {min_frac}, -1.0)
'''


def _leaked(c: CandidateInteraction) -> bool:
    """Whether a pour is evidence of a leak: it landed in the object, and most of its droplets that reached the
    ground lie beneath the object's middle, so they came through it rather than over the rim.

    Landed: most droplets rest on the object, or, poured at the centre, most stayed off the ground (they plug a
    hole in the base). Droplets that fell past a handle reach the ground or pile there touching nothing; one that
    spills over the rim by a handle lands beside the body.
    """
    s = c.summary
    landed = s.frac_touching_object >= MOST or (c.plan == "above" and s.frac_on_ground < MOST)
    return landed and s.frac_through_object > 0 and s.frac_through_object >= MOST * s.frac_on_ground


#: A liquid holder's spill level stands at least this fraction of the pose's height: an upright vessel's is its rim
#: (a scoop's 0.5-0.7 under its rising handle); a bowl on its side holds a puddle in its wall at 0.15-0.2.
_FILL = 0.35


def _basin_fault(aff: Affordance, pose: PoseCandidates) -> str:
    """Why a pose of a liquid holder holds no water, from its spill map; "" when it does."""
    if pose.basin is None:
        return (f"water poured into it runs out: seen from above the pose has no basin (walls all round), and a "
                f"{aff.name} holds liquid")
    height = 2.0 * pose.half_extents[2]
    if pose.basin.rim < _FILL * height:
        return (f"water poured into it stands {pose.basin.rim:.3f} m deep at most, under {_FILL:.2f} of its "
                f"{height:.2f} m height: a puddle in a wall (a vessel on its side), not a {aff.name} filled from above")
    basin_length = cast(ContainerParams, aff.params).basin_length
    if pose.basin.length < basin_length:
        return (f"its basin holds water {pose.basin.length:.2f} m long; a {aff.name}'s is at least "
                f"{basin_length:g} m")
    return ""


def _stem_lean(c: CandidateInteraction, pose: PoseCandidates) -> tuple[float, float, float]:
    """(lean from vertical in deg, depth m, width m) of a flower stem in the water a pour left: its foot on the
    floor where the droplets came to rest, leaning on the rim across the water's surface (the basin's longer side
    at the spill level). A stem in a vessel as wide as it is deep leans 45 deg, across the mouth; in a vase it
    stands."""
    depth = (1.0 - c.summary.mean_height) * pose.half_extents[2]  # below the box top (mean_height: units of h)
    width = pose.basin.length if pose.basin is not None else math.inf
    return math.degrees(math.atan2(width, max(depth, 0.0))), depth, width


@register_kind
class Container(Kind):
    name = "container"
    decomposition_matters = True
    params_model = ContainerParams
    agent_description = ("Small spheres standing for droplets of liquid (or items bigger than the holes of a "
                         "basket), sized to the object's opening, in a 3x3x3 grid.")
    interaction_description = ("The grid of droplets is brought above the object's opening (its deepest basin seen "
                               "from above) and released so the droplets fall in; alternatives release it offset "
                               "from there to the front, back, left and right.")
    expected_outcome = ("Most droplets end inside the {name}'s bounding box, below its rim, not touching the ground, "
                        "and the {name} stays upright.")

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        d = cast(ContainerParams, aff.params).droplets
        r = max(d.min_radius, min(d.max_radius, d.scale * dims[1]))
        mass = WATER_DENSITY * 4.0 / 3.0 * math.pi * r**3  # a sphere of water
        # rolling friction lets droplets that miss come to rest instead of rolling on the ground forever
        return AgentShape(f'type="sphere" size="{r:.4f}" condim="6" friction="1 0.005 0.0005"', r, r, mass,
                          "droplet")

    def layout(self, shape: AgentShape) -> AgentLayout:
        """A 3×3×3 grid, 0.4 droplet diameters apart (they fall as a loose pour, not a block); droplets pile up."""
        s = round(2.4 * shape.radius, 5)  # centres 1.2 diameters apart
        return AgentLayout(nx=_GRID, ny=_GRID, nz=_GRID, sx=s, sy=s, sz=s, collide_agents=True)

    def plans(self, shape: AgentShape) -> list[MotionPlan]:
        plans = [MotionPlan(name="above", description="Hold the droplet grid centred above the opening, just over "
                                                     "the rim; release it so the droplets fall in.")]
        plans += [MotionPlan(name=f"above_{side}", description=f"Hold the droplet grid above the rim, offset to the "
                                                               f"{side} of the opening by {_OFFSET:g} of the half "
                                                               "size (the basin map may have missed it); release it.")
                  for side, _, _ in SIDES]
        return plans

    def via_poses(self, plan: str, shape: AgentShape, layout: AgentLayout) -> list[ViaPose]:
        spread_z = (layout.nz - 1) / 2.0 * layout.sz + shape.radius  # grid half height
        ox, oy = side_offset(plan, _OFFSET)
        # poured at the opening: over a saucepan's pan, not its box's centre by the handle, where the droplets
        # bounce off the rim and fall beside the body
        return [via((ox, oy, 1), (0, 0, spread_z + clearance(shape)), "opening"),
                via((ox, oy, 1), (0, 0, spread_z + 0.002), "opening")]  # released 2 mm over the rim

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        body = _BODY.format(min_frac=MOST, max_tilt=math.radians(MAX_OBJECT_TILT_DEG),
                            beneath=profile.BENEATH_MIDDLE)
        return ScoringCode(description="Success when more than half the droplets rest inside the object's box "
                                       "below the rim and off the ground, none leaks through to the ground under "
                                       "the object, and the object is upright.",
                           source=SCORING_HEADER + body)

    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        s = c.summary
        if c.via_poses[0][2] < h[2]:
            return False, "the droplets did not come from above the opening"
        # a fifth on the ground: spray over the rim of a full vessel, not a pour that missed it
        if s.frac_inside_bbox < MOST or s.mean_height >= 1.0 or s.frac_on_ground > 0.2:
            return False, (f"only {s.frac_inside_bbox:.0%} of droplets rest inside below the rim "
                           f"({s.frac_on_ground:.0%} on the ground)")
        depth = (1.0 - s.mean_height) / 2.0
        if depth < MIN_DEPTH:
            return False, (f"the droplets rest {depth:.0%} of the height below the rim, on a top rather than in a "
                           f"cavity (at least {MIN_DEPTH:.0%} deep)")
        if s.frac_open_side > MAX_OPEN:
            return False, (f"{s.frac_open_side:.0%} of the droplets inside lie open to one side (no wall over a "
                           "sector of 67 deg or more): the opening is no enclosing cavity")
        return True, (f"{s.frac_inside_bbox:.0%} of droplets from above rest inside, {depth:.0%} of the height below "
                      "the rim, walled all round")

    def evidence_plans(self, aff: Affordance, plans: Sequence[str]) -> set[str]:
        """Every pour: a leak from any of them, failed or not, refuses the pose."""
        return set(plans)

    def accept_pose(
        self, aff: Affordance, accepted: list[CandidateInteraction], pose: PoseCandidates
    ) -> tuple[list[CandidateInteraction], str]:
        # whichever pour it was: a slatted crate leaks from its side pours too
        leaks = [c.plan for c in pose.candidates + pose.failed if _leaked(c)]
        if leaks:
            return [], (f"droplets poured into the object ({', '.join(leaks)}) came through it to the ground "
                        f"beneath; a {aff.name} that leaks does not hold")
        params = cast(ContainerParams, aff.params)
        why = _basin_fault(aff, pose) if params.holds_water else ""
        if why:
            return [], why
        if params.stems and accepted:
            leans = [_stem_lean(c, pose) for c in accepted]
            upright = [c for c, (lean, _, _) in zip(accepted, leans, strict=True) if lean <= NEAR_AXIS_DEG]
            if not upright:
                lean, depth, width = min(leans)
                return [], (f"a flower stem standing in the water {depth:.3f} m below the rim and leaning on a "
                             f"{width:.3f} m wide mouth leans {lean:.0f} deg from vertical; a {aff.name} holds "
                             f"stems within {NEAR_AXIS_DEG} deg of upright (water at least 1.7 times as deep as its "
                             "mouth is wide)")
            return upright, ""
        return accepted, ""
