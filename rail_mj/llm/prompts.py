"""Versioned prompt templates of the stages (0, the affordance definer, and the paper's seven), with few-shot
examples from the offline library.

Bump a stage's ``PROMPT_VERSION`` whenever its template or examples change:
the version is part of the response-cache key.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass
from functools import cache

from pydantic import BaseModel

import rail_mj.llm.offline as offline
from rail_mj.affordances import REGISTRY
from rail_mj.affordances.envelope import QUANTITIES
from rail_mj.affordances.files import _toml_value, row_toml
from rail_mj.affordances.kinds import KINDS
from rail_mj.affordances.prototypes import SHAPES, Prototype, extents
from rail_mj.affordances.sizes import UseSizes
from rail_mj.core.profile import CandidateInteraction, PoseCandidates, PoseShape, ResultSummary, SegmentState
from rail_mj.core.results import BasinInfo
from rail_mj.core.types import SCORING_ARGS
from rail_mj.llm.schemas import (
    AffordanceAnalysis,
    AffordanceDefinition,
    AgentLayout,
    AgentModel,
    AgentModelRequest,
    AnalyzerRequest,
    DefinitionRequest,
    FunctionalPoseRequest,
    FunctionalPoseVerdict,
    LayoutRequest,
    MotionPlans,
    PlannerRequest,
    Request,
    RequestText,
    ScoringCode,
    ScoringRequest,
    TaskDescription,
    Trajectories,
    TrajectoryRequest,
)

__all__ = ["StageSpec", "PROMPT_VERSION", "STAGES", "system_prompt", "user_prompt", "repair_prompt"]

PROMPT_VERSION: dict[str, str] = {
    # 2: the prototypes the row is proven on; 3: the bowl example's row states its length (a handle's)
    "affordance_definition": "3",
    # 2: the task carries the request's agent scale (its examples show it); 3: the prior's format, the alternative
    # and the resting face defined; 4: a task of no obb_dims (one profile per use) gives sizes and prototypes
    "affordance_analyzer": "4",
    # 3 (all stages 2-6): the task of no obb_dims and its example; the agent's size and mass bounds stated
    "agent_model": "3",
    "agent_configuration": "3",
    # 4 (stage 4): at most sixteen plans in its answer's schema (a seat's hips at three places along each heading)
    "motion_planner": "4",
    # 3: a via-pose may be anchored at the pose's opening; 4: the start check's cube stated; 5: the boxes checked
    # for a task of no obb_dims
    "trajectory": "5",
    # 3: the synthetic batch and the proof on prototypes stated
    "scoring": "3",
    # 3: the poses carry their basin's length; 5: each pose's shape, the object's as it came, the drop frequency;
    # 6: every field of the request named with its meaning; 7: pictures of the poses, as_it_came null for an object
    # that came in an arbitrary orientation; 8: a torso's reaches_object (reclining onto a back) in the glossary;
    # 9: a foot's reaches_object counts the floor its knee bends down to
    "functional_pose": "9",
    # 2: the owner the object's name gives (a doll's chair)
    "request_parser": "2",
}


@dataclass(frozen=True)
class StageSpec:
    """A stage's name, prompt version, answer type and instructions."""

    name: str
    output_type: type[BaseModel]
    instructions: str

    @property
    def version(self) -> str:
        return PROMPT_VERSION[self.name]


def _kinds() -> str:
    """Each registered kind: the physics it tests (its module's first paragraph) and its row's params."""
    lines = []
    for name, kind in sorted(KINDS.items()):
        paragraphs = (sys.modules[type(kind).__module__].__doc__ or "").strip().split("\n\n")
        test = " ".join(p for p in paragraphs[:2] if p is paragraphs[0] or p.startswith("Success"))
        test = re.sub(r":\w+:`~?([^`]+)`", r"\1", " ".join(test.replace(f"``{name}``:", "").split())).replace("``", "")
        docs: dict[str, str] = getattr(kind.params_model, "DOCS", {})
        params = "; ".join(f"{key}: {doc} (default {_toml_value(_default(kind.params_model, key))})"
                           for key, doc in docs.items())
        lines.append(f"- {name}: {test} Params: {params or 'none'}.")
    return "\n".join(lines)


