"""The offline provider's library: imagination profiles for a catalogue of affordances.

Each affordance has a *kind* that fixes the physics of its imagination:

* ``container`` — a 3×3×3 grid of droplet spheres dropped from above the
  opening; success: most droplets rest inside the box, off the ground, object upright.
* ``seat`` — a box "pelvis" lowered onto the object from above or arriving
  from a side at above-seat height; success: upright, at seat height, on the object.
* ``lie`` — a "torso" box lowered onto the object; success: level, at bed height.
* ``surface`` — a flat box placed on top; success: level on top at table height.
* ``dish`` — a flat disc of "food" lowered onto the object; success: level on it
  (a plate must also be low).
* ``storage`` — a small box pushed in horizontally; success: it ends inside
  the box resting on the object.

Everything scales with the object's OBB dims. Directions (task frame):
front = +x, back = −x, left = +y, right = −y. Via-poses are ``rel * h +
offset_m`` (see :mod:`rail_mj.llm.schemas`). The answers are the same types
the LLM stages return, and serve as the LLM prompts' few-shot examples.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from rail_mj.errors import UnknownAffordanceError
from rail_mj.llm.schemas import (
    AffordanceAnalysis,
    AgentLayout,
    AgentModel,
    CandidateInteraction,
    FunctionalPoseRequest,
    FunctionalPoseVerdict,
    MotionPlan,
    MotionPlans,
    PlanTrajectory,
    PoseVerdict,
    ScoringCode,
    TaskDescription,
    Trajectories,
    ViaPose,
)

__all__ = [
    "AffordanceSpec",
    "CATALOGUE",
    "LIQUID_RADIUS",
    "PAPER_AFFORDANCES",
    "known_affordances",
    "normalize_affordance",
    "lookup",
    "dims_fit",
    "offline_analysis",
    "offline_agent",
    "offline_layout",
    "offline_plans",
    "offline_trajectories",
    "offline_scoring",
    "offline_functional_poses",
]

IDENTITY = [1.0, 0.0, 0.0, 0.0]
INF = math.inf
#: Largest droplet radius standing for a liquid, m: drops 9 mm across leak through 1 cm slots and holes.
LIQUID_RADIUS = 0.0045
#: Directions of the side plans, (name, unit x, unit y).
SIDES = (("front", 1.0, 0.0), ("back", -1.0, 0.0), ("left", 0.0, 1.0), ("right", 0.0, -1.0))


@dataclass(frozen=True)
class AffordanceSpec:
    """One catalogue entry: what the affordance means and the object sizes it plausibly has."""

    name: str
    kind: str  # container | seat | lie | surface | dish | storage
    ibd: str
    largest: tuple[float, float]  # plausible range of the largest OBB dim, m
    smallest: tuple[float, float]  # plausible range of the smallest OBB dim, m
    droplet_scale: float = 0.045  # container droplet radius / middle OBB dim: the 3x3x3 grid spans ~30% of it
    min_droplet_radius: float = 0.004  # m
    max_droplet_radius: float = 0.05  # m; liquids: LIQUID_RADIUS, small enough to leak through a basket's slots
    # Pose-dependent envelope, checked by the scoring code and the analyzer on the pose's task-frame box:
    # H = 2 h_z, W / L = smaller / larger horizontal full extent, aspect = H / W; rest = the agent's bottom
    # height above the ground for seat, lie and surface kinds.
    height: tuple[float, float] = (0.0, INF)
    width: tuple[float, float] = (0.0, INF)
    length: tuple[float, float] = (0.0, INF)
    aspect: tuple[float, float] = (0.0, INF)
    rest: tuple[float, float] = (0.0, INF)


CATALOGUE: dict[str, AffordanceSpec] = {
    s.name: s
    for s in (
        AffordanceSpec("cup", "container", "A cup holds a small amount of liquid in an upward-facing cavity "
                       "that can be filled from above and keeps the liquid while resting on a table; it is held "
                       "in one hand (rim at most 12.5 cm across, 6-16 cm tall, taller than about half its width).",
                       (0.06, 0.2), (0.03, 0.15), max_droplet_radius=LIQUID_RADIUS,
                       height=(0.06, 0.16), width=(0.03, 0.15), length=(0.03, 0.2),
                       aspect=(0.5, INF)),
        AffordanceSpec("bowl", "container", "A bowl holds food or liquid in a wide, open, upward-facing cavity "
                       "reachable from above (rim 12.5-35 cm across, at least 4 cm deep, height at most 0.55 of "
                       "the rim).", (0.125, 0.4), (0.04, 0.2), max_droplet_radius=LIQUID_RADIUS,
                       height=(0.04, 0.2), width=(0.125, 0.4),
                       length=(0.125, 0.4), aspect=(0.0, 0.55)),
        AffordanceSpec("vase", "container", "A vase holds water and flower stems in a deep cavity with an "
                       "opening at the top, often narrower than its body (15-80 cm tall, clearly taller than "
                       "wide, its body rarely over 23 cm across).", (0.15, 0.85), (0.03, 0.23), droplet_scale=0.035,
                       max_droplet_radius=LIQUID_RADIUS, height=(0.15, 0.8), width=(0.03, 0.23), aspect=(1.2, INF)),
        AffordanceSpec("pot", "container", "A pot holds food or soil in an open cavity, filled from above "
                       "(rim 15-45 cm, 10-30 cm tall).", (0.15, 0.5), (0.1, 0.45), max_droplet_radius=LIQUID_RADIUS,
                       height=(0.1, 0.3),
                       width=(0.15, 0.5), aspect=(0.4, INF)),
        AffordanceSpec("pen holder", "container", "A pen holder keeps pens upright in an open cavity "
                       "filled from above (opening 4-12.5 cm, 7-16 cm tall).", (0.07, 0.2), (0.04, 0.15),
                       height=(0.07, 0.16), width=(0.04, 0.15)),
        AffordanceSpec("trash bin", "container", "A trash bin collects waste dropped through its top opening "
                       "and keeps it inside (opening at least 18 cm, 30-90 cm tall).", (0.3, 1.0), (0.18, 0.8),
                       height=(0.3, 0.9), width=(0.18, 0.8)),
        AffordanceSpec("basket", "container", "A basket carries items in an open, often perforated cavity "
                       "whose holes are smaller than the items (opening over 12.5 cm, 4-35 cm deep, footprint "
                       "at most 60 cm, not taller than wide).", (0.125, 0.65), (0.04, 0.6),
                       min_droplet_radius=0.012, height=(0.04, 0.35), width=(0.125, 0.6), length=(0.125, 0.65),
                       aspect=(0.0, 1.0)),
        AffordanceSpec("bathtub", "container", "A bathtub holds enough water for a person to bathe in a long "
                       "open basin on the floor (over 1.2 m long inside, 0.35-0.8 m tall).", (1.25, 2.5),
                       (0.35, 1.2), droplet_scale=0.05, max_droplet_radius=LIQUID_RADIUS,
                       height=(0.35, 0.8), width=(0.5, 2.5), length=(1.25, 2.5)),
        AffordanceSpec("chair", "seat", "A chair lets one person sit: a level seat 0.38-0.55 m high and "
                       "0.3-0.7 m across, usually with a backrest.", (0.4, 1.3), (0.3, 0.9), width=(0.3, 0.8),
                       length=(0.3, 0.8), rest=(0.36, 0.57)),
        AffordanceSpec("stool", "seat", "A stool lets one person sit on a level seat 0.38-0.85 m high, "
                       "without a backrest.", (0.3, 1.0), (0.25, 0.75), width=(0.25, 0.75), length=(0.25, 0.8),
                       rest=(0.36, 0.87)),
        AffordanceSpec("bench", "seat", "A bench lets people sit side by side on a long level seat 0.38-0.55 m "
                       "high.", (0.9, 3.0), (0.25, 0.9), length=(0.9, 3.0), rest=(0.36, 0.57)),
        AffordanceSpec("bed", "lie", "A bed lets a person lie down on a large level surface a little above "
                       "the floor.", (1.6, 2.6), (0.2, 1.2), length=(1.6, 2.6), rest=(0.15, 0.9)),
        AffordanceSpec("table", "surface", "A table holds items on a level top surface 0.55-1.1 m high and "
                       "at least 0.5 m across, its top at least as wide as it is high.", (0.55, 3.0), (0.3, 1.6),
                       height=(0.55, 1.12), width=(0.5, 3.0), aspect=(0.0, 1.0), rest=(0.54, 1.12)),
        AffordanceSpec("plate", "dish", "A plate holds food on a low, level, nearly flat surface "
                       "(15-32 cm across, 1-4 cm tall).", (0.15, 0.32), (0.01, 0.045), height=(0.01, 0.045),
                       length=(0.15, 0.32)),
        AffordanceSpec("tray", "dish", "A tray carries items on a flat level base with a low rim "
                       "(15-60 cm across, at most 4.5 cm tall).", (0.15, 0.6), (0.01, 0.045),
                       height=(0.01, 0.045), length=(0.15, 0.6)),
        AffordanceSpec("shelf", "storage", "A shelf stores items on level boards reached horizontally from "
                       "the front.", (0.5, 2.5), (0.15, 0.8)),
        AffordanceSpec("cupboard", "storage", "A cupboard stores items inside an enclosure on level boards, "
                       "reached through an opening at the front.", (0.5, 2.5), (0.3, 1.0)),
    )
}

#: The paper's eight affordances; preferred as alternatives when several fit.
PAPER_AFFORDANCES = frozenset({"cup", "bowl", "vase", "basket", "bathtub", "plate", "table", "chair"})

_ALIASES = {
    "mug": "cup",
    "trash can": "trash bin",
    "garbage can": "trash bin",
    "bin": "trash bin",
    "pencil holder": "pen holder",
    "pencil cup": "pen holder",
    "bath tub": "bathtub",
    "tub": "bathtub",
    "bookshelf": "shelf",
    "cabinet": "cupboard",
    "dish": "plate",
}


def known_affordances() -> list[str]:
    """Names the offline provider can imagine, sorted."""
    return sorted(CATALOGUE)


def normalize_affordance(name: str) -> str:
    """Canonical catalogue name (case, spaces/underscores/hyphens, simple plurals, aliases).

    Raises UnknownAffordanceError listing the known names when there is none.
    """
    key = re.sub(r"[\s_\-]+", " ", name.strip().lower())
    candidates = [key]
    if key.endswith("ves"):
        candidates.append(key[:-3] + "f")
    if key.endswith("es"):
        candidates.append(key[:-2])
    if key.endswith("s"):
        candidates.append(key[:-1])
    for cand in candidates:
        if cand in CATALOGUE:
            return cand
        if cand in _ALIASES:
            return _ALIASES[cand]
    raise UnknownAffordanceError(
        f"no offline imagination profile for affordance {name!r}; known: {', '.join(known_affordances())}. "
        "An LLM provider imagines novel affordances: use --provider anthropic with ANTHROPIC_API_KEY set."
    )


def lookup(name: str) -> AffordanceSpec:
    """The catalogue entry for a (possibly unnormalised) affordance name."""
    return CATALOGUE[normalize_affordance(name)]


def dims_fit(spec: AffordanceSpec, dims: list[float]) -> bool:
    """Whether sorted OBB dims lie in the affordance's plausible size ranges."""
    return spec.largest[0] <= max(dims) <= spec.largest[1] and spec.smallest[0] <= min(dims) <= spec.smallest[1]


