"""Model-written affordances in a run: each use outside the registry defined once (stage 0), as a row of a tested
kind where one fits, else as one free-form profile for every object of the use; either proven on prototypes first.

:func:`define` asks the provider (stage 0, :func:`rail_mj.llm.define_affordance`) for every requested name that
neither the registry, the run's affordance files nor a profile folder knows, once per run and before any object;
the answers travel to every worker in ``RunConfig.definitions`` and :func:`register` registers their rows there.
A use defined as a row is then imagined like any registered row: the kind's agent, plans and scoring (stages 1-6
from the kind, no model call) and the kind's pose rules; only stage 7 asks the model.

A use no kind models gets its own profile (:func:`write_profile`): stages 1-6 once for the run, for a task of no
object dims (:func:`rail_mj.llm.use_task`), so the same profile serves every object: its positions are relative
to each object's half extents and opening, and its stage 1 gives the use's typical sizes, the prior each object is
weighed by (:class:`rail_mj.affordances.sizes.UseSizes`).

Before a row or a profile is accepted it is proven: the answer's prototypes
(:mod:`rail_mj.affordances.prototypes`) are imagined as they stand, a row with its kind's physics and rules
(registered for the trial only, :func:`prover`), a profile with itself and the generic rules
(:func:`profile_prover`); the positive must come out functional and the negative not. When one does not, the
answer (the row, or the profile's scoring code) goes back to the model with what the simulation saw, as any
rejected answer does, for at most ``max_retries`` rounds; then the run stops with a StageError naming what failed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from rail_mj import llm
from rail_mj.affordances.files import FileRow
from rail_mj.affordances.judge import rules_row
from rail_mj.affordances.prototypes import Prototype, build, describe
from rail_mj.affordances.registry import load_text, trial
from rail_mj.core.results import AffordanceResult
from rail_mj.core.runfiles import atomic_write_text
from rail_mj.core.types import RailObject
from rail_mj.imagination.worlds import ImaginedWorlds
from rail_mj.llm.checks import InvalidAnswerError
from rail_mj.llm.schemas import AffordanceDefinition, DefinitionRequest, ImaginationProfile
from rail_mj.pipeline.config import Definition, RunConfig
from rail_mj.profiles import save_profile

__all__ = ["define", "register", "save", "file_stem", "source_of", "file_text", "prover", "profile_prover",
           "write_profile", "plans_seen", "CaseRunner", "ProfileRunner"]

#: imagines one object for one use as it stands (the prover's physics): ``(object, use name) -> result``
CaseRunner = Callable[[RailObject, str], AffordanceResult]
#: imagines one object as it stands with a profile: ``(object, profile) -> (result, what the simulation saw)``
ProfileRunner = Callable[[RailObject, ImaginationProfile], tuple[AffordanceResult, str]]


def source_of(d: Definition) -> str:
    """How a definition's row is named in errors and registry sources."""
    return f"{d.by}'s definition of {d.name!r}"


def file_text(d: Definition) -> str | None:
    """A defined row as an affordance file: where it came from and what its sizes rest on, as comments, then the
    row as the checks passed it; None without a row. ``--affordances-file`` loads it with no model."""
    if d.row_toml is None:
        return None
    head = [f"# {d.name!r}: defined by {d.by} (rail_mj stage 0); load it with --affordances-file, no model needed",
            f"# why this kind: {d.reason}", "# size basis:", *(f"#   - {line}" for line in d.size_basis),
            *([f"# {d.profile_check}"] if d.profile_check else [])]
    return "\n".join(" ".join(line.split("\n")) for line in head) + "\n" + d.row_toml


def file_stem(name: str) -> str:
    """A use's name as :func:`save` names its file or folder: ``fruit_bowl``."""
    return "_".join(name.lower().split())


def save(definitions: Sequence[Definition], folder: Path) -> list[Path]:
    """Write each definition in ``folder``: a row as ``<use>.toml`` (:func:`file_text`), a profile as the profile
    folder ``<use>/`` (:func:`rail_mj.profiles.save_profile`, its via-points for the positive prototype) with
    ``definition.txt`` (who wrote it, why no kind, its proof); the paths written."""
    written = []
    for d in definitions:
        stem = file_stem(d.name)
        text = file_text(d)
        if text is not None:
            folder.mkdir(parents=True, exist_ok=True)
            atomic_write_text(folder / f"{stem}.toml", text)
            written.append(folder / f"{stem}.toml")
        elif d.profile is not None:
            path = save_profile(d.profile, folder / stem)
            atomic_write_text(path / "definition.txt", f"{d.name!r}: written by {d.by} (rail_mj stages 1-6, one "
                              f"profile for every object of the use); load it with --profile-dir, no model needed\n"
                              f"why no kind: {d.reason}\n{d.profile_check or 'not proven'}\n")
            written.append(path)
    return written