def _glossary() -> str:
    """Every field of stage 7's request a model must read, by name, with its meaning (the request carries values
    only)."""
    models = (FunctionalPoseRequest, PoseCandidates, PoseShape, BasinInfo, CandidateInteraction, ResultSummary,
              SegmentState)
    lines = []
    for model in models:
        fields = "; ".join(f"{name}: {field.description}" for name, field in model.model_fields.items()
                           if field.description)
        lines.append(f"- {model.__name__}: {fields}.")
    return "\n".join(lines)


def _default(model: type, key: str) -> object:
    """The default of a params model's (dotted) field."""
    value: object = model()
    for part in key.split("."):
        value = getattr(value, part)
    return value


_PROTOTYPE_SHAPES = f"""Each is one of: {", ".join(SHAPES)}, with length, width, height and wall in metres, \
built upright with its base on the floor: open_box / open_cylinder are shells open at the top whose walls \
and floor are "wall" thick (a cylinder's diameter is length, its width 0); closed_box / closed_cylinder / slab are \
solid; seat_on_legs is a top length x width, wall thick, whose upper face is height above the floor, on four corner \
legs; rod is a bar length long and width across lying along x (height 0); sphere is a ball length across (width \
and height 0)."""


def _definition_instructions() -> str:
    return f"""You are the Affordance Definer of a robot that imagines how an unseen object could be used. The \
requested use is not in the robot's registry. The robot has these kinds of physics, each tested on many real \
objects; a use that one of them models is imagined with it, which is far more reliable than new code:
{_kinds()}
Answer "kind": the kind whose test is this use's test (the same agent, the same success), or null when none is. \
With a kind, "row_toml" is the use as ONE [[affordance]] table of an affordance file (TOML), which must pass every \
check below; with null, row_toml is null, size_basis is [] and "reason" says what the use needs that no kind tests.
Checks on row_toml: it parses as TOML with one [[affordance]] table and nothing else; keys only name, aliases, \
kind, ibd, largest, smallest, scale, envelope, params; name is the requested name exactly (lower case, words \
separated by one space); aliases (optional) are other names of the same use, none of them a registered name; kind \
equals the answer's kind; ibd is the interaction-based definition, non-empty, with the typical sizes in words; \
largest / smallest (optional) are [lo, hi] in metres with 0 < lo <= hi, the typical range of the object's \
largest / smallest OBB dim; scale (optional, default 1) is the agent's size against a person's (a doll 0.18, a dog \
0.5) and must be > 0; [affordance.envelope] (optional) holds ranges [lo, hi] with 0 <= lo <= hi (hi may be inf) \
for the object's box in the pose of use: height, width (the smaller horizontal extent), length (the larger), \
aspect (height / width) and rest (where the agent's bottom comes to rest above the floor: seat and lie kinds), and \
widths = {{quantity = w}} for a range whose spread differs from the default, with quantity one of \
{", ".join(QUANTITIES)} and 0.01 <= w <= 10 (a fraction of the bound); [affordance.params] holds only the \
kind's params listed above (numbers >= 0, true / false), nested tables for nested ones; no override key. Sizes are \
priors, not vetoes: give the range real objects of the use have, for the person (or the scale's agent) using it. \
size_basis gives one line per range: the real objects measured and where the numbers come from (a standard, \
catalogue ranges, anthropometry).
Prototypes prove the row before it judges any object: give at least one "positive" (an obvious object of the use, \
its sizes inside the row's typical ranges: a prior of at least 0.5, checked) and one "negative", a near miss the \
use must refuse (the same shell closed or turned into a slab, a box too small, too shallow or too tall). \
{_PROTOTYPE_SHAPES} The robot imagines \
each as it stands with the kind's physics and rules: the positive must come out functional and the negative not. \
If one does not, the answer comes back with what the simulation saw (the prior, each plan's score, the rules' \
words) for you to repair the row or the prototypes. Keep "affordance" equal to the requested name."""


_FRAME = """Conventions. Units are metres, kilograms, radians. The TASK FRAME has its origin at the centre of the \
object's world-aligned bounding box in the stable pose being imagined, axes along the world axes, +z up. The \
object occupies [-h, h] per axis, where h are its half extents in that pose; its top is at z = +h_z and the ground \
at z = -h_z. Directions: front = +x, back = -x, left = +y, right = -y. Quaternions are (w, x, y, z). OBB dims are \
the object's oriented-bounding-box extents sorted in descending order; which of them is vertical depends on the \
stable pose."""