def _log_distance(spec: AffordanceSpec, dims: list[float]) -> float:
    centre = math.sqrt(spec.largest[0] * spec.largest[1])
    return abs(math.log(max(dims) / centre))


def offline_analysis(task: TaskDescription) -> AffordanceAnalysis:
    """Stage 1: size check against real-world ranges (alternative from the same kind), IBD and outline."""
    spec = lookup(task.affordance)
    dims = list(task.obb_dims)
    fits = dims_fit(spec, dims)
    sizes = f"largest {max(dims):.3f} m, smallest {min(dims):.3f} m"
    ranges = (f"a {spec.name} is {spec.largest[0]:g}–{spec.largest[1]:g} m at its largest and "
              f"{spec.smallest[0]:g}–{spec.smallest[1]:g} m at its smallest")
    alternative = None
    if fits:
        reason = f"The object ({sizes}) fits: {ranges}."
    else:
        fitting = [s for s in CATALOGUE.values() if s.kind == spec.kind and s.name != spec.name and dims_fit(s, dims)]
        if fitting:
            alternative = min(fitting, key=lambda s: (s.name not in PAPER_AFFORDANCES, _log_distance(s, dims))).name
        reason = (f"The object ({sizes}) does not fit: {ranges}. "
                  + (f"Its size fits a {alternative}." if alternative else "No similar affordance fits its size."))
    agent, interaction, outcome = _OUTLINES[spec.kind]
    return AffordanceAnalysis(
        affordance=task.affordance,
        fits=fits,
        reason=reason,
        alternative=alternative,
        ibd=spec.ibd,
        agent_description=agent,
        interaction_description=interaction,
        expected_outcome=outcome.format(name=spec.name),
    )


