"""The Kind protocol and the kinds' registry: the physics one kind of affordance is imagined with.

A kind answers the offline provider's stages for an affordance of its kind:
the agent (stage 2) and its layout (3), the plans (4) and their via-poses (5),
the scoring source (6), and the Functional Pose Analyzer's rules (7) for one
candidate and for a pose's candidates together. Everything scales with the
object's OBB dims. Directions (task frame): front = +x, back = −x, left = +y,
right = −y. Via-poses are ``rel * h + offset_m`` (see :mod:`rail_mj.core.profile`).

A kind is a plugin: a :class:`Kind` subclass decorated with :func:`register_kind`
joins :data:`KINDS` and its parameter model (``params_model``, the fields its rows
alone have) becomes the one its rows' ``params`` must be (docs/new_affordance.md).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, Literal, TypeVar

from rail_mj.affordances.row import KIND_PARAMS, Affordance, KindParams
from rail_mj.core.errors import ConfigError
from rail_mj.core.profile import AgentLayout, CandidateInteraction, MotionPlan, PoseCandidates, ScoringCode, ViaPose
from rail_mj.mjcf.body import BodySize

__all__ = [
    "SIDES",
    "SCORING_HEADER",
    "MAX_OBJECT_TILT_DEG",
    "LEVEL_DEG",
    "NEAR_AXIS_DEG",
    "MOST",
    "GAP",
    "WATER_DENSITY",
    "AgentShape",
    "Kind",
    "KINDS",
    "register_kind",
    "kind_of",
    "box_agent",
    "via",
    "side_offset",
    "clearance",
    "tipping",
    "judge_unregistered",
    "rest_words",
    "rest_bounds",
    "rest_window",
    "rest_scoring",
    "rest_accept",
]

IDENTITY = [1.0, 0.0, 0.0, 0.0]
#: Directions of the side plans, (name, unit x, unit y).
SIDES = (("front", 1.0, 0.0), ("back", -1.0, 0.0), ("left", 0.0, 1.0), ("right", 0.0, -1.0))
#: A success with the object tilted this much (deg) or more relied on it tipping over: a table top, a seat or a
#: vessel used as made stands within a few degrees of level, and 15 deg is past any floor's or scan's slope.
MAX_OBJECT_TILT_DEG = 15
#: An agent resting tilted less than this (deg) rests level: an item on a surface tilted more slides off at the
#: friction of wood or china (coefficient 0.27 = tan 15 deg).
LEVEL_DEG = 15
#: A long part is near an axis within a third of a right angle of it (deg): a sitter's thigh near level (steeper,
#: it slides off the seat), a flower stem near upright (leaning more, it lies across the vessel's mouth).
NEAR_AXIS_DEG = 30
#: "Most" of the agents, by definition: more than half.
MOST = 0.5
#: Gap (m) that keeps an agent clear of the object at a plan's start or between agents: 1 cm, above a scan's or
#: a decomposition's noise.
GAP = 0.01
#: Density of water (kg/m^3): the agents' (a droplet is water, food and stored items about as dense).
WATER_DENSITY = 1000.0

SCORING_HEADER = ("def score(agent_pos, agent_quat, agent_vel, contacts_object, contacts_agents, contacts_ground, "
                  "object_pos, object_tilt, object_half_extents):\n")


@dataclass(frozen=True)
class AgentShape:
    """A kind's agent scaled to one object."""

    geom: str  # MJCF geom attributes without mass
    radius: float  # bounding radius, m
    half_z: float  # half height, m
    mass: float  # kg
    label: str
    #: the whole agent MJCF fragment when it is more than one geom (an articulated body); None: one ``geom``
    fragment: str | None = None
    body: BodySize | None = None  # the articulated body's dimensions, when it is one
    count: int = 1  # agents side by side (bodies on a bench)