#: The stages that write a profile (1-6) are also asked for one that serves every object of a use.
_PER_USE = """A task whose obb_dims is null asks for one profile that serves every object of the use: positions are \
relative to each object's h (as every trajectory is), and the agent's and the layout's sizes are the use's (the \
analysis's sizes give its objects' typical range)."""
_PROFILE_STAGES = ("affordance_analyzer", "agent_model", "agent_configuration", "motion_planner", "trajectory",
                   "scoring")

STAGES: dict[str, StageSpec] = {
    s.name: s
    for s in (
        StageSpec("affordance_definition", AffordanceDefinition, _definition_instructions()),
        StageSpec("affordance_analyzer", AffordanceAnalysis, """You are the Affordance Analyzer of a robot that \
imagines how an unseen object could be used. Given an affordance name and the object's OBB dims, (1) check whether \
the dims are plausible for that affordance in the real world and give the reason with the sizes compared; when they \
are not, name an alternative affordance of the same family (a use with the same agent and test: a bowl for a cup too \
wide, a bench for a chair too long) that the dims do fit (or null); judge the object resting on the face its use \
needs (a cup upright, a bed lying flat): which OBB dim is vertical is yours to choose, the imagination then tries \
every stable pose. The examples' reasons quote a size prior as "quantity value (typical lo-hi, width w%): p", where \
p is 1 inside the typical range and falls off outside it over w percent of the bound, and the prior is the product \
of the p's; "fits" is true when the product is at least 0.5; (2) give the \
interaction-based definition (IBD); (3) describe a simple rigid agent (or a grid of identical agents) that can test \
the affordance in a physics simulator, how the agent moves to interact, and the resultant configuration that means \
the object affords it. With obb_dims given, "sizes" is null and "prototypes" []. Keep "affordance" equal to the \
requested name.
When the task's obb_dims is null, the profile you start is written once and serves EVERY object of the use, each \
weighed by the sizes you give: there is no object to check, so "fits" is true, "alternative" null and "reason" \
says what the sizes rest on. "sizes" holds "largest" and "smallest", each [lo, hi] in metres with 0 < lo <= hi and \
smallest's lo <= largest's hi: the typical range of the largest and of the smallest OBB dim of the use's real \
objects, for the person (or the task's scale's agent) using it; each object's prior is the product of the two \
plausibilities (1 inside, half gone 10% past a bound); "basis" gives one line per range: the real objects measured \
and where the numbers come from (a standard, catalogues, anthropometry). "prototypes" holds at least one \
"positive" (an obvious object of the use, its sizes inside "sizes": a prior of at least 0.5, checked) and one \
"negative" (a near miss the use must refuse: the same shell closed or turned into a slab, too small, too shallow, \
too tall), each with its role, shape, sizes and "why". {_PROTOTYPE_SHAPES} Before the profile judges any object \
the robot imagines each prototype as it stands with the whole profile (the agent, layout, plans, trajectories and \
scoring of the next stages): the positive must come out functional and the negative not."""),
        StageSpec("agent_model", AgentModel, """You are the Agent Model Generator. Write the agent described in the \
analysis as an MJCF fragment: <mujoco><worldbody><body name="..."><geom .../></body></worldbody></mujoco> with \
EXACTLY ONE body, NO joints (the simulator adds a free joint), primitive geoms (sphere, box, cylinder, capsule, \
ellipsoid) with explicit mass, sizes in metres (MuJoCo sizes are half sizes / radii) scaled to the object (with \
obb_dims null: to the use's objects, the analysis's sizes). Its bounding radius must be 0.001 m to max(1.5 x the \
object's largest dim (with obb_dims null: the largest's hi), 1.1 m); its mass 1e-05 to 200 kg."""),
        StageSpec("agent_configuration", AgentLayout, """You are the Agent Configuration Generator. Arrange identical \
agents in a world-aligned grid about the layout centre: counts nx, ny, nz >= 1 and spacings sx, sy, sz (m) between \
neighbouring agent centres. Spacing along an axis with more than one agent must be at least the agent's bounding \
diameter so agents do not overlap. One agent: nx = ny = nz = 1. collide_agents: true when agents should pile up \
(droplets), false for a lone agent."""),
        StageSpec("motion_planner", MotionPlans, """You are the Agent Motion Planner. Give at least five distinct \
high-level plans (e.g. from above, front, back, left, right) for moving the agent layout to interact with the \
object, each with a short identifier name and a step-by-step description from the start to the end point. The \
agents are released at their first contact with anything, or at the end of the trajectory."""),
        StageSpec("trajectory", Trajectories, """You are the Trajectory Generator. For every plan, in the same order \
and with the same name, give 2-8 via-poses of the LAYOUT CENTRE. Each via-pose position is rel * h + offset_m in \
the task frame: rel in units of the object's half extents h (so one answer fits every stable pose; (0, 0, 1) is \
the centre of the top face, (0, 0, -1) the ground below the centre), offset_m in metres for clearances that depend \
on the agent. With anchor "opening", x and y are measured from the middle of the pose's deepest basin instead of \
the box centre (aim pours there: a handle moves the box centre off the opening). The first via-pose must keep \
the whole agent grid outside the object's box and above the ground, checked with a cube: the grid's half size per \
axis is the largest layout offset on that axis plus the agent's bounding radius (the farthest point of its geoms \
from its body origin; an articulated body's is its whole reach), and [start - half size, start + half size] must \
not overlap [-h, h] on every axis at once and must stay above z = -h_z (the ground) — for every stable pose's h \
(every axis-aligned orientation of the OBB; with obb_dims null, of every extreme box of the analysis's sizes: \
largest at its lo and hi, smallest at its lo and hi, the middle dim equal to either). \
Keep every via-pose within 3 max(h) + the grid's half size + 1 m of the origin. quat is a unit quaternion \
(w, x, y, z)."""),
        StageSpec("scoring", ScoringCode, f"""You are the Scoring Function Generator. Write Python source of \
def score({", ".join(SCORING_ARGS)}): returning one float per rollout, shape (B,), > 0 meaning success. Inputs are \
numpy arrays over a batch of B rollouts and N agents, all in the task frame at the end of the rollout: agent_pos \
(B, N, 3), agent_quat (B, N, 4) wxyz, agent_vel (B, N, 3) m/s, contacts_object / contacts_agents / contacts_ground \
(B, N) contact-point counts, object_pos (B, 3) displacement of the object, object_tilt (B,) rad, object_half_extents \
(B, 3). Vectorise over the batch (reduce over the agent axis with np functions); use only `np` (already provided); \
no imports, no dunder names, no I/O, no loops over rollouts. The code is run on a synthetic batch of the request's \
agents and plans (every orientation of the object's box; with obb_dims null, of every extreme box of the \
analysis's sizes) and must return a finite float array of shape (B,). With obb_dims null the whole profile is then \
imagined on the analysis's prototypes, each as it stands: the positive must come out functional (a plan scores \
> 0 in most of the robot's perturbed worlds, with the object not tipped over and not with most agents on the \
ground away from the object: agents on the ground must touch it) and the negative not; otherwise your code comes \
back with what the simulation saw, plan by plan (the score, where the agents came to rest: inside the object's \
box, beside it, on the ground, how far; contacts; the object's tilt), to \
repair: the agent, layout and trajectories are fixed by then, so make the score tell the two apart."""),
        StageSpec("functional_pose", FunctionalPoseVerdict, f"""You are the Functional Pose Analyzer. For each \
stable pose you get how often drops of the object end in it, its box, its basin and its shape (which faces its \
cavity opens through, whether it is the pose the object came in: the mesh file's own up, the pose it was modelled \
or scanned in, as files usually store an object as built), and the candidate interactions that the scoring \
function called successful, each with its plan, via-poses (task frame, m), score and a summary of the resultant \
configuration; `failed` lists the pose's other plans, which the scoring function called failures, as evidence \
about the object. "came_in" is the object's shape as it came, whether or not that pose is among them; for an object \
that came in an arbitrary orientation (a scan whose up is unknown) "came_in" and each pose's "as_it_came" are null: \
then nothing says which pose its maker designed, so judge by the shape and the physics alone. A model that takes \
pictures also gets one picture per pose after the request, each after its caption: the object resting in that pose, \
drawn as the convex parts the physics used (brown shades), the agents blue where the pose's best plan left them, on \
a ground of 10 cm checker squares; read the object's shape from it. Decide per \
pose whether the success is consistent with common sense for the affordance (reject successes that rely on the \
object tipping over, agents arriving from an implausible direction, or resting at an implausible height, and a \
container through which agents poured at its centre reached the ground beneath it: it leaks); weigh whether a \
person would use the object in that pose (an object whose cavity opens sideways as it came, a shelf box or a \
cubby, holds what is dropped in only on its back, a pose its maker did not design it for) and say it in the \
reason. Give a reason, the best accepted plan of the pose, and the best (pose, plan) overall (null when none is \
accepted). One verdict per pose, in the same order.
The request's fields:
{_glossary()}"""),
        StageSpec("request_parser", Request, """You are the Request Parser of a robot that places things. Given a \
sentence asking it to put an agent in or on an object ("put the apple in the bowl", "place the doll on the toy \
chair"), answer the agent (what is placed: singular, lower case, no article), the affordance the object must have \
for it (singular, lower case: its registered name, e.g. "pen holder" for "pencil cup"; a compound name such as \
"coffee table" or "soap dish" whole, never only its last word), the preposition: "in" for in / into / inside, "on" \
for on / onto / on top of, and the owner: the figure or animal whose smaller thing the object's name says it is, when \
the affordance is the person-sized thing's name ("the doll's chair": affordance "chair", owner "doll"), else null. \
Keep "text" equal to the sentence as given."""),
    )
}