_OUTLINES: dict[str, tuple[str, str, str]] = {
    "container": (
        "Small spheres standing for droplets of liquid (or items bigger than the holes of a basket), "
        "sized to the object's opening, in a 3x3x3 grid.",
        "The grid of droplets is brought above the object's opening and released so the droplets fall in; "
        "alternatives release it above the rim offset to the front, back, left and right.",
        "Most droplets end inside the {name}'s bounding box, below its rim, not touching the ground, "
        "and the {name} stays upright.",
    ),
    "seat": (
        "One box standing for a sitting person's pelvis's contact patch, 0.2 x 0.2 x 0.1 m.",
        "The pelvis is lowered onto the object from above, or arrives from the front, back, left or right "
        "above seat height and is then lowered; it is released at the first contact.",
        "The pelvis rests upright on the {name} at seat height (0.3–0.65 m above the ground), not touching "
        "the ground, and the {name} does not tip over.",
    ),
    "lie": (
        "One box standing for a lying person's torso, about 0.5 x 0.35 x 0.15 m.",
        "The torso is lowered onto the object from above at its centre and at offsets; released at contact.",
        "The torso rests level on the {name} 0.15–0.9 m above the ground, not touching the ground, "
        "and the {name} does not tip over.",
    ),
    "surface": (
        "One flat box standing for a book or a dish placed on the object.",
        "The box is lowered onto the object from above at its centre and at offsets to each side; "
        "released at the first contact.",
        "The box rests level on top of the {name} 0.4–1.1 m above the ground, not touching the ground, "
        "and the {name} does not tip over.",
    ),
    "dish": (
        "One flat disc standing for a portion of food, sized to the object.",
        "The disc is lowered onto the object from above at its centre and at offsets; released at contact.",
        "The disc rests level on the {name}, touching it and not the ground, the {name} is low and does "
        "not tip over.",
    ),
    "storage": (
        "One small box standing for a stored item, sized to the object's depth.",
        "The box is pushed in horizontally from the front, back, left and right at mid height, and from "
        "the front higher and lower; released at the first contact or at the end.",
        "The box ends inside the {name}'s bounding box, resting on it, not on the ground, upright, "
        "and the {name} does not tip over.",
    ),
}


