"""A profile folder in the paper authors' format imported as an :class:`ImaginationProfile`, and written.

A folder holds ``analysis.txt``, ``agent.urdf``, ``arrangement.json``, ``plan.json`` and/or
``agents_traj.json`` and sometimes ``evaluation.py`` (see :mod:`rail_mj.profiles`); every stage the folder
lacks comes from the provider. Via-points are metres from an origin (:data:`Origin`): ``ground``, the centre
of the object's footprint on the ground, z up (the default: how the published folders were read when this
format was specified, a 10 cm cup's droplets ending 13 cm up), or ``center``, the centre of the object's box.
Either way a via-point becomes a via-pose ``rel * h + offset_m`` with ``offset_m`` the point and
``rel = (0, 0, -1)`` or ``(0, 0, 0)``, so it stays at the same height above the ground (or the box centre) in
every stable pose. Adapted (the default), a via-point is read as written for a typical object of the class and
scaled to each pose's box (:func:`typical_half_extents`, ``_via``).

:func:`save_profile` writes a profile in the same format, plus ``scoring.py`` (rail_mj's own vectorised scoring
code, used when there is no ``evaluation.py``) and ``rail_mj.json``, which holds what the paper's files cannot
carry exactly (via-poses relative to the box, contact settings, plan descriptions). On import each part of
``rail_mj.json`` is used only while the paper file it belongs to is unchanged (writing the part again gives
the file's text), so an edited file always wins and a folder written here round-trips exactly.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Literal

import numpy as np

import rail_mj.profiles.files as F
from rail_mj.affordances import names
from rail_mj.affordances.prototypes import extents
from rail_mj.core.errors import ProfileFolderError, UnknownAffordanceError
from rail_mj.core.profile import AgentLayout, MotionPlan, PlanTrajectory, ScoringCode, ViaPose
from rail_mj.imagination.inputs import layout_offsets, trajectory_array
from rail_mj.llm import stages
from rail_mj.llm.checks import InvalidAnswerError, agent_geometry, candidate_half_extents, check_agent
from rail_mj.llm.prompts import PROMPT_VERSION
from rail_mj.llm.providers import Provider
from rail_mj.llm.schemas import (
    AffordanceAnalysis,
    AgentModel,
    AgentModelRequest,
    AnalyzerRequest,
    ImaginationProfile,
    LayoutRequest,
    MotionPlans,
    PlannerRequest,
    ScoringRequest,
    TaskDescription,
    Trajectories,
    TrajectoryRequest,
)
from rail_mj.mjcf import check_fragment
from rail_mj.profiles.evaluation import evaluation_scoring, probe_scoring
from rail_mj.urdf.agent import fragment_to_urdf, urdf_to_fragment

__all__ = ["Origin", "ORIGIN_LIFT", "AGREE_M", "import_profile", "save_profile", "typical_half_extents"]

#: Where the via-points' coordinates start: ``ground`` (under the box centre) or ``center`` (of the box).
Origin = Literal["ground", "center"]
#: The origin's height above the box centre in units of h_z (the ground is at z = -h_z in the task frame).
ORIGIN_LIFT: dict[str, float] = {"ground": 1.0, "center": 0.0}
#: agents_traj.json's agents must keep their arrangement to this (m): rounding of published numbers, far below an
#: agent's size; rail_mj moves the agents as one group.
AGREE_M = 1e-3


def _lift(origin: str) -> float:
    if origin not in ORIGIN_LIFT:
        raise ProfileFolderError(f"unknown via-point origin {origin!r}; valid: {', '.join(ORIGIN_LIFT)}")
    return ORIGIN_LIFT[origin]


def _sidecar(folder: Path) -> dict:
    path = folder / F.SIDECAR
    if not path.is_file():
        return {}
    try:
        data = json.loads(F.read_text(path))
        return {"h": [float(v) for v in data["half_extents"]], "origin": data["origin"],
                "profile": ImaginationProfile.model_validate(data["profile"])}
    except (ValueError, KeyError, TypeError) as exc:
        raise ProfileFolderError(f"{path}: not a profile that rail_mj wrote ({type(exc).__name__}: {exc})"[:600]) \
            from None


def _unchanged(folder: Path, name: str, text: str) -> bool:
    path = folder / name
    return path.is_file() and F.read_text(path) == text


def _paper_plans(trajectories: Trajectories, offsets: np.ndarray, h: Sequence[float], lift: float):
    """plan.json's and agents_traj.json's contents for the half extents ``h``."""
    up = np.array([0.0, 0.0, lift * h[2]])
    centre = {f"plan_{i + 1}": a[:, :3] + up
              for i, a in enumerate(trajectory_array(trajectories.trajectories, h))}
    return centre, {k: pts[None, :, :] + offsets[:, None, :] for k, pts in centre.items()}


def _analysis(folder: Path, task: TaskDescription, provider: Provider, side: dict) -> AffordanceAnalysis | None:
    path = folder / F.ANALYSIS
    if not path.is_file():
        return None
    paper = F.read_analysis(path)
    old = side.get("profile")
    if old is not None and _unchanged(folder, F.ANALYSIS, F.analysis_text(old.analysis, paper.object_class)):
        return old.analysis.model_copy(update={"affordance": task.affordance})
    got = paper.fields
    if "fits" in got:
        fits, reason, alternative = got["fits"].lower() == "yes", got.get("reason", paper.text), got.get("alternative")
    else:  # the dimension check is stage 1's: the provider's when it can analyse this affordance
        try:
            check = stages.analyze_affordance(AnalyzerRequest(task=task), provider)
            fits, reason, alternative = check.fits, check.reason, check.alternative
        except UnknownAffordanceError:
            fits, reason, alternative = True, f"{path} gives no dimension check and the {provider.name} provider " \
                                              f"cannot make one for {task.affordance!r}", None
    return AffordanceAnalysis(
        affordance=task.affordance, fits=fits, reason=reason,
        alternative=None if (alternative or "none").lower() == "none" else alternative,
        ibd=got.get("ibd", paper.text), agent_description=got.get("agent_description", paper.text),
        interaction_description=got.get("interaction_description", paper.text),
        expected_outcome=got.get("expected_outcome", paper.text))


def _agent(folder: Path, task: TaskDescription, side: dict) -> AgentModel | None:
    path = folder / F.AGENT
    if not path.is_file():
        return None
    text = F.read_text(path)
    fragment = urdf_to_fragment(text, str(path))
    old = side.get("profile")
    if old is not None and fragment_to_urdf(old.agent.mjcf, old.agent.name) == text:
        agent = old.agent
    else:
        name = check_fragment(fragment).worldbody.first_body().name
        agent = AgentModel(name=name, description=f"the agent of {path}", mjcf=fragment)
    try:
        check_agent(agent, task)
    except InvalidAnswerError as exc:
        raise ProfileFolderError(f"{path}: {exc}") from None
    return agent


def _layout(folder: Path, offsets: np.ndarray | None, radius: float, side: dict, adapt: bool,
            notes: list[str]) -> AgentLayout | None:
    if offsets is None:
        return None
    old = side.get("profile")
    if old is not None and _unchanged(folder, F.ARRANGEMENT, F.arrangement_text(layout_offsets(old.layout))):
        return old.layout
    where = folder / (F.ARRANGEMENT if (folder / F.ARRANGEMENT).is_file() else F.AGENTS_TRAJ)
    pairs = [(float(np.linalg.norm(offsets[i] - offsets[j])), i, j)
             for i, j in itertools.combinations(range(len(offsets)), 2)]
    gap, i, j = min(pairs) if pairs else (np.inf, 0, 0)
    if gap < 2 * radius:
        overlap = (f"{where}: agents {i + 1} and {j + 1} are {gap:.4f} m apart, closer than the agent's diameter "
                   f"{2 * radius:.4f} m: they would start inside each other")
        if not adapt or gap < _SAME_PLACE_M:
            raise ProfileFolderError(overlap + ("" if adapt else " (adaptation is off: space them, or import with "
                                                "adaptation on, which spreads the arrangement)"))
        # the authors' simulator pushes bodies that start inside each other apart on its first step: spread the
        # arrangement about its centre just enough that the closest two touch, keeping its shape
        factor = 2 * radius / gap
        centre = offsets.mean(axis=0)
        offsets = np.asarray(centre + (offsets - centre) * factor)
        notes.append(f"{overlap}; the arrangement is spread {factor:.2f}x about its centre so that none does, as the "
                     f"authors' simulator pushes them apart on its first step")
    spacing = 2 * radius  # the grid is unused beside explicit offsets; its spacing says what they keep to
    return AgentLayout(nx=1, ny=1, nz=1, sx=spacing, sy=spacing, sz=spacing, collide_agents=True,
                       offsets=offsets.tolist())


#: Two agents closer than this stand in one place: no spreading of the arrangement about its centre parts them.
_SAME_PLACE_M = 1e-6


def _offsets(folder: Path, trajs: dict[str, np.ndarray] | None) -> np.ndarray | None:
    """The arrangement: arrangement.json, else the agents' spread at the start of agents_traj.json."""
    if (folder / F.ARRANGEMENT).is_file():
        offsets = F.read_arrangement(folder / F.ARRANGEMENT)
        if trajs is not None and next(iter(trajs.values())).shape[0] != len(offsets):
            raise ProfileFolderError(f"{folder / F.AGENTS_TRAJ}: moves {next(iter(trajs.values())).shape[0]} agents; "
                                     f"{folder / F.ARRANGEMENT} arranges {len(offsets)}")
        return offsets
    if trajs is None:
        return None
    first = next(iter(trajs.values()))[:, 0, :]
    return first - first.mean(axis=0)