def register(definitions: Sequence[Definition]) -> set[str]:
    """Register the rows of ``definitions`` in this process (again: a no-op); the names of their rows."""
    names: set[str] = set()
    for d in definitions:
        if d.row_toml is not None:
            names.update(row.name for row in load_text(d.row_toml, source_of(d)))
    return names


def prover(run_case: CaseRunner, proofs: dict[str, str]) -> Callable[[AffordanceDefinition, FileRow], None]:
    """The stage-0 check that imagines an answer's prototypes with its row (registered for the trial only):
    InvalidAnswerError with what the simulation saw when the positive is not functional or the negative is; the
    words of a passed proof go to ``proofs`` under the row's text."""

    def prove(answer: AffordanceDefinition, entry: FileRow) -> None:
        name = entry.row.name

        def run(obj: RailObject) -> tuple[AffordanceResult, str]:
            r = run_case(obj, name)
            return r, _seen(r)

        with trial([entry], f"the proof of {name!r}"):
            lines, failed = _try_prototypes(answer.prototypes, run)
        if failed:
            raise InvalidAnswerError("the row failed its proof on its prototypes (imagined as they stand with the "
                                     "kind's physics and rules): " + " | ".join(failed) + " Repair the row (its "
                                     "sizes, params or kind) or the prototypes.")
        proofs[answer.row_toml or ""] = "proven: " + "; ".join(lines)

    return prove


def profile_prover(run_profile: ProfileRunner, proofs: dict[str, str]) -> Callable[[ImaginationProfile], None]:
    """The check before a free-form profile's scoring code is accepted: its analysis's prototypes imagined as they
    stand with the whole profile; InvalidAnswerError with what the simulation saw, plan by plan, when the positive
    is not functional or the negative is; the words of a passed proof go to ``proofs`` under the scoring source."""

    def prove(profile: ImaginationProfile) -> None:
        lines, failed = _try_prototypes(profile.analysis.prototypes, lambda obj: run_profile(obj, profile))
        if failed:
            raise InvalidAnswerError("the profile failed its proof on its prototypes (each imagined as it stands "
                                     "with the whole profile, in the nominal and the perturbed worlds): "
                                     + " | ".join(failed) + " Repair the scoring code so that the positive's "
                                     "rollouts score > 0 and the negative's do not (the agent, layout and "
                                     "trajectories are fixed).")
        proofs[profile.scoring.source] = "proven: " + "; ".join(lines)

    return prove


def _try_prototypes(prototypes: Sequence[Prototype], run: Callable[[RailObject], tuple[AffordanceResult, str]]
                    ) -> tuple[list[str], list[str]]:
    """Each prototype built and imagined as it stands by ``run`` (its result and what the simulation saw): the
    words on each, and on each that failed (a positive not functional, a negative functional, or an error)."""
    lines, failed = [], []
    for i, p in enumerate(prototypes):
        r, seen = run(build(p, f"{p.role}_prototype_{i}"))
        want = p.role == "positive"
        line = (f"{p.role} prototype {describe(p)}: {'functional' if r.functional else 'not functional'}, "
                f"probability {r.probability:.2f}")
        lines.append(line)
        if r.error is not None or r.functional != want:
            failed.append(f"{line}, but the {p.role} must{'' if want else ' not'} be functional. {seen}")
    return lines, failed


def write_profile(name: str, provider: llm.Provider, scale: float,
                  run_profile: ProfileRunner | None) -> tuple[ImaginationProfile, str | None]:
    """Stages 1-6 once for a use no kind models: one profile for every object of it at the agent ``scale``,
    proven on its prototypes by ``run_profile`` (None: unproven); the profile and its proof in words."""
    proofs: dict[str, str] = {}
    prove = profile_prover(run_profile, proofs) if run_profile is not None else None
    profile = llm.task_profile(llm.use_task(name, scale=scale), provider, prove=prove)
    return profile, proofs.get(profile.scoring.source)