@dataclass(frozen=True)
class _AgentShape:
    geom: str  # MJCF geom attributes without mass
    radius: float  # bounding radius, m
    half_z: float  # half height, m
    mass: float  # kg
    label: str


def _shape(spec: AffordanceSpec, dims: list[float]) -> _AgentShape:
    """The agent of a kind, scaled to the object (dims sorted descending)."""
    d0, d1, d2 = dims
    if spec.kind == "container":
        r = max(spec.min_droplet_radius, min(spec.max_droplet_radius, spec.droplet_scale * d1))
        mass = 1000.0 * 4.0 / 3.0 * math.pi * r**3  # water
        # rolling friction lets droplets that miss come to rest instead of rolling on the ground forever
        return _AgentShape(f'type="sphere" size="{r:.4f}" condim="6" friction="1 0.005 0.0005"', r, r, mass,
                           "droplet")
    if spec.kind == "dish":
        a = min(0.12, max(0.02, 0.25 * d1))
        c = min(0.015, max(0.005, 0.1 * a))
        mass = 800.0 * math.pi * a * a * 2 * c
        return _AgentShape(f'type="cylinder" size="{a:.4f} {c:.4f}"', math.hypot(a, c), c, mass, "food")
    if spec.kind == "seat":
        # the contact patch of a sitting pelvis, 0.2 m across: fits the narrowest seat (0.3 m) and the gap between
        # armrests as the object's convex hulls render it (a 0.28 m box lands on the armrests of a dataset chair)
        half = (0.1, 0.1, 0.05)
        label = "pelvis"
    elif spec.kind == "lie":
        k = min(1.2, max(0.7, d0 / 2.0))
        half = (0.25 * k, 0.175 * k, 0.075)
        label = "torso"
    elif spec.kind == "surface":
        half = (min(0.15, max(0.04, 0.12 * d1)),) * 2 + (0.015,)
        label = "book"
    else:  # storage
        half = (min(0.1, 0.2 * d2),) * 3  # never taller than the object's thinnest side allows
        label = "item"
    mass = 1000.0 * 8.0 * half[0] * half[1] * half[2]
    size = " ".join(f"{v:.4f}" for v in half)
    return _AgentShape(f'type="box" size="{size}"', math.sqrt(sum(v * v for v in half)), half[2], mass, label)


def offline_agent(task: TaskDescription) -> AgentModel:
    """Stage 2: the kind's agent as an MJCF fragment (one body, no joints), scaled to the object."""
    spec = lookup(task.affordance)
    shape = _shape(spec, list(task.obb_dims))
    xml = (f'<mujoco><worldbody><body name="{shape.label}">'
           f'<geom name="{shape.label}_geom" {shape.geom} mass="{shape.mass:.6g}" rgba="0.2 0.5 0.9 1"/>'
           "</body></worldbody></mujoco>")
    return AgentModel(name=shape.label, description=_OUTLINES[spec.kind][0], mjcf=xml)


def offline_layout(task: TaskDescription) -> AgentLayout:
    """Stage 3: droplets in a 3×3×3 grid with a gap of 0.4 diameters; one agent otherwise."""
    spec = lookup(task.affordance)
    shape = _shape(spec, list(task.obb_dims))
    if spec.kind == "container":
        s = round(2.4 * shape.radius, 5)
        return AgentLayout(nx=3, ny=3, nz=3, sx=s, sy=s, sz=s, collide_agents=True)
    s = round(2.0 * shape.radius + 0.01, 5)
    return AgentLayout(nx=1, ny=1, nz=1, sx=s, sy=s, sz=s, collide_agents=False)