def _centre_paths(folder: Path, trajs: dict[str, np.ndarray], offsets: np.ndarray) -> dict[str, np.ndarray]:
    """The group centre's via-points of agents_traj.json, whose agents must keep their arrangement."""
    out = {}
    for name, agents in trajs.items():
        centres = agents - offsets[:, None, :]
        spread = float(np.abs(centres - centres.mean(axis=0)).max())
        if spread > AGREE_M:
            raise ProfileFolderError(
                f"{folder / F.AGENTS_TRAJ}: {name}: the agents leave their arrangement by up to {spread:.4f} m; "
                f"rail_mj moves them as one group, so each agent's path must be the group's shifted by its offset "
                f"(to {AGREE_M} m)")
        out[name] = centres.mean(axis=0)
    return out


def _plans(folder: Path, trajs: dict[str, np.ndarray] | None, offsets: np.ndarray | None, lift: float,
           side: dict, adapt: bool, notes: list[str], affordance: str) -> tuple[MotionPlans, Trajectories] | None:
    if (folder / F.PLAN).is_file():
        centre = F.read_plans(folder / F.PLAN)
        source = F.PLAN
    elif trajs is not None and offsets is not None:
        centre, source = _centre_paths(folder, trajs, offsets), F.AGENTS_TRAJ
    else:
        return None
    old = side.get("profile")
    if old is not None and offsets is not None:
        plan, agents = _paper_plans(old.trajectories, np.asarray(offsets), side["h"], ORIGIN_LIFT[side["origin"]])
        if _unchanged(folder, source, F.plans_text(plan) if source == F.PLAN else F.agents_traj_text(agents)):
            return old.plans, old.trajectories
    plans = [MotionPlan(name=k, description=f"{k}: the via-points of {source}") for k in centre]
    # the format places via-points about the box's centre, which is the use's place only where nothing sticks out
    # (a mug's handle moves the box's centre off its cavity): centred at the opening, a pose's basin, where a pour
    # aims (a pose without a basin keeps the box's centre)
    anchor: Literal["box", "opening"] = "opening" if adapt else "box"
    typical = typical_half_extents(affordance) if adapt else None
    if adapt:
        notes.append(f"{source}'s via-points are centred at each pose's opening (the middle of its deepest basin, "
                     f"where a pour aims; a pose without one keeps its box's centre), not at its box's centre")
    if typical is not None and any(t is not None for t in typical):
        sizes = ", ".join(f"{name} {2 * t:.3g} m" for name, t in zip(("length", "width", "height"), typical,
                                                                     strict=True) if t is not None)
        notes.append(f"{source}'s via-points are read as written for a typical {affordance} ({sizes}: the middle of "
                     f"each typical range, on a log scale) and scaled to each pose's box: a point within the typical "
                     f"box keeps its place in proportion, a point outside it keeps its clearance from the box")
    else:
        typical = (None, None, None)
    trajectories = [PlanTrajectory(plan=k, via_poses=[_via(p, typical, lift, anchor) for p in pts])
                    for k, pts in centre.items()]
    return MotionPlans(plans=plans), Trajectories(trajectories=trajectories)