def plans_seen(r: AffordanceResult, evidence: ImaginedWorlds | None) -> str:
    """What the simulation saw of one prototype with a profile, plan by plan in its nominal world: the score,
    where the agents came to rest (inside the object's box, outside its footprint and how far, on the ground),
    contacts with the object and its tilt; then the worlds that passed and the rules' words."""
    if r.error is not None:
        return f"The case failed: {r.error}"
    if evidence is None:
        return f"Not imagined: {'; '.join(r.analyzer_reasons)[:400]} (prior {r.prior or 'n/a'})."
    out, pose = evidence.nominal.outcomes, evidence.kept[0]
    plans = []
    for j, name in enumerate(evidence.plan_names):
        b = evidence.nominal_rollout(pose, j)
        h, pos, n = out.object_half_extents[b], out.agent_pos[b], out.agent_pos.shape[1]
        inside = int(np.sum(np.all(np.abs(pos) < h, axis=1)))
        gap = np.linalg.norm(np.maximum(np.abs(pos[:, :2]) - h[:2], 0.0), axis=1)
        outside = int(np.sum(gap > 0))
        plans.append(f"{name}: score {float(evidence.nominal.scores[b]):.2f}; of {n} agents {inside} inside the box, "
                     f"{outside} outside its footprint (farthest {float(gap.max()):.2f} m from it), "
                     f"{int(np.sum(out.contacts_ground[b] > 0))} on the ground, "
                     f"{int(np.sum(out.contacts_object[b] > 0))} touching the object; mean height "
                     f"{float(np.mean(pos[:, 2]) / h[2]):.2f} h_z; object tilt "
                     f"{float(np.degrees(out.object_tilt[b])):.0f} deg")
    worlds = "; ".join(f"passed {v.successes} of {v.imagined} worlds" for v in r.pose_verdicts)
    reasons = "; ".join(reason[:300] for reason in r.analyzer_reasons[:3])
    return (f"Prior {r.prior or 'n/a'}. Per plan: " + " | ".join(plans) + f". {worlds or 'no world passed'}. "
            f"What the rules saw: {reasons or 'nothing'}.")


def _seen(r: AffordanceResult) -> str:
    """What the simulation saw of one prototype: the prior, each plan's score as placed, the rules' words."""
    if r.error is not None:
        return f"The case failed: {r.error}"
    scores = ", ".join(f"{plan} {s:.2f}" for plan, s in zip(r.plans, r.scores[0] if r.scores else []))
    reasons = "; ".join(reason[:400] for reason in r.analyzer_reasons[:4])
    return (f"Prior {r.prior or 'n/a'}. Scores per plan: {scores or 'none imagined'}. What the rules saw: "
            f"{reasons or 'nothing'}.")


def define(affordances: Sequence[str], provider: llm.Provider, config: RunConfig,
           has_folder: Callable[[str], bool], run_case: CaseRunner | None = None,
           run_profile: ProfileRunner | None = None, scale: float = 1.0) -> list[Definition]:
    """Stage 0 for each of ``affordances`` that no registered row, loaded file or profile folder (``has_folder``)
    imagines and that ``provider`` may imagine; its rows, proven on their prototypes by ``run_case``, registered
    here; a use no kind models gets its profile for every object at the agent ``scale``, proven by
    ``run_profile``. The others are left as they are (a name the provider cannot imagine was refused before, by
    :meth:`Pipeline.check_affordances`)."""
    if not provider.novel_affordances:
        return []
    out: list[Definition] = []
    known = {d.name for d in config.definitions}
    for name in dict.fromkeys(a.strip() for a in affordances):
        if name in known or has_folder(name) or rules_row(name) is not None:
            continue
        # the row is for the use's own user (its scale field); a request's agent scales it later, as any row
        calls, repairs = provider.calls.copy(), provider.repairs.copy()
        proofs: dict[str, str] = {}
        prove = prover(run_case, proofs) if run_case is not None else None
        answer = llm.define_affordance(DefinitionRequest(affordance=name), provider, prove)
        profile, check = None, proofs.get(answer.row_toml) if answer.row_toml else None
        if answer.row_toml is None:
            profile, check = write_profile(name, provider, scale, run_profile)
        d = Definition(name=name, row_toml=answer.row_toml, reason=answer.reason, size_basis=answer.size_basis,
                       profile=profile, profile_check=check, by=f"{provider.name}:{provider.model}",
                       llm_calls=dict(provider.calls - calls), llm_repairs=dict(provider.repairs - repairs))
        register([d])
        out.append(d)
    return out