#: Typical objects whose offline profiles are the few-shot examples.
_EXAMPLE_TASKS = (
    TaskDescription(affordance="cup", obb_dims=[0.11, 0.085, 0.085]),
    TaskDescription(affordance="chair", obb_dims=[0.9, 0.5, 0.48]),
)

#: Stage 1's answer for every cup (a task of no obb_dims): its sizes and prototypes, the rest as the library's.
_EXAMPLE_USE_ANALYSIS = offline.offline_analysis(_EXAMPLE_TASKS[0]).model_copy(update={
    "reason": "A profile for every cup: sizes from catalogue cups and mugs, each object weighed by them.",
    "sizes": UseSizes(largest=(0.07, 0.16), smallest=(0.05, 0.11), basis=[
        "largest 0.07-0.16 m: espresso cups 6-7 cm tall to tall mugs 12-16 cm with a handle, in catalogues",
        "smallest 0.05-0.11 m: a cup's rim 5-9 cm across, a mug's up to 11 cm, held in one hand"]),
    "prototypes": [Prototype(role="positive", shape="open_cylinder", length=0.08, width=0.0, height=0.1, wall=0.004,
                             why="a plain 8 cm mug, 10 cm tall"),
                   Prototype(role="negative", shape="closed_cylinder", length=0.08, width=0.0, height=0.1,
                             why="the same outline closed: nothing poured stays in it")]})

