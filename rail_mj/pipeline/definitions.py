"""Stage 0 in a run: each use outside the registry defined once, as a row of a tested kind where one fits.

:func:`define` asks the provider (stage 0, :func:`rail_mj.llm.define_affordance`) for every requested name that
neither the registry, the run's affordance files nor a profile folder knows, once per run and before any object;
the answers travel to every worker in ``RunConfig.definitions`` and :func:`register` registers their rows there.
A use defined as a row is then imagined like any registered row: the kind's agent, plans and scoring (stages 1-6
from the kind, no model call) and the kind's pose rules; only stage 7 asks the model.

Before a row is accepted it is proven (:func:`prover`): the answer's prototypes
(:mod:`rail_mj.affordances.prototypes`) are imagined as they stand with the row registered for the trial only, by
the kind's physics and rules alone; the positive must come out functional and the negative not. When one does not,
the answer goes back to the model with what the simulation saw, as any rejected answer does, for at most
``max_retries`` rounds; then the run stops with a StageError naming what failed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from rail_mj import llm
from rail_mj.affordances.files import FileRow
from rail_mj.affordances.judge import rules_row
from rail_mj.affordances.prototypes import build, describe
from rail_mj.affordances.registry import load_text, trial
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.llm.checks import InvalidAnswerError
from rail_mj.llm.schemas import AffordanceDefinition, DefinitionRequest
from rail_mj.pipeline.config import Definition, RunConfig

__all__ = ["define", "register", "source_of", "file_text", "prover", "CaseRunner"]

#: imagines one object for one use as it stands (the prover's physics): ``(object, use name) -> result``
CaseRunner = Callable[[RailObject, str], AffordanceResult]


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
        name, lines, failed = entry.row.name, [], []
        with trial([entry], f"the proof of {name!r}"):
            for i, p in enumerate(answer.prototypes):
                r = run_case(build(p, f"{p.role}_prototype_{i}"), name)
                want = p.role == "positive"
                ok = r.error is None and r.functional == want
                line = (f"{p.role} prototype {describe(p)}: {'functional' if r.functional else 'not functional'}, "
                        f"probability {r.probability:.2f}")
                lines.append(line)
                if not ok:
                    failed.append(f"{line}, but the {p.role} must{'' if want else ' not'} be functional. "
                                  f"{_seen(r)}")
        if failed:
            raise InvalidAnswerError("the row failed its proof on its prototypes (imagined as they stand with the "
                                     "kind's physics and rules): " + " | ".join(failed) + " Repair the row (its "
                                     "sizes, params or kind) or the prototypes.")
        proofs[answer.row_toml or ""] = "proven: " + "; ".join(lines)

    return prove


def _seen(r: AffordanceResult) -> str:
    """What the simulation saw of one prototype: the prior, each plan's score as placed, the rules' words."""
    if r.error is not None:
        return f"The case failed: {r.error}"
    scores = ", ".join(f"{plan} {s:.2f}" for plan, s in zip(r.plans, r.scores[0] if r.scores else []))
    reasons = "; ".join(reason[:400] for reason in r.analyzer_reasons[:4])
    return (f"Prior {r.prior or 'n/a'}. Scores per plan: {scores or 'none imagined'}. What the rules saw: "
            f"{reasons or 'nothing'}.")


def define(affordances: Sequence[str], provider: llm.Provider, config: RunConfig,
           has_folder: Callable[[str], bool], run_case: CaseRunner | None = None) -> list[Definition]:
    """Stage 0 for each of ``affordances`` that no registered row, loaded file or profile folder (``has_folder``)
    imagines and that ``provider`` may imagine; its rows, proven on their prototypes by ``run_case``, registered
    here. The others are left as they are (a name the provider cannot imagine was refused before, by
    :meth:`Pipeline.check_affordances`)."""
    if not provider.novel_affordances:
        return []
    out: list[Definition] = []
    known = {d.name for d in config.definitions}
    for name in dict.fromkeys(a.strip() for a in affordances):
        if name in known or has_folder(name) or rules_row(name) is not None:
            continue
        # the row is for the use's own user (its scale field); a request's agent scales it later, as any row
        stage = "affordance_definition"
        calls, repairs = provider.calls[stage], provider.repairs[stage]
        proofs: dict[str, str] = {}
        prove = prover(run_case, proofs) if run_case is not None else None
        answer = llm.define_affordance(DefinitionRequest(affordance=name), provider, prove)
        d = Definition(name=name, row_toml=answer.row_toml, reason=answer.reason, size_basis=answer.size_basis,
                       profile_check=proofs.get(answer.row_toml or "") if answer.row_toml else None,
                       by=f"{provider.name}:{provider.model}", llm_calls=provider.calls[stage] - calls,
                       llm_repairs=provider.repairs[stage] - repairs)
        register([d])
        out.append(d)
    return out