def _lowering_plans(label: str, what: str, offset: float) -> list[MotionPlan]:
    plans = [MotionPlan(name="above", description=f"Start with the {label} above the object's centre; lower it "
                                                  f"straight down onto {what}; release it at the first contact.")]
    plans += [
        MotionPlan(name=f"above_{side}", description=f"Start with the {label} above the object, offset to the {side} "
                                                      f"by {offset:g} of its half size; lower it straight down; "
                                                      "release it at the first contact.")
        for side, _, _ in SIDES
    ]
    return plans


def offline_plans(task: TaskDescription) -> MotionPlans:
    """Stage 4: five or six plans from above and from the four sides."""
    spec = lookup(task.affordance)
    label = _shape(spec, list(task.obb_dims)).label
    if spec.kind == "container":
        plans = [MotionPlan(name="above", description="Hold the droplet grid centred above the opening, just over "
                                                     "the rim; release it so the droplets fall in.")]
        plans += [MotionPlan(name=f"above_{side}", description=f"Hold the droplet grid above the rim, offset to the "
                                                               f"{side} by {_CONTAINER_OFFSET:g} of the half size (the opening "
                                                               "may be off the box centre); release it.")
                  for side, _, _ in SIDES]
        return MotionPlans(plans=plans)
    if spec.kind == "seat":
        plans = [MotionPlan(name="above", description="Start with the pelvis above the object's centre; lower it "
                                                     "straight down onto the seat; release at the first contact.")]
        plans += [MotionPlan(name=side, description=f"Start at the {side} of the object, above seat height; move "
                                                    "horizontally over the object's centre; lower the pelvis "
                                                    "straight down; release at the first contact.")
                  for side, _, _ in SIDES]
        return MotionPlans(plans=plans)
    if spec.kind == "storage":
        plans = [MotionPlan(name=side, description=f"Start at the {side} of the object at mid height; push the "
                                                   "item horizontally to the object's centre; release at the "
                                                   "first contact or at the end.")
                 for side, _, _ in SIDES]
        plans += [MotionPlan(name=f"front_{level}", description=f"Start at the front of the object at {level} height; "
                                                                "push the item horizontally to the centre; release at "
                                                                "the first contact or at the end.")
                  for level in ("high", "low")]
        return MotionPlans(plans=plans)
    what = {"lie": "the lying surface", "surface": "the top", "dish": "the dish"}[spec.kind]
    return MotionPlans(plans=_lowering_plans(label, what, _LOWER_OFFSET[spec.kind]))


#: Horizontal offset (units of h) of the above_<side> container plans: a handle shifts the box centre off the
#: cavity's axis by a fraction of the half size, so the grid must move by about that much, not onto the rim.
_CONTAINER_OFFSET = 0.3
#: Horizontal offset (units of h) of the above_<side> plans of lowering kinds.
_LOWER_OFFSET = {"lie": 0.3, "surface": 0.75, "dish": 0.4}
#: Height (units of h_z) of the side storage plans; off-centre so a middle board does not stop them all.
#: front_high / front_low run one agent size below the top / above the ground instead.
_STORAGE_MID_Z = 0.15


def _via(rel: tuple[float, float, float], off: tuple[float, float, float]) -> ViaPose:
    return ViaPose(rel=[float(v) for v in rel], offset_m=[round(float(v), 5) for v in off], quat=IDENTITY)


def offline_trajectories(task: TaskDescription, layout: AgentLayout) -> Trajectories:
    """Stage 5: via-poses of the layout centre for each plan of :func:`offline_plans`."""
    spec = lookup(task.affordance)
    shape = _shape(spec, list(task.obb_dims))
    spread_z = (layout.nz - 1) / 2.0 * layout.sz + shape.radius  # grid half height
    gap = max(0.01, 2.0 * shape.radius)
    trajs: list[PlanTrajectory] = []
    for plan in offline_plans(task).plans:
        if spec.kind == "container":
            ox, oy = _side_offset(plan.name, _CONTAINER_OFFSET)
            via = [_via((ox, oy, 1), (0, 0, spread_z + gap)), _via((ox, oy, 1), (0, 0, spread_z + 0.002))]
        elif spec.kind == "seat":
            above_seat = 0.65 + shape.radius + 0.05  # higher than any seat, pelvis included
            bottom = shape.half_z + 0.02
            if plan.name == "above":
                via = [_via((0, 0, 1), (0, 0, shape.radius + gap)), _via((0, 0, -1), (0, 0, bottom))]
            else:
                ux, uy = _side_offset(plan.name, 1.0)
                via = [_via((ux, uy, -1), (ux * (shape.radius + gap), uy * (shape.radius + gap), above_seat)),
                       _via((0, 0, -1), (0, 0, above_seat)),
                       _via((0, 0, -1), (0, 0, bottom))]
        elif spec.kind == "storage":
            ux, uy = _side_offset(plan.name, 1.0)
            rz, dz = {"front_high": (1.0, -shape.radius - 0.01), "front_low": (-1.0, shape.radius + 0.01)}.get(
                plan.name, (_STORAGE_MID_Z, 0.0))
            out = shape.radius + gap
            via = [_via((ux, uy, rz), (ux * out, uy * out, dz)), _via((0, 0, rz), (0, 0, dz))]
        else:
            ox, oy = _side_offset(plan.name, _LOWER_OFFSET[spec.kind])
            via = [_via((ox, oy, 1), (0, 0, shape.radius + gap)), _via((ox, oy, -1), (0, 0, shape.half_z + 0.005))]
        trajs.append(PlanTrajectory(plan=plan.name, via_poses=via))
    return Trajectories(trajectories=trajs)