def typical_half_extents(affordance: str) -> tuple[float | None, float | None, float | None] | None:
    """Half the length, width and height of a typical object of a registered ``affordance`` (x, y, z of the task
    frame, the longer horizontal side along x): the middle, on a log scale, of each typical range of its row's
    envelope that is bounded on both sides; None where a range is open. A side of the footprint whose range is open
    takes the other's (a plate is about as wide as long). None for an affordance the registry does not know."""
    try:
        ranges = names.get(affordance).envelope.ranges()
    except UnknownAffordanceError:
        return None

    def middle(name: str) -> float | None:
        lo, hi = ranges.get(name, (0.0, math.inf))
        return math.sqrt(lo * hi) / 2 if 0 < lo and math.isfinite(hi) else None

    length, width, height = middle("length"), middle("width"), middle("height")
    return length or width, width or length, height


def _via(point: np.ndarray, typical: Sequence[float | None], lift: float, anchor: Literal["box", "opening"]) -> ViaPose:
    """A folder's via-point (m from ``lift``'s origin) as a via-pose. Along an axis with a typical half extent t,
    a point within the typical box keeps its place in proportion to the pose's box (``rel = c / t``, the use's
    place in the object: the floor of a tub, a fraction of a cup's depth), and a point outside keeps its
    clearance from the box's face (the height an agent falls from, the room an approach leaves)."""
    centred = np.asarray(point, dtype=float) - np.array([0.0, 0.0, lift * (typical[2] or 0.0)])
    rel, offset = [0.0, 0.0, -lift], [float(v) for v in point]
    for axis, t in enumerate(typical):
        if t is None:
            continue
        c = float(centred[axis])
        rel[axis] = c / t if abs(c) <= t else math.copysign(1.0, c)
        offset[axis] = 0.0 if abs(c) <= t else c - math.copysign(t, c)
    return ViaPose(rel=rel, offset_m=offset, quat=[1.0, 0.0, 0.0, 0.0], anchor=anchor)