#: Sentences whose offline parses are the request parser's few-shot examples.
_EXAMPLE_REQUESTS = ("put the apple in the bowl", "Place the dolls onto the chairs.", "put the cup on the doll's table")


#: Stage 0's examples: two registry rows as a model would write them, with what their sizes are measured from, and
#: a use that no kind models.
_EXAMPLE_DEFINITIONS = (
    ("stool", "seat",
     [Prototype(role="positive", shape="seat_on_legs", length=0.35, width=0.35, height=0.45, wall=0.03,
                why="a plain four-legged stool, its seat 45 cm up"),
      Prototype(role="negative", shape="seat_on_legs", length=0.35, width=0.35, height=1.2, wall=0.03,
                why="the same seat 1.2 m up: too high to sit on")],
     ["seat height 0.43-0.8 m: sitting stools 43-48 cm (ANSI/BIFMA X5.1 seat heights), counter and bar stools "
      "61-80 cm", "seat 0.25-0.45 m across: catalogue stools, a person's hips (bi-trochanteric breadth ~0.35 m)"],
     "A stool's test is a person sitting on a seat: the seat kind lowers the body onto it facing each way."),
    ("bowl", "container",
     [Prototype(role="positive", shape="open_cylinder", length=0.2, width=0.0, height=0.08, wall=0.006,
                why="a 20 cm bowl 8 cm deep"),
      Prototype(role="negative", shape="closed_cylinder", length=0.2, width=0.0, height=0.08,
                why="the same outline closed: nothing stays in it")],
     ["rim 12.5-40 cm across, 4.5-20 cm deep: cereal bowls to serving bowls in catalogues; up to 50 cm long with "
      "a saucepan's handle",
      "height at most 0.55 of the rim: a bowl is wider than tall, unlike a cup"],
     "A bowl holds food poured into it: the container kind drops droplets above the opening and keeps them."),
)