def _side_offset(plan: str, amount: float) -> tuple[float, float]:
    for side, ux, uy in SIDES:
        if plan == side or plan == f"above_{side}" or plan.startswith(f"{side}_"):
            return amount * ux, amount * uy
    return 0.0, 0.0


_HEADER = ("def score(agent_pos, agent_quat, agent_vel, contacts_object, contacts_agents, contacts_ground, "
           "object_pos, object_tilt, object_half_extents):\n")

#: Half height (m) of the resting agents of seat, lie and surface kinds (see :func:`_shape`).
_AGENT_HALF_Z = {"seat": 0.05, "lie": 0.075, "surface": 0.015}


def _envelope(spec: AffordanceSpec) -> list[tuple[str, str, tuple[float, float]]]:
    """(name, numpy expression over ``e`` = pose half extents (n, 3), range) of the pose-dependent size checks."""
    terms = [("height", "2.0 * e[:, 2]", spec.height),
             ("width", "2.0 * np.minimum(e[:, 0], e[:, 1])", spec.width),
             ("length", "2.0 * np.maximum(e[:, 0], e[:, 1])", spec.length),
             ("height/width", "e[:, 2] / np.maximum(np.minimum(e[:, 0], e[:, 1]), 1e-9)", spec.aspect)]
    return [t for t in terms if t[2] != (0.0, INF)]


def _envelope_source(spec: AffordanceSpec) -> str:
    conds = []
    for _, expr, (lo, hi) in _envelope(spec):
        if lo > 0.0:
            conds.append(f"({expr} >= {lo:g})")
        if hi < INF:
            conds.append(f"({expr} <= {hi:g})")
    return "".join(f" & {c}" for c in conds)


def _envelope_ok(spec: AffordanceSpec, half: list[float]) -> tuple[bool, str]:
    hx, hy, hz = half
    values = {"height": 2 * hz, "width": 2 * min(hx, hy), "length": 2 * max(hx, hy),
              "height/width": hz / max(min(hx, hy), 1e-9)}
    for name, _, (lo, hi) in _envelope(spec):
        if not lo <= values[name] <= hi:
            return False, f"in this pose its {name} is {values[name]:.3f}; a {spec.name} has {lo:g}-{hi:g}"
    return True, ""


_CONTAINER_BODY = '''    """Fraction of droplets inside the box below the rim and off the ground, minus {min_frac}; -1 if tipped,
    if a droplet leaked through to the ground under the object, or if the pose is outside the {name} size
    envelope ({envelope})."""
    e = object_half_extents
    h = e[:, None, :]
    inside = (np.abs(agent_pos[:, :, 0]) < h[:, :, 0]) & (np.abs(agent_pos[:, :, 1]) < h[:, :, 1])
    inside = inside & (agent_pos[:, :, 2] < h[:, :, 2]) & (contacts_ground == 0)
    frac = np.mean(inside, axis=1)
    # a droplet on the ground under the middle of the object came through it: the container leaks
    rel = agent_pos - object_pos[:, None, :]  # the object may have slid under the droplets' impacts
    under = (rel[:, :, 0] / h[:, :, 0]) ** 2 + (rel[:, :, 1] / h[:, :, 1]) ** 2 < 0.25
    leaked = np.any(under & (contacts_ground > 0), axis=1)
    ok = (object_tilt < {max_tilt:.4f}) & ~leaked{object_cond}
    return np.where(ok, frac - {min_frac}, -1.0)
'''

_REST_BODY = '''    """Fraction of agents resting as intended ({what}), minus 0.5; -1 if the object tipped
    or the pose is outside the {name} size envelope ({envelope})."""
    e = object_half_extents
    h = e[:, None, :]
    footprint = (np.abs(agent_pos[:, :, 0]) < h[:, :, 0]) & (np.abs(agent_pos[:, :, 1]) < h[:, :, 1])
    bottom = agent_pos[:, :, 2] - {half_z:.4f}
    height = (bottom > {lo}) & (bottom < {hi})
    cos_tilt = 1.0 - 2.0 * (agent_quat[:, :, 1] ** 2 + agent_quat[:, :, 2] ** 2)
    upright = cos_tilt > {cos_agent:.4f}
    resting = footprint & height & upright & (contacts_object > 0) & (contacts_ground == 0)
    frac = np.mean(resting, axis=1)
    ok = (object_tilt < {max_tilt:.4f}){object_cond}
    return np.where(ok, frac - 0.5, -1.0)
'''