def import_profile(folder: str | Path, task: TaskDescription, provider: Provider, *,
                   origin: Origin = "ground", adapt: bool = True) -> ImaginationProfile:
    """The profile of a paper-format ``folder`` for ``task``; stages it lacks come from ``provider``.

    Every file is checked (ProfileFolderError naming it): the URDF through MuJoCo's compiler and the agent
    allow-list and the agent's size and mass checks, the JSON shapes, finite numbers, agents that start apart,
    and ``evaluation.py`` under the scoring sandbox's allow-list, run once on a synthetic batch. With ``adapt``,
    what the format leaves open is adapted the way the authors' simulator would run it (agents that start inside
    each other are spread apart, via-points centred at each pose's opening and scaled from the class's typical
    object to each pose's box, :func:`typical_half_extents`), each adaptation named in the profile's ``notes``;
    without, a folder with overlapping agents is refused and via-points keep the box's centre and their metres.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ProfileFolderError(f"{folder}: not a folder")
    lift = _lift(origin)
    side = _sidecar(folder)
    used: dict[str, str] = {}

    def mark(stage: str, from_folder: bool) -> None:
        used[stage] = "folder" if from_folder else PROMPT_VERSION[stage]

    analysis = _analysis(folder, task, provider, side)
    mark("affordance_analyzer", analysis is not None)
    analysis = analysis or stages.analyze_affordance(AnalyzerRequest(task=task), provider)
    agent = _agent(folder, task, side)
    mark("agent_model", agent is not None)
    agent = agent or stages.generate_agent_model(AgentModelRequest(task=task, analysis=analysis), provider)
    trajs = F.read_agents_traj(folder / F.AGENTS_TRAJ) if (folder / F.AGENTS_TRAJ).is_file() else None
    offsets = _offsets(folder, trajs)
    notes: list[str] = []
    # spread or not, the group's centre path is the same: the spread keeps the arrangement's centre
    layout = _layout(folder, offsets, agent_geometry(agent).radius, side, adapt, notes)
    mark("agent_configuration", layout is not None)
    layout = layout or stages.generate_layout(LayoutRequest(task=task, analysis=analysis, agent=agent), provider)
    both = _plans(folder, trajs, offsets if offsets is not None else layout_offsets(layout), lift, side, adapt,
                  notes, task.affordance)
    mark("motion_planner", both is not None)
    mark("trajectory", both is not None)
    if both is None:
        plans = stages.plan_motions(PlannerRequest(task=task, analysis=analysis), provider)
        trajectories = stages.generate_trajectories(
            TrajectoryRequest(task=task, analysis=analysis, agent=agent, layout=layout, plans=plans), provider)
    else:
        plans, trajectories = both
    scoring = _scoring(folder, lift, layout.n_agents, len(plans.plans), task)
    mark("scoring", scoring is not None)
    scoring = scoring or stages.generate_scoring(
        ScoringRequest(task=task, analysis=analysis, agent=agent, layout=layout, plans=plans), provider)
    parts = (analysis, agent, layout, plans, trajectories, scoring)
    old = side.get("profile")
    # a folder rail_mj wrote and nobody changed is the profile it was written from, whoever made that
    exact = old if old is not None and parts == (old.analysis.model_copy(update={"affordance": task.affordance}),
                                                 old.agent, old.layout, old.plans, old.trajectories,
                                                 old.scoring) else None
    return ImaginationProfile(
        affordance=task.affordance, obb_dims=task.obb_dims, scale=task.scale,
        provider=exact.provider if exact else f"folder+{provider.name}",
        model=exact.model if exact else provider.model,
        prompt_versions=exact.prompt_versions if exact else used,
        analysis=analysis, agent=agent, layout=layout, plans=plans, trajectories=trajectories, scoring=scoring,
        notes=exact.notes if exact else notes)


def _scoring(folder: Path, lift: float, n_agents: int, n_plans: int, task: TaskDescription) -> ScoringCode | None:
    """evaluation.py (the paper's), else scoring.py (rail_mj's own), else None."""
    h = [list(map(float, row)) for row in candidate_half_extents(list(task.obb_dims or ()))]
    if (folder / F.EVALUATION).is_file():
        path = folder / F.EVALUATION
        return evaluation_scoring(F.read_text(path), str(path), lift=lift, n_agents=n_agents, n_plans=n_plans,
                                  half_extents=h)
    if (folder / F.SCORING).is_file():
        path = folder / F.SCORING
        source = F.read_text(path)
        probe_scoring(source, str(path), n_agents=n_agents, n_plans=n_plans, half_extents=h)
        side = _sidecar(folder).get("profile")
        if side is not None and side.scoring.source == source:
            return side.scoring
        return ScoringCode(description=f"the score function of {path}", source=source)
    return None


def save_profile(profile: ImaginationProfile, folder: str | Path, *, half_extents: Sequence[float] | None = None,
                 origin: Origin = "ground") -> Path:
    """Write ``profile`` as a paper-format folder (created if needed; these files replaced) and return it.

    Via-points are metres for the object's half extents ``half_extents`` (a pose's; default the OBB's, its
    largest along x and smallest up; for a profile of every object of the use, its positive prototype's) from
    ``origin``. ProfileFolderError when the agent has a shape URDF lacks.
    """
    folder = Path(folder)
    lift = _lift(origin)
    if half_extents is None:
        positive = next((p for p in profile.analysis.prototypes if p.role == "positive"), None)
        dims = profile.obb_dims if profile.obb_dims is not None else extents(positive) if positive is not None else []
        half_extents = [v / 2 for v in dims]
    h = [float(v) for v in half_extents]
    if len(h) != 3 or not all(np.isfinite(h)) or min(h) <= 0:
        raise ProfileFolderError(f"half_extents must be three positive finite numbers; got {h}")
    offsets = layout_offsets(profile.layout)
    plan, agents = _paper_plans(profile.trajectories, offsets, h, lift)
    texts = {
        F.ANALYSIS: F.analysis_text(profile.analysis, profile.affordance),
        F.AGENT: fragment_to_urdf(profile.agent.mjcf, profile.agent.name),
        F.ARRANGEMENT: F.arrangement_text(offsets),
        F.PLAN: F.plans_text(plan),
        F.AGENTS_TRAJ: F.agents_traj_text(agents),
        F.SCORING: profile.scoring.source,
        F.SIDECAR: json.dumps({"format": 1, "half_extents": h, "origin": origin,
                               "profile": profile.model_dump(mode="json")}, indent=1) + "\n",
    }
    if (folder / F.EVALUATION).exists():
        raise ProfileFolderError(f"{folder}: holds an {F.EVALUATION}, which would be used in place of the profile's "
                                 f"own {F.SCORING}; write the profile to another folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for name, text in texts.items():
            (folder / name).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise ProfileFolderError(f"{folder}: cannot write the profile ({exc})") from None
    return folder