@cache
def _examples(stage: str) -> tuple[tuple[str, str], ...]:
    """(request JSON, answer JSON) pairs of the offline library for one stage."""
    if stage == "affordance_definition":
        pairs = [(DefinitionRequest(affordance=name).model_dump_json(),
                  AffordanceDefinition(affordance=name, kind=kind, row_toml=row_toml(REGISTRY[name]),
                                       size_basis=basis, prototypes=prototypes, reason=reason).model_dump_json())
                 for name, kind, prototypes, basis, reason in _EXAMPLE_DEFINITIONS]
        ladder = AffordanceDefinition(affordance="ladder", kind=None, row_toml=None, size_basis=[], prototypes=[],
                                      reason="climbing needs a body that steps and grips rung to rung; no kind "
                                             "tests that")
        return (*pairs, (DefinitionRequest(affordance="ladder").model_dump_json(), ladder.model_dump_json()))
    if stage == "request_parser":
        return tuple((RequestText(text=t).model_dump_json(), offline.offline_request(RequestText(text=t))
                      .model_dump_json()) for t in _EXAMPLE_REQUESTS)
    pairs = [_profile_example(stage, task, task, offline.offline_analysis(task)) for task in _EXAMPLE_TASKS]
    # one profile for every cup: the same answers made for its positive prototype, under a task of no obb_dims
    cup = _EXAMPLE_USE_ANALYSIS
    reference = TaskDescription(affordance="cup", obb_dims=sorted(extents(cup.prototypes[0]), reverse=True))
    pairs.append(_profile_example(stage, TaskDescription(affordance="cup", obb_dims=None), reference, cup))
    return tuple(p for p in pairs if p is not None)


def _profile_example(stage: str, shown: TaskDescription, task: TaskDescription,
                     analysis: AffordanceAnalysis) -> tuple[str, str] | None:
    """(request, answer) JSON of a profile stage (1-6): the offline library's answer for ``task``, the request as
    ``shown`` (a task of no obb_dims shows one), with ``analysis`` as stage 1's answer; None for another stage."""
    agent = offline.offline_agent(task)
    layout = offline.offline_layout(task)
    plans = offline.offline_plans(task)
    request: BaseModel
    answer: BaseModel
    if stage == "affordance_analyzer":
        request, answer = AnalyzerRequest(task=shown), analysis
    elif stage == "agent_model":
        request, answer = AgentModelRequest(task=shown, analysis=analysis), agent
    elif stage == "agent_configuration":
        request, answer = LayoutRequest(task=shown, analysis=analysis, agent=agent), layout
    elif stage == "motion_planner":
        request, answer = PlannerRequest(task=shown, analysis=analysis), plans
    elif stage == "trajectory":
        request = TrajectoryRequest(task=shown, analysis=analysis, agent=agent, layout=layout, plans=plans)
        answer = offline.offline_trajectories(task, layout)
    elif stage == "scoring":
        request = ScoringRequest(task=shown, analysis=analysis, agent=agent, layout=layout, plans=plans)
        answer = offline.offline_scoring(task)
    else:
        return None
    return request.model_dump_json(), answer.model_dump_json()


def system_prompt(stage: StageSpec) -> str:
    """Role and rules of the stage, the frame conventions, and worked examples."""
    parts = [stage.instructions, _FRAME, *([_PER_USE] if stage.name in _PROFILE_STAGES else [])]
    if stage.name == "scoring":
        from rail_mj.scoring import scoring_rules  # the sandbox's allow-list, one source of truth

        parts.append(scoring_rules())
    for i, (request, answer) in enumerate(_examples(stage.name), start=1):
        parts.append(f"Example {i} request:\n{request}\nExample {i} answer:\n{answer}")
    parts.append("Answer with exactly one JSON object matching the required schema, nothing else.")
    return "\n\n".join(parts)


def user_prompt(request: BaseModel) -> str:
    """The request as JSON."""
    return f"Request:\n{request.model_dump_json()}"


def repair_prompt(problem: str) -> str:
    """Follow-up message after an answer was rejected."""
    return (f"Your previous answer was rejected:\n{problem}\n"
            "Fix the problem and answer again with one complete JSON object matching the schema.")