def _envelope_doc(spec: AffordanceSpec) -> str:
    parts = [f"{name} {lo:g}-{hi:g}" for name, _, (lo, hi) in _envelope(spec)]
    return ", ".join(parts) if parts else "any size"


def offline_scoring(task: TaskDescription) -> ScoringCode:
    """Stage 6: vectorised numpy scoring source for the kind (constants and size envelope baked in)."""
    spec = lookup(task.affordance)
    shape = _shape(spec, list(task.obb_dims))
    object_cond = _envelope_source(spec)
    envelope = _envelope_doc(spec)
    if spec.kind == "container":
        body = _CONTAINER_BODY.format(min_frac=0.5, max_tilt=math.radians(15), name=spec.name, envelope=envelope,
                                      object_cond=object_cond)
        return ScoringCode(description="Success when more than half the droplets rest inside the object's box "
                                       "below the rim and off the ground, none leaks through to the ground under "
                                       f"the object, the object is upright and its pose has "
                                       f"the size of a {spec.name} ({envelope}).",
                           source=_HEADER + body)
    # bottom-height window of the agent, as task-frame z expressions (hz broadcast over agents)
    rest = f"at {spec.rest[0]:g}-{spec.rest[1]:g} m above the ground"
    windows = {
        "seat": (f"-h[:, :, 2] + {spec.rest[0]:g}", f"-h[:, :, 2] + {spec.rest[1]:g}", 15, 15, f"upright {rest}"),
        "lie": (f"-h[:, :, 2] + {spec.rest[0]:g}", f"-h[:, :, 2] + {spec.rest[1]:g}", 15, 15, f"level {rest}"),
        "surface": (f"np.maximum(-h[:, :, 2] + {spec.rest[0]:g}, 0.0)", f"-h[:, :, 2] + {spec.rest[1]:g}", 10, 10,
                    f"level on top {rest}"),
        "dish": ("-h[:, :, 2] - 0.005", "h[:, :, 2] + 0.01", 15, 15, "level on the dish"),
        "storage": ("-h[:, :, 2]", "h[:, :, 2] - " + f"{2 * shape.half_z:.4f}", 20, 10, "inside, on a board"),
    }
    lo, hi, agent_deg, object_deg, what = windows[spec.kind]
    body = _REST_BODY.format(what=what, name=spec.name, envelope=envelope, half_z=shape.half_z, lo=lo, hi=hi,
                             cos_agent=math.cos(math.radians(agent_deg)), max_tilt=math.radians(object_deg),
                             object_cond=object_cond)
    return ScoringCode(description=f"Success when the {shape.label} rests {what}, touching the object and not "
                                   f"the ground, the object does not tip and its pose has the size of a "
                                   f"{spec.name} ({envelope}).",
                       source=_HEADER + body)


def _candidate_ok(spec: AffordanceSpec | None, c: CandidateInteraction, h: list[float]) -> tuple[bool, str]:
    """Common-sense rules of the offline Functional Pose Analyzer for one candidate."""
    kind = spec.kind if spec is not None else None
    if spec is not None:
        fits, why = _envelope_ok(spec, h)
        if not fits:
            return False, why
    s = c.summary
    hx, hy, hz = h
    start = c.via_poses[0]
    ground_height = (s.mean_height + 1.0) * hz  # of the agent centres
    if s.object_tilt_deg >= 15:
        return False, f"success relies on the object tipping ({s.object_tilt_deg:.0f} deg)"
    if kind == "container":
        if start[2] < hz:
            return False, "the droplets did not come from above the opening"
        if s.frac_inside_bbox < 0.5 or s.mean_height >= 1.0 or s.frac_on_ground > 0.2:
            return False, (f"only {s.frac_inside_bbox:.0%} of droplets rest inside below the rim "
                           f"({s.frac_on_ground:.0%} on the ground)")
        return True, f"{s.frac_inside_bbox:.0%} of droplets from above rest inside below the rim"
    if kind in ("seat", "lie", "surface", "dish"):
        max_tilt = 10 if kind == "surface" else 15
        rest = (-INF, INF) if spec is None or kind == "dish" else spec.rest
        lo, hi = rest[0] + _AGENT_HALF_Z.get(kind, 0.0), rest[1] + _AGENT_HALF_Z.get(kind, 0.0)
        if s.agent_tilt_deg >= max_tilt:
            return False, f"the agent is tilted {s.agent_tilt_deg:.0f} deg"
        if not lo <= ground_height <= hi:
            return False, f"the agent's centre rests {ground_height:.2f} m above the ground; plausible: {lo:g}-{hi:g} m"
        if s.frac_touching_object < 1.0 or s.frac_on_ground > 0.0:
            return False, "the agent does not rest on the object alone"
        # on a table the item belongs on top; on a plate, food resting low inside the rim is the point
        if kind == "surface" and s.mean_height < 0.0:
            return False, "the agent rests in the lower half of the object, not on top"
        return True, f"the agent rests level on the object {ground_height:.2f} m above the ground"
    if kind == "storage":
        if abs(start[2]) >= hz or (abs(start[0]) <= hx and abs(start[1]) <= hy):
            return False, "the item did not come in horizontally from a side"
        if s.frac_inside_bbox < 0.5 or s.frac_touching_object < 1.0 or s.frac_on_ground > 0.0:
            return False, "the item does not rest inside on the object"
        return True, "the item pushed in from the side rests inside on the object"
    if s.frac_on_ground >= 0.5:
        return False, "most agents ended on the ground"
    return True, "the object stayed upright and the agents did not end on the ground"


