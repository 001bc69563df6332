"""The pipeline: object → stable poses → profile → batched imagination → scores → pose probabilities → functional pose.

``classify`` is the library API for batch affordance classification; the
``Pipeline`` class keeps what is reused across objects (provider, profiles,
compiled scoring functions).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from contextlib import closing
from pathlib import Path
from typing import Any, cast

import numpy as np

from rail_mj import llm, profiles
from rail_mj.affordances import Affordance, load_files, request_scale
from rail_mj.affordances.envelope import ANY
from rail_mj.affordances.judge import rules_row
from rail_mj.affordances.kinds import kind_of
from rail_mj.affordances.prior import FUNCTIONAL, NEGLIGIBLE, Prior
from rail_mj.core.errors import ConfigError, RailError, UnknownAffordanceError
from rail_mj.core.profile import PoseShape
from rail_mj.core.results import AffordanceResult, PlanInfo, PoseInfo
from rail_mj.core.types import AgentSetup, RailObject, StablePose, StablePoses
from rail_mj.imagination import PerturbationSet, draw_perturbations, imagine, pose_plan, resolve_backend
from rail_mj.imagination.inputs import agent_setup, trajectory_array
from rail_mj.imagination.perturb import resting_on
from rail_mj.imagination.worlds import ImaginedWorlds
from rail_mj.llm.schemas import FunctionalPoseVerdict, ImaginationProfile
from rail_mj.mesh import load_object, mesh_notes, redecomposed
from rail_mj.pipeline import definitions
from rail_mj.pipeline.config import Definition, ObjectInput, RunConfig
from rail_mj.pipeline.parallel import run_tasks
from rail_mj.pipeline.pose_pictures import stage7_pictures
from rail_mj.pipeline.tasks import ObjectTask
from rail_mj.pipeline.verdicts import candidate_slots, judge, most_probable, next_worlds, pose_prior, undecided
from rail_mj.scoring import ScoringFunction, compile_scoring
from rail_mj.stable_poses import find_stable_poses, pose_from_up
from rail_mj.stable_poses.came_in import common_factor, design_factors
from rail_mj.stable_poses.shape import ObjectShapes

__all__ = ["Pipeline", "classify", "define_uses", "definition_counter", "provider_for", "as_placed_pose",
           "object_task", "run_object"]

ProgressCallback = Callable[[int, int, AffordanceResult], None]
logger = logging.getLogger(__name__)


def _check_names(affordances: Sequence[str]) -> None:
    """Refuse a non-list, an empty list or an empty name: no provider can imagine those."""
    if isinstance(affordances, str):
        raise ConfigError(f"affordances must be a list of names, e.g. [{affordances!r}]; got a string")
    known = ", ".join(llm.known_affordances())
    if not affordances:
        raise ConfigError(f"no affordance requested; name at least one, e.g. one of the offline library's: {known}")
    for a in affordances:
        if not isinstance(a, str) or not a.strip():
            raise ConfigError(
                f"affordance names must be non-empty text, got {a!r}; the offline library knows: {known} "
                "(an LLM provider also imagines other named uses)"
            )


def provider_for(config: RunConfig) -> llm.Provider:
    """The run's provider, configured once with the run's LLM settings (those left None: the provider's own)."""
    options = {**config.provider_options,
               **{k: v for k, v in (("model", config.model), ("max_retries", config.max_retries),
                                    ("cache", config.cache), ("timeout", config.llm_timeout),
                                    ("pictures", config.llm_pictures)) if v is not None}}
    return llm.get_provider(config.provider, **options)


def _shape_facts(shapes: ObjectShapes | None,
                 oriented: bool) -> tuple[Callable[[int], PoseShape] | None, PoseShape | None]:
    """Stage 7's shape facts: each pose's shape and the object's as it came. For an object that came in an arbitrary
    orientation, neither the shape it came in nor whether a pose is that one: they say nothing of the pose its
    maker designed."""
    if shapes is None:
        return None, None
    if oriented:
        return shapes.pose, shapes.came_in
    return lambda i: shapes.pose(i).model_copy(update={"as_it_came": None}), None


def as_placed_pose(obj: RailObject) -> StablePoses:
    """The object's pose as it stands, as the one stable pose (probability 1): its mesh frame's z up, resting on
    the ground, turned about z only so that its footprint's box lies on the task frame's axes."""
    return StablePoses(poses=(pose_from_up(obj, np.array([0.0, 0.0, 1.0]), 1.0),), n_drops=0, n_unsettled=0)


class Pipeline:
    """Runs the whole chain for (object, affordance) pairs, reusing profiles and scoring code."""

    def __init__(self, config: RunConfig | None = None):
        # the defaults of the config are taken here, in the process that runs it: a task's config, built by
        # the parent, leaves an unset ImaginationConfig.nthread to this worker's RAIL_MJ_THREADS
        config = config or RunConfig()
        self.config = type(config).model_validate(config.model_dump(exclude_unset=True))
        # the run's affordance files and the uses the provider defined, registered here too: a worker is a fresh
        # interpreter
        load_files(self.config.affordances_files)
        self._defined = definitions.register(self.config.definitions)
        # the uses no kind models: their one profile for every object, written and proven once for the run
        self._written = {_norm(d.name): d.profile for d in self.config.definitions if d.profile is not None}
        self.backend = resolve_backend(self.config.backend)
        # the run's LLM settings go to the provider once; every stage then reads them from it
        self.provider = provider_for(self.config)
        if self.config.profile_dir is not None:
            profiles.check_profile_dir(self.config.profile_dir)
        self._profiles: dict[tuple, ImaginationProfile] = {}
        self._scorers: dict[str, ScoringFunction] = {}
        # the last object's second decomposition and shape facts: an object's affordances run one after another
        self._second_of: tuple[RailObject, RailObject] | None = None
        self._shapes_of: ObjectShapes | None = None

    @property
    def provider_name(self) -> str:
        return getattr(self.provider, "name", str(self.config.provider))

    def check_affordances(self, affordances: Sequence[str]) -> None:
        """Refuse names this provider cannot imagine before any mesh or provider work.

        Empty names always (ConfigError); names outside the registry when the provider
        cannot imagine novel ones (the offline library: UnknownAffordanceError listing the known names).
        """
        _check_names(affordances)
        for a in affordances:
            if self.profile_folder(a) is None:  # a folder imagines a name the provider may not know
                self.provider.affordance_name(a)

    def profile_folder(self, affordance: str) -> Path | None:
        """The run's profile folder for ``affordance`` (by the name requested or the provider's), if any."""
        if self.config.profile_dir is None:
            return None
        try:
            names = {affordance, self.provider.affordance_name(affordance)}
        except UnknownAffordanceError:
            names = {affordance}
        return profiles.find_folder(self.config.profile_dir, names)

    # ---- per-object work ------------------------------------------------------------
    def load(self, item: ObjectInput | RailObject | str | Path) -> RailObject:
        if isinstance(item, RailObject):
            return item
        if not isinstance(item, ObjectInput):
            item = ObjectInput(path=Path(item))
        obj = load_object(item.path, units=item.units, up=item.up, name=item.name,
                          decomposition=self.config.decomposition)
        return obj if item.oriented else dataclasses.replace(obj, oriented=False)

    def stable_poses(self, obj: RailObject) -> StablePoses:
        if self.config.pose == "as_placed":
            return as_placed_pose(obj)
        return find_stable_poses(obj, self.config.stable_poses)

    # ---- per-affordance work --------------------------------------------------------
    def profile(self, affordance: str, obb_dims: Sequence[float] | np.ndarray) -> ImaginationProfile:
        """A profile for this affordance, reused for objects of similar size and for every spelling
        of the name that the provider resolves alike ("mug" and "cup" share one); imported from the run's
        profile folder for it when there is one (:mod:`rail_mj.profiles`); for a use no kind models, the one
        profile the run's definition wrote for every object (:mod:`rail_mj.pipeline.definitions`)."""
        written = self._written.get(_norm(affordance))
        if written is not None:
            return written
        folder = self.profile_folder(affordance)
        scale = request_scale(self.config.agent, self.config.owner)
        task = (llm.task_description(affordance, obb_dims, self.provider, scale=scale) if folder is None
                else profiles.folder_task(affordance, obb_dims, self.provider, scale=scale))
        b = math.log1p(self.config.profile_bin)
        # lower case: a novel name (an LLM provider's) is kept as written, in any case
        key = (task.affordance.lower(), task.scale, *(round(math.log(max(d, 1e-4)) / b) for d in task.obb_dims or ()))
        if key not in self._profiles:
            # a use the provider defined as a row of a tested kind: stages 1-6 are the kind's (no model call)
            stages = llm.get_provider("offline") if task.affordance in self._defined else self.provider
            self._profiles[key] = (llm.task_profile(task, stages) if folder is None else
                                   profiles.import_profile(folder, task, self.provider,
                                                           origin=self.config.profile_origin,
                                                           adapt=self.config.profile_adapt))
        return self._profiles[key]

    def scorer(self, source: str) -> ScoringFunction:
        if source not in self._scorers:
            self._scorers[source] = compile_scoring(source)
        return self._scorers[source]

    def _shapes(self, obj: RailObject, poses: StablePoses) -> ObjectShapes:
        """The object's shape facts for stage 7's model, measured once per object (its affordances run in turn)."""
        if self._shapes_of is None or self._shapes_of.obj is not obj:
            self._shapes_of = ObjectShapes(obj, cast(Sequence[StablePose], poses))
        return self._shapes_of

    def _decomposition_matters(self, row: Affordance | None) -> bool:
        """Whether the use's verdict is also imagined on the object's second decomposition: the config asks for it
        and the use rests in the object's concavities (its kind's ``decomposition_matters``; an LLM's use outside
        the registry may, so it is)."""
        return self.config.imagination.perturb_decomposition and (row is None or kind_of(row).decomposition_matters)

    def _second_decomposition(self, obj: RailObject) -> RailObject:
        """``obj`` with its second decomposition's hulls, made once per object (CoACD's cache keeps them on disk)."""
        if self._second_of is None or self._second_of[0] is not obj:
            self._second_of = (obj, redecomposed(obj))
        return self._second_of[1]

    def run(self, obj: RailObject, poses: StablePoses, affordance: str) -> AffordanceResult:
        """Imagine one affordance on one object whose stable poses are known: profile → prior gate → imagine (up to
        three batched calls) → judge → pick."""
        return self.imagine_case(obj, poses, affordance)[0]

    def imagine_case(self, obj: RailObject, poses: StablePoses, affordance: str,
                     profile: ImaginationProfile | None = None) -> tuple[AffordanceResult, ImaginedWorlds | None]:
        """:meth:`run` with a given ``profile`` (None: the run's for the use) and the worlds it imagined (None when
        the prior gate imagined none)."""
        timings: dict[str, float] = {}
        t = time.perf_counter()
        profile = profile or self.profile(affordance, obj.obb_dims)
        timings["profile"] = time.perf_counter() - t
        # the registry row whose kind's rules judge the use (None outside the registry: the generic rules)
        row = rules_row(profile.affordance, profile.scale)
        result = self._result(obj, poses, affordance, profile, row)
        result.timings = timings
        shapes = self._shapes(obj, poses)  # measures nothing until a shape is asked for
        design = design_factors(obj, cast(Sequence[StablePose], poses), lambda: shapes.came_in, shapes.pose)
        gate = self._prior_gate(obj, poses, profile, row, result, design)
        if gate is None:
            return result, None
        kept, priors, skipped = gate
        evidence, stage7 = self._imagine(obj, poses, profile, row, kept, priors, result, design)
        if stage7 is None:
            result.analyzer_reasons = [*skipped, "no plan scored above 0 in any imagined stable pose"]
        else:
            result.analyzer_reasons = ([f"pose {v.pose_index}: {v.reason}" for v in stage7.poses] + skipped
                                       + [stage7.reason])
        self._pick(result, profile, evidence, stage7, common_factor(design))
        return result, evidence

    def _result(self, obj: RailObject, poses: StablePoses, affordance: str, profile: ImaginationProfile,
                row: Affordance | None) -> AffordanceResult:
        """The case's result before any physics: the profile's plans, agent, scoring and size check."""
        words, toml, check = self._definition(affordance)
        return AffordanceResult(
            definition=words,
            definition_toml=toml,
            profile_check=check,
            object=obj.name,
            affordance=profile.affordance,
            requested=affordance,
            alternative=profile.analysis.alternative,
            dims_fit=self._size_prior(obj, profile, row).value >= FUNCTIONAL if row is not None
            or profile.analysis.sizes is not None else profile.analysis.fits,
            stable_poses=[PoseInfo.from_pose(i, poses[i]) for i in range(len(poses))],
            plans=[p.name for p in profile.plans.plans],
            profile_notes=list(profile.notes),
            agent_fragment=profile.agent.mjcf,
            scoring_source=profile.scoring.source,
            provider=self.provider_name,
            backend=self.backend,
        )

    def _prior_gate(self, obj: RailObject, poses: StablePoses, profile: ImaginationProfile, row: Affordance | None,
                    result: AffordanceResult, design: Sequence[tuple[str, float] | None]
                    ) -> tuple[list[int], dict[int, Prior], list[str]] | None:
        """The poses worth imagining, their priors and the reasons for those skipped; None, with the result's
        probability set to the prior, when no physics could make the object functional.

        The object's stage-1 prior (stage 1's answer is shared by every object of a profile's size bin) is its
        OBB's in its most plausible orientation. A size no real object of the use has (prior.NEGLIGIBLE), or, for a
        use outside the registry, the LLM analyser's veto: the physics is not run. A pose whose own prior is below
        NEGLIGIBLE is no use worth imagining either: its verdict is the same imagined or not, so it is not (no row,
        no prior: 1, and every pose is imagined).
        """
        analysis = profile.analysis
        dims = self._size_prior(obj, profile, row)
        vetoed = row is None and analysis.sizes is None and not analysis.fits
        if dims.value < NEGLIGIBLE or vetoed:
            result.analyzer_reasons = [analysis.reason]
            result.probability = 0.0 if vetoed else dims.value
            result.prior = dims.doc()
            return None
        kept = [i for i, p in enumerate(poses) if p.probability >= self.config.min_pose_probability] or [0]
        priors = {i: pose_prior(row, obj.obb_dims, poses[i], analysis.sizes, design[i]) for i in kept}
        skipped = [f"pose {i}: not imagined: its prior {priors[i].value:.3f} is below {NEGLIGIBLE:g} "
                   f"({priors[i].doc()}), so no physics could make it functional"
                   for i in kept if priors[i].value < NEGLIGIBLE]
        worth = [i for i in kept if priors[i].value >= NEGLIGIBLE]
        if not worth:
            top = max(kept, key=lambda i: priors[i].value)
            result.analyzer_reasons = [*skipped, analysis.reason]
            result.probability = priors[top].value
            result.prior = priors[top].doc()
            return None
        return worth, priors, skipped

    @staticmethod
    def _size_prior(obj: RailObject, profile: ImaginationProfile, row: Affordance | None) -> Prior:
        """The object's size prior: its row's, else the sizes of a profile for every object of the use, else none."""
        if row is not None:
            return row.dims_prior(obj.obb_dims)
        sizes = profile.analysis.sizes
        return sizes.prior(obj.obb_dims) if sizes is not None else Prior()

    def _imagine(self, obj: RailObject, poses: StablePoses, profile: ImaginationProfile, row: Affordance | None,
                 kept: list[int], priors: dict[int, Prior], result: AffordanceResult,
                 design: Sequence[tuple[str, float] | None]) -> tuple[ImaginedWorlds, FunctionalPoseVerdict | None]:
        """Up to three batched calls — the nominal world, the perturbed worlds, the second decomposition — into one
        :class:`ImaginedWorlds`, the provider's stage 7 on the nominal world, and the poses' verdicts
        (``result.pose_verdicts``, judged after the perturbed worlds and again with the second decomposition)."""
        timings = result.timings
        agents = agent_setup(profile.agent.mjcf, profile.layout)
        result.agent_offsets = agents.offsets.tolist()
        pose_list = cast(Sequence[StablePose], poses)  # StablePoses reads as a sequence of StablePose
        evidence = ImaginedWorlds(
            affordance=profile.affordance, scale=profile.scale, plans=profile.plans.plans, poses=pose_list, kept=kept,
            trajectories=[trajectory_array(profile.trajectories.trajectories, poses[i].half_extents, poses[i].basin)
                          for i in kept],
            perturbations=draw_perturbations(self.config.imagination))
        t, cpu = time.perf_counter(), time.process_time()
        outcomes = imagine(obj, [poses[i] for i in kept], agents, evidence.trajectories, backend=self.backend,
                           config=self.config.imagination)
        timings["imagination"] = time.perf_counter() - t
        # CPU seconds of every thread of this process: what the batch cost, however loaded the machine was
        timings["imagination_cpu"] = time.process_time() - cpu
        t = time.perf_counter()
        scorer = self.scorer(profile.scoring.source)
        nominal = evidence.add_nominal(outcomes, scorer(outcomes))  # a blown-up rollout scores -1
        timings["scoring"] = time.perf_counter() - t
        n_plans = evidence.n_plans
        grid = np.full((len(poses), n_plans), -1.0)
        grid[kept] = nominal.scores.reshape(len(kept), n_plans)
        result.scores = grid.tolist()
        # Without the analyser: the best-scoring successful rollout decides (Table 2 ablation).
        best_b = int(np.argmax(nominal.scores))
        result.evidence_pose = kept[pose_plan(best_b, n_plans)[0]]
        result.evidence_agent_pos = nominal.outcomes.agent_pos[best_b].tolist()
        if nominal.scores[best_b] > 0:
            result.pose_without_analyzer = result.stable_poses[kept[pose_plan(best_b, n_plans)[0]]]

        # stage 7 reads the nominal world alone; its veto (a model's) is physics 0 whatever the perturbed worlds show
        t = time.perf_counter()
        veto = self.provider_name != "offline"  # a model's common sense; the offline answer is the rules' own
        # a model also gets the shape facts it cannot read from the numbers; the rules read the physics alone
        shapes = self._shapes(obj, poses) if veto else None
        request = llm.functional_pose_request(profile, evidence.candidates(nominal),
                                              *_shape_facts(shapes, obj.oriented))
        pictures = (stage7_pictures(obj, profile.agent.mjcf, poses, evidence, request)
                    if request is not None and veto and self.provider.sees_pictures else [])
        stage7 = None if request is None else llm.analyze_functional_poses(request, self.provider, pictures)
        vetoed = {v.pose_index for v in stage7.poses if not v.accept} if veto and stage7 is not None else set()
        sizes = profile.analysis.sizes

        def verdicts() -> None:
            result.pose_verdicts = judge(evidence, obj.obb_dims, stage7, llm_veto=veto, sizes=sizes, design=design)

        verdicts()
        timings["functional_pose_analyzer"] = time.perf_counter() - t
        slots = [k for k in candidate_slots(nominal.scores, len(kept), n_plans, [priors[i].value for i in kept])
                 if kept[k] not in vetoed]
        upper = [priors[i].value for i in kept]
        self._perturbed_worlds(obj, poses, agents, evidence, row, slots, upper, scorer, verdicts, result)
        # the second decomposition: one more world for the poses whose verdict it could still change
        open_slots = undecided(result.pose_verdicts, slots) if self._decomposition_matters(row) else []
        if open_slots:
            t = time.perf_counter()
            second = self._second_decomposition(obj)
            rollouts = imagine(second, [resting_on(poses[kept[k]], obj.hulls, second.hulls) for k in open_slots],
                               agents, [evidence.trajectories[k] for k in open_slots], backend=self.backend,
                               config=self.config.imagination)
            evidence.add_second_decomposition(rollouts, scorer(rollouts), open_slots)
            verdicts()
            timings["second_decomposition"] = time.perf_counter() - t
            # where it left a second pose that can pass, the poses that can go on to the last perturbed world
            self._perturbed_worlds(obj, poses, agents, evidence, row, slots, upper, scorer, verdicts, result)
        return evidence, stage7

    def _perturbed_worlds(self, obj: RailObject, poses: StablePoses, agents: AgentSetup, evidence: ImaginedWorlds,
                          row: Affordance | None, slots: list[int], upper: list[float], scorer: ScoringFunction,
                          verdicts: Callable[[], None], result: AffordanceResult) -> None:
        """The perturbed worlds, a few at a time: each candidate plan (:meth:`ImaginedWorlds.candidate_plans`)
        again in each pose of the ``slots`` whose verdict the worlds left could still change
        (:func:`~rail_mj.pipeline.verdicts.next_worlds`; ``upper``: each imagined pose's prior without a rest
        prior), each group of poses and worlds in one batched call, ``verdicts()`` judged again after each round;
        their seconds added to the result's timings (called again after the second decomposition)."""
        perturbed = evidence.perturbations.perturbed
        if perturbed is None:
            return
        t, cpu = time.perf_counter(), time.process_time()
        names = evidence.plan_names
        read = {names.index(p) for p in (kind_of(row).evidence_plans(row, names) if row is not None else ())}
        # the most worlds a pose is imagined in: the nominal one, each perturbed one and the second decomposition
        most = evidence.perturbations.n_worlds + self._decomposition_matters(row)
        prior_final = row is None or row.envelope.rest == ANY  # a rest prior moves with each world's rest height
        while groups := next_worlds(result.pose_verdicts, slots, upper, most, perturbed.n_worlds, prior_final):
            for group, first, n in groups:
                pairs = evidence.candidate_plans(group, read)
                rollouts = imagine(obj, [poses[evidence.kept[k]] for k, _ in pairs], agents,
                                   [[evidence.trajectories[k][j]] for k, j in pairs], backend=self.backend,
                                   config=self.config.imagination,
                                   perturbations=PerturbationSet(evidence.perturbations.worlds[first : first + n]))
                evidence.add_perturbed(rollouts, scorer(rollouts), pairs, group, first=first)
            verdicts()
        timings = result.timings
        timings["perturbed_worlds"] = timings.get("perturbed_worlds", 0.0) + time.perf_counter() - t
        # CPU seconds of every thread of this process: what the batches cost, however loaded the machine was
        timings["perturbed_worlds_cpu"] = timings.get("perturbed_worlds_cpu", 0.0) + time.process_time() - cpu

    def _pick(self, result: AffordanceResult, profile: ImaginationProfile, evidence: ImaginedWorlds,
              stage7: FunctionalPoseVerdict | None, common: float = 1.0) -> None:
        """The use's probability (its likeliest pose's) and, when functional, its functional pose and best plan
        (``common``: the factor every pose carries alike, :func:`most_probable`)."""
        best = most_probable(result.pose_verdicts, evidence.poses, None if stage7 is None else stage7.best_pose,
                             common)
        if best is None:
            return
        result.probability = max(v.probability for v in result.pose_verdicts)
        result.prior = best.prior_factors
        if result.probability < FUNCTIONAL or best.best_plan is None:
            return
        plan_idx = result.plans.index(best.best_plan)
        b = evidence.nominal_rollout(best.index, plan_idx)
        plan = profile.plans.plans[plan_idx]
        result.functional = True
        result.functional_pose = result.stable_poses[best.index]
        result.best_plan = PlanInfo(
            index=plan_idx,
            name=plan.name,
            description=plan.description,
            via_poses=evidence.trajectories[evidence.slot_of(best.index)][plan_idx].tolist(),
            score=float(evidence.nominal.scores[b]),
        )
        result.evidence_pose = best.index
        result.evidence_agent_pos = evidence.nominal.outcomes.agent_pos[b].tolist()

    def classify_object(
        self, item: ObjectInput | RailObject | str | Path, affordances: Sequence[str]
    ) -> list[AffordanceResult]:
        """All requested affordances of one object; errors become error results."""
        self.check_affordances(affordances)
        name = item.name if isinstance(item, RailObject) else str(getattr(item, "path", item))
        try:
            t = time.perf_counter()
            obj = self.load(item)
            t_load = time.perf_counter() - t
            t = time.perf_counter()
            poses = self.stable_poses(obj)
            t_poses = time.perf_counter() - t
        except RailError as exc:
            return [self._error(name, a, exc) for a in affordances]
        notes = mesh_notes(obj.mesh)
        results = []
        for a in affordances:
            calls, repairs = self.provider.calls.copy(), self.provider.repairs.copy()
            try:
                r = self.run(obj, poses, a)
            except RailError as exc:
                r = self._error(obj.name, a, exc)
            r.llm_calls = dict(self.provider.calls - calls)
            r.llm_repairs = dict(self.provider.repairs - repairs)
            r.timings = {"load": t_load, "stable_poses": t_poses, **r.timings}
            r.mesh_notes = notes
            results.append(r)
        return results

    def _definition(self, affordance: str) -> tuple[str | None, str | None, str | None]:
        """A result's words on how the provider defined ``affordance`` (stage 0), its row as a file and its proof
        on its prototypes."""
        defined = next((d for d in self.config.definitions if d.name == affordance.strip()), None)
        if defined is None:
            return None, None, None
        row = rules_row(defined.name) if defined.row_toml else None
        words = (f"{defined.by} defined it as a row of the {row.kind} kind, imagined with that kind's tested "
                 f"physics: {defined.reason}" if row is not None else
                 f"{defined.by} found no kind that models it ({defined.reason}): its own profile (stages 1-6), "
                 f"written once for every object of the use")
        return words, definitions.file_text(defined), defined.profile_check

    def _error(self, name: str, affordance: str, exc: Exception) -> AffordanceResult:
        """A failed case: no check ran, so ``dims_fit`` stays None (never a passed check)."""
        words, toml, check = self._definition(affordance)
        return AffordanceResult(
            definition=words,
            definition_toml=toml,
            profile_check=check,
            object=name,
            affordance=affordance,
            requested=affordance,
            dims_fit=None,
            error=f"{type(exc).__name__}: {exc}",
            provider=self.provider_name,
            backend=self.backend,
        )


def classify(
    objects: Iterable[ObjectInput | RailObject | str | Path],
    affordances: Sequence[str],
    *,
    config: RunConfig | None = None,
    progress: bool | ProgressCallback = True,
    workers: int | None = None,
    executor: str = "local",
    ray_address: str | None = None,
) -> list[AffordanceResult]:
    """Classify every object for every requested affordance; results object-major, in input order.

    ``config`` (:class:`~rail_mj.pipeline.config.RunConfig`, default its defaults) holds every setting of the run:
    provider and backend, ``pose="as_placed"`` (each object imagined in the pose it stands in, the paper's
    real-robot test), the request's ``agent`` and ``owner`` (a doll's chair), ``affordances_files`` (their rows are
    registered before the names are checked, here and in every worker), ``profile_dir`` (profile folders in the
    paper authors' format, :mod:`rail_mj.profiles`) and each stage's config.

    ``progress`` is ``True`` for a progress bar, ``False`` for none, or a callback
    ``(done, total, result)`` called after each (object, affordance), as objects finish.
    Names no provider can imagine are refused (ConfigError, UnknownAffordanceError
    listing the known names) before any provider is set up or any mesh is read.

    Objects are spread over ``workers`` processes (None: every core; 1: this process), or run as
    Ray tasks with ``executor="ray"`` on the cluster at ``ray_address`` (None: a local Ray); see
    :mod:`rail_mj.pipeline.parallel`. A worker that crashes on an object gives error results for it. Each
    result is the same however the objects were spread.
    """
    _check_names(affordances)
    cfg = config or RunConfig()
    # set, not defaulted: a worker elsewhere has no $RAIL_MJ_PROFILE_DIR of this process
    cfg = cfg.model_copy(update={"profile_dir": cfg.profile_dir})
    pipe = Pipeline(cfg)
    pipe.check_affordances(affordances)
    cfg, defined = define_uses(affordances, pipe, cfg)
    task_cfg = cfg.model_copy(update={"provider": pipe.provider_name, "backend": pipe.backend})
    tasks = [object_task(i, item, affordances, task_cfg) for i, item in enumerate(objects)]
    total = len(tasks) * len(affordances)
    bar = None
    if progress is True:
        from tqdm.auto import tqdm

        bar = tqdm(total=total, unit="case", desc="rail_mj")
    per_object: list[list[AffordanceResult]] = [[] for _ in tasks]
    done = 0
    try:
        with closing(run_tasks(tasks, workers=workers, executor=executor, ray_address=ray_address)) as stream:
            for task, results in stream:
                per_object[task.index] = results
                for r in results:
                    done += 1
                    if bar is not None:
                        bar.update(1)
                    elif callable(progress):
                        progress(done, total, r)
    finally:
        if bar is not None:
            bar.close()
    results = [r for results in per_object for r in results]
    count = definition_counter(defined)
    for r in results:
        count(r)
    return results


def define_uses(affordances: Sequence[str], pipe: Pipeline, cfg: RunConfig) -> tuple[RunConfig, list[Definition]]:
    """Stage 0, once per run before any object, for each of ``affordances`` outside the registry (a row proven on
    its prototypes, or a profile for every object proven on its own): ``cfg`` with their definitions, which go to
    every worker, and the new ones; each written to ``cfg.save_affordance`` as soon as it is proven."""
    defined = definitions.define(affordances, pipe.provider, cfg, lambda a: pipe.profile_folder(a) is not None,
                                 _prototype_runner(cfg), _profile_runner(cfg), request_scale(cfg.agent, cfg.owner))
    if not defined:
        return cfg, []
    cfg = cfg.model_copy(update={"definitions": [*cfg.definitions, *defined]})
    if cfg.save_affordance is not None:  # proven: written before any object, so a long run's crash keeps them
        for path in definitions.save(defined, cfg.save_affordance):
            logger.info("wrote %s", path)
    return cfg, defined


def definition_counter(defined: Sequence[Definition]) -> Callable[[AffordanceResult], None]:
    """A function that adds each definition's requests (stage 0 and a profile's stages 1-6, sent once for the
    run) to the first result of its use that it is shown, in the order results come."""
    waiting = {d.name: d for d in defined}

    def count(r: AffordanceResult) -> None:
        d = waiting.pop(r.requested.strip(), None)
        if d is not None:
            r.llm_calls = dict(Counter(d.llm_calls) + Counter(r.llm_calls))
            r.llm_repairs = dict(Counter(d.llm_repairs) + Counter(r.llm_repairs))

    return count


def _prototype_runner(cfg: RunConfig) -> definitions.CaseRunner:
    """The physics a stage-0 row is proven with: the kind's profile and rules alone (the offline library, no model
    call), each prototype imagined as it stands."""
    proof = RunConfig(provider="offline", backend=cfg.backend, imagination=cfg.imagination)
    # a fresh Pipeline each time: a repaired row of the same name must not meet the last one's cached profile
    return lambda obj, name: Pipeline(proof).run(obj, as_placed_pose(obj), name)


def _profile_runner(cfg: RunConfig) -> definitions.ProfileRunner:
    """The physics a free-form profile is proven with: the profile itself, the generic rules for stage 7 (no model
    call), each prototype imagined as it stands; with what the simulation saw, plan by plan."""
    proof = RunConfig(provider="offline", backend=cfg.backend, imagination=cfg.imagination)

    def run(obj: RailObject, profile: ImaginationProfile) -> tuple[AffordanceResult, str]:
        result, evidence = Pipeline(proof).imagine_case(obj, as_placed_pose(obj), profile.affordance, profile)
        return result, definitions.plans_seen(result, evidence)

    return run


def _norm(name: str) -> str:
    """A use's name as its profile is looked up: lower case, words separated by one space."""
    return " ".join(name.lower().split())


def run_object(task: ObjectTask) -> str:
    """Classify one object; JSON ``{"results": [...]}``, or ``{"error": ...}`` when something other than a
    :class:`~rail_mj.core.errors.RailError` stopped it (those are per-case error results already).

    The task callable of :mod:`rail_mj.pipeline.parallel`. Every task builds a fresh Pipeline, so a result
    depends on the object and the settings only, never on the worker or on what ran before. A Pipeline reuses
    one profile across objects of similar size, and that reuse made a verdict depend on which object of a size
    bin it met first. Seeds are per object (``RunConfig.stable_poses.seed``), and MuJoCo's batch gives
    bit-identical states at any thread count.
    """
    try:
        results = Pipeline(task.config).classify_object(task.item, list(task.affordances))
    except Exception as exc:  # noqa: BLE001 - one object's unexpected failure is that object's error, not the run's
        return json.dumps({"error": f"{type(exc).__name__}: {exc}"})
    return json.dumps({"results": [r.model_dump(mode="json") for r in results]})


def object_task(index: int, item: Any, affordances: Sequence[str], config: RunConfig) -> ObjectTask:
    """A task that :func:`run_object` runs, labelled as :meth:`Pipeline.classify_object` names the object in its
    error results."""
    label = item.name if isinstance(item, RailObject) else str(getattr(item, "path", item))
    return ObjectTask(index=index, item=item, label=label, affordances=tuple(affordances), config=config,
                      run=run_object)