class Kind(ABC):
    """One kind of imagined physics. Instances hold no state; :data:`KINDS` has one of each registered kind."""

    name: ClassVar[str]
    #: The kind's own parameters of a row (Affordance.params); KindParams itself for a kind without any.
    params_model: ClassVar[type[KindParams]] = KindParams
    #: Stage 1's outline of the imagination; ``expected_outcome`` takes ``{name}``, the affordance's name.
    agent_description: ClassVar[str]
    interaction_description: ClassVar[str]
    expected_outcome: ClassVar[str]
    #: The use rests in the object's concavities (a cavity, a well, a compartment), whose hulls the decomposition's
    #: concavity threshold shapes: the perturbed worlds include the object's second decomposition. A kind whose
    #: agent rests on the object's top (a seat, a table) meets the same convex top in any decomposition.
    decomposition_matters: ClassVar[bool] = False
    #: The kind's rules read its agent's own size (a body's toe reach, its hips' height over a seat): a perturbed
    #: world whose agent is ``agent_size`` times the size is judged by the row scaled for that agent
    #: (:meth:`Affordance.scaled`), as a doll's chair is judged for a doll.
    rules_read_agent_size: ClassVar[bool] = False
    #: An owner's body sets the size of the kind's objects (what a figure or an animal lies or sits on: "the dog
    #: bed"); a bowl is sized by its food and a basket by what it carries, so "dog bowl" is refused unless a row
    #: names it.
    sized_by_owner_body: ClassVar[bool] = False

    @abstractmethod
    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        """The agent scaled to the object (OBB dims sorted descending)."""

    def layout(self, shape: AgentShape) -> AgentLayout:
        """One agent; kinds whose agents come in a grid override this."""
        s = round(2.0 * shape.radius + GAP, 5)
        return AgentLayout(nx=1, ny=1, nz=1, sx=s, sy=s, sz=s, collide_agents=False)

    @abstractmethod
    def plans(self, shape: AgentShape) -> list[MotionPlan]:
        """Five or more plans in language, with distinct names."""

    @abstractmethod
    def via_poses(self, plan: str, shape: AgentShape, layout: AgentLayout) -> list[ViaPose]:
        """The via-poses of the layout centre for one of :meth:`plans`."""

    @abstractmethod
    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        """Vectorised numpy scoring source of the physics alone, its constants baked in (the pose envelope is a
        prior, :meth:`Affordance.pose_prior`, never a mask)."""

    def judge(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float],
              rim: float | None = None) -> tuple[bool, str]:
        """Whether one candidate of a pose with half extents ``h`` (and spill level ``rim``, m, when it has a
        basin) is consistent with common sense, and why: the physics alone; the pose's sizes are its prior."""
        why = tipping(c)
        if why:
            return False, why
        return self.accept(aff, c, h)

    @abstractmethod
    def accept(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> tuple[bool, str]:
        """The kind's own rules for a candidate whose object did not tip."""

    def accept_pose(
        self, aff: Affordance, accepted: list[CandidateInteraction], pose: PoseCandidates
    ) -> tuple[list[CandidateInteraction], str]:
        """Rules over a pose's accepted candidates (never empty) together, with the pose (its every plan tried,
        its basin) as evidence: (candidates still accepted, why the pose is rejected or "")."""
        return accepted, ""

    def evidence_plans(self, aff: Affordance, plans: Sequence[str]) -> set[str]:
        """Of ``plans``, those whose rollouts :meth:`accept_pose` reads whatever they scored (a leak, a probe of the
        room under a top): the perturbed worlds imagine them again even where they failed in the nominal world,
        where a plan that failed otherwise counts as failed in each world (:func:`rail_mj.pipeline.verdicts.
        candidate_plans`). None unless a kind's pose rules read such a plan."""
        return set()

    def rest_height(self, aff: Affordance, c: CandidateInteraction, h: Sequence[float]) -> float | None:
        """The height (m) above the ground at which an accepted candidate's agent came to rest, for a row whose
        envelope has a ``rest`` window (its :meth:`Affordance.rest_prior` weighs it); None for a kind that measures
        none."""
        return None

    def rank(self, aff: Affordance, accepted: list[CandidateInteraction], h: Sequence[float]) -> int:
        """First key in choosing the best pose (half extents ``h``), before the number of accepted plans; 0 unless
        a kind cares."""
        return 0

    def tie_rank(self, aff: Affordance, accepted: list[CandidateInteraction], h: Sequence[float]) -> int:
        """Key in choosing the best pose after the number of accepted plans, before the top score; 0 unless a kind
        cares."""
        return 0


#: Every registered kind by name, one instance each (:func:`register_kind` fills it).
KINDS: dict[str, Kind] = {}

_KindT = TypeVar("_KindT", bound=Kind)


def register_kind(cls: type[_KindT]) -> type[_KindT]:
    """Class decorator: register a concrete kind under its ``name`` (one instance in :data:`KINDS`) and its
    ``params_model`` as the model its rows' params must be. A name registered twice is a ConfigError."""
    if cls.name in KINDS:
        raise ConfigError(f"kind {cls.name!r} is already registered ({type(KINDS[cls.name]).__qualname__})")
    KINDS[cls.name] = cls()
    KIND_PARAMS[cls.name] = cls.params_model
    return cls


def kind_of(aff: Affordance) -> Kind:
    """The kind that imagines a registry row."""
    return KINDS[aff.kind]


def box_agent(label: str, half: Sequence[float]) -> AgentShape:
    """A box agent of the density of water."""
    mass = WATER_DENSITY * math.prod(2.0 * v for v in half)
    size = " ".join(f"{v:.4f}" for v in half)
    return AgentShape(f'type="box" size="{size}"', math.sqrt(sum(v * v for v in half)), half[2], mass, label)


def via(rel: tuple[float, float, float], off: tuple[float, float, float],
        anchor: Literal["box", "opening"] = "box") -> ViaPose:
    return ViaPose(rel=[float(v) for v in rel], offset_m=[round(float(v), 5) for v in off], quat=IDENTITY,
                   anchor=anchor)


def side_offset(plan: str, amount: float) -> tuple[float, float]:
    """Horizontal offset ``amount`` towards the side a plan name says (``front``, ``above_left``, ``front_high``)."""
    for side, ux, uy in SIDES:
        if plan == side or plan == f"above_{side}" or plan.startswith(f"{side}_"):
            return amount * ux, amount * uy
    return 0.0, 0.0


def clearance(shape: AgentShape) -> float:
    """Gap (m) between the agent and the object's box at the start of a plan."""
    return max(GAP, 2.0 * shape.radius)


def tipping(c: CandidateInteraction) -> str:
    """Why a candidate's success relied on the object tipping over; "" when it did not."""
    tilt = c.summary.object_tilt_deg
    return f"success relies on the object tipping ({tilt:.0f} deg)" if tilt >= MAX_OBJECT_TILT_DEG else ""


def judge_unregistered(c: CandidateInteraction) -> tuple[bool, str]:
    """Stage 7's rules for an affordance outside the registry: the object did not tip, and the agents did not end
    mostly on the ground away from it. Agents on the ground that touch the object were held by it (books leaning
    on a bookend, feet under a desk): the object made their place; agents on the ground that do not touch it came
    to rest as they would without it (droplets spilled beside a cup)."""
    why = tipping(c)
    if why:
        return False, why
    s = c.summary
    if s.frac_on_ground >= MOST and s.frac_touching_object < MOST:
        return False, "most agents ended on the ground, away from the object"
    return True, "the object stayed upright and the agents rest on it or against it, not on the ground away from it"


def rest_words(aff: Affordance) -> str:
    """The rest heights of the agent's bottom the rules let through, and the typical ones, in words."""
    lo, hi = aff.rest_limits()
    return f"at {lo:.2f}-{hi:.2f} m above the ground (typically {aff.envelope.rest[0]:g}-{aff.envelope.rest[1]:g} m)"


def rest_bounds(aff: Affordance) -> tuple[str, str]:
    """The rest heights of the agent's bottom the rules let through (:meth:`Affordance.rest_limits`: the typical
    window is a prior) as task-frame z expressions (``h`` broadcast over agents)."""
    lo, hi = aff.rest_limits()
    return f"-h[:, :, 2] + {lo:g}", f"-h[:, :, 2] + {hi:g}"


def rest_window(aff: Affordance, agent_half_z: float) -> tuple[float, float]:
    """The rest heights of the agent's centre above the ground (m) the rules let through, for an agent of half
    height ``agent_half_z``: what the analyzer checks, as :func:`rest_bounds` is what the scoring checks."""
    lo, hi = aff.rest_limits()
    return lo + agent_half_z, hi + agent_half_z


_REST_BODY = '''    """Fraction of agents resting as intended ({what}), minus {most}; -1 if the object tipped."""
    e = object_half_extents
    h = e[:, None, :]
    footprint = (np.abs(agent_pos[:, :, 0]) < h[:, :, 0]) & (np.abs(agent_pos[:, :, 1]) < h[:, :, 1])
    bottom = agent_pos[:, :, 2] - {half_z:.4f}
    height = (bottom > {lo}) & (bottom < {hi})
    cos_tilt = 1.0 - 2.0 * (agent_quat[:, :, 1] ** 2 + agent_quat[:, :, 2] ** 2)
    upright = cos_tilt > {cos_agent:.4f}
    resting = footprint & height & upright & (contacts_object > 0){ground_cond}
    frac = np.mean(resting, axis=1)
    return np.where(object_tilt < {max_tilt:.4f}, frac - {most}, -1.0)
'''


def rest_scoring(aff: Affordance, shape: AgentShape, lo: str, hi: str, agent_deg: float, object_deg: float,
                 what: str, ground: bool = True) -> ScoringCode:
    """Scoring of one agent that must come to rest on the object: its bottom between the task-frame z
    expressions ``lo`` and ``hi`` (``h`` broadcast over agents), tilted less than ``agent_deg``, the object less
    than ``object_deg``; ``what`` says where in words. ``ground``: an agent touching the ground fails (False for a
    body whose feet may stand on the floor: its rules say which segments may touch it)."""
    body = _REST_BODY.format(what=what, half_z=shape.half_z, lo=lo, hi=hi, most=MOST,
                             cos_agent=math.cos(math.radians(agent_deg)), max_tilt=math.radians(object_deg),
                             ground_cond=" & (contacts_ground == 0)" if ground else "")
    ground_words = " and not the ground" if ground else ""
    return ScoringCode(description=f"Success when the {shape.label} rests {what}, touching the object{ground_words}, "
                                   "and the object does not tip.",
                       source=SCORING_HEADER + body)


def rest_accept(c: CandidateInteraction, h: Sequence[float], window: tuple[float, float],
                max_agent_tilt: float) -> tuple[bool, str]:
    """One agent resting level on the object alone, its centre ``window`` (m) above the ground."""
    s = c.summary
    ground_height = (s.mean_height + 1.0) * h[2]  # of the agent centres
    lo, hi = window
    if s.agent_tilt_deg >= max_agent_tilt:
        return False, f"the agent is tilted {s.agent_tilt_deg:.0f} deg"
    if not lo <= ground_height <= hi:
        return False, f"the agent's centre rests {ground_height:.2f} m above the ground; plausible: {lo:g}-{hi:g} m"
    if s.frac_touching_object < 1.0 or s.frac_on_ground > 0.0:
        return False, "the agent does not rest on the object alone"
    return True, f"the agent rests level on the object {ground_height:.2f} m above the ground"