#: Surface kinds: how many of the five lowering plans must succeed — a top at least half a metre across holds
#: the box placed off centre too, a small pedestal foot or a stretcher only at one place.
_SURFACE_MIN_PLANS = 4


def _pose_rules(
    spec: AffordanceSpec | None, accepted: list[CandidateInteraction], tried: list[CandidateInteraction]
) -> tuple[list[CandidateInteraction], str]:
    """Rules over a pose's accepted candidates together, with every plan ``tried`` in it as evidence:
    (candidates still accepted, why the pose is rejected)."""
    if spec is None or not accepted:
        return accepted, ""
    # only the centre pour is evidence: droplets spilt past a cup's handle also end on the ground beneath its box
    if spec.kind == "container" and any(c.plan == "above" and c.summary.frac_through_object > 0 for c in tried):
        return [], (f"droplets poured at the centre came through the object to the ground beneath it; "
                    f"a {spec.name} that leaks does not hold")
    if spec.kind == "surface" and len(accepted) < _SURFACE_MIN_PLANS:
        return [], (f"only {len(accepted)} of the placements hold the box; a {spec.name} top holds it at the centre "
                    f"and off centre ({_SURFACE_MIN_PLANS} needed)")
    if spec.kind == "dish" and all(c.plan != "above" for c in accepted):
        return [], f"the food placed at the centre does not stay; a {spec.name} has a solid centre"
    return accepted, ""


def offline_functional_poses(request: FunctionalPoseRequest) -> FunctionalPoseVerdict:
    """Stage 7 by rules: accept a pose when one of its candidates passes its kind's rules; best = the pose
    accepted with the most plans, then the top score, then the most probable.

    Affordances outside the catalogue get the generic rules (object not tipped,
    agents not mostly on the ground).
    """
    try:
        spec: AffordanceSpec | None = lookup(request.affordance)
    except UnknownAffordanceError:
        spec = None
    verdicts: list[PoseVerdict] = []
    # best = (held by a rim, accepted plans, top score, probability, pose, plan): the pose that works from the
    # most approaches; for dishes first the one whose rim rises around the food (an upturned plate's flat
    # bottom also holds a disc, but nothing keeps it there)
    best: tuple[int, int, float, float, int, str] | None = None
    dish = spec is not None and spec.kind == "dish"
    for pose in request.poses:
        accepted: list[CandidateInteraction] = []
        reasons: list[str] = []
        for c in pose.candidates:
            ok, why = _candidate_ok(spec, c, list(pose.half_extents))
            reasons.append(f"{c.plan}: {why}")
            if ok:
                accepted.append(c)
        if not pose.candidates:
            reasons.append("no plan succeeded")
        accepted, why_not = _pose_rules(spec, accepted, pose.candidates + pose.failed)
        if why_not:
            reasons.append(why_not)
        top = max(accepted, key=lambda c: c.score) if accepted else None
        verdicts.append(PoseVerdict(pose_index=pose.pose_index, accept=top is not None, reason="; ".join(reasons),
                                    plan=top.plan if top else None))
        held = sum(c.summary.mean_height < 1.0 for c in accepted) if dish else 0
        key = (held, len(accepted), top.score if top else 0.0, pose.probability)
        if top is not None and (best is None or key > best[:4]):
            best = (*key, pose.pose_index, top.plan)
    if best is None:
        return FunctionalPoseVerdict(poses=verdicts, best_pose=None, best_plan=None,
                                     reason="no candidate interaction is consistent with common sense")
    return FunctionalPoseVerdict(poses=verdicts, best_pose=best[4], best_plan=best[5],
                                 reason=f"pose {best[4]} works with the most plans ({best[1]}); plan {best[5]!r} "
                                        f"has its best accepted score ({best[2]:.3f})")
