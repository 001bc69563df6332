"""Stage 0 in a run: each use outside the registry defined once, as a row of a tested kind where one fits.

:func:`define` asks the provider (stage 0, :func:`rail_mj.llm.define_affordance`) for every requested name that
neither the registry, the run's affordance files nor a profile folder knows, once per run and before any object;
the answers travel to every worker in ``RunConfig.definitions`` and :func:`register` registers their rows there.
A use defined as a row is then imagined like any registered row: the kind's agent, plans and scoring (stages 1-6
from the kind, no model call) and the kind's pose rules; only stage 7 asks the model.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from rail_mj import llm
from rail_mj.affordances.registry import load_text
from rail_mj.core.errors import UnknownAffordanceError
from rail_mj.llm.schemas import DefinitionRequest
from rail_mj.pipeline.config import Definition, RunConfig

__all__ = ["define", "register", "source_of", "file_text"]


def source_of(d: Definition) -> str:
    """How a definition's row is named in errors and registry sources."""
    return f"{d.by}'s definition of {d.name!r}"


def file_text(d: Definition) -> str | None:
    """A defined row as an affordance file: where it came from and what its sizes rest on, as comments, then the
    row as the checks passed it; None without a row. ``--affordances-file`` loads it with no model."""
    if d.row_toml is None:
        return None
    head = [f"# {d.name!r}: defined by {d.by} (rail_mj stage 0); load it with --affordances-file, no model needed",
            f"# why this kind: {d.reason}", "# size basis:", *(f"#   - {line}" for line in d.size_basis)]
    return "\n".join(" ".join(line.split("\n")) for line in head) + "\n" + d.row_toml


def register(definitions: Sequence[Definition]) -> set[str]:
    """Register the rows of ``definitions`` in this process (again: a no-op); the names of their rows."""
    names: set[str] = set()
    for d in definitions:
        if d.row_toml is not None:
            names.update(row.name for row in load_text(d.row_toml, source_of(d)))
    return names


def define(affordances: Sequence[str], provider: llm.Provider, config: RunConfig,
           has_folder: Callable[[str], bool]) -> list[Definition]:
    """Stage 0 for each of ``affordances`` that no registered row, loaded file or profile folder (``has_folder``)
    imagines and that ``provider`` may imagine; its rows registered here. The others are left as they are (a name
    the provider cannot imagine was refused before, by :meth:`Pipeline.check_affordances`)."""
    if not provider.novel_affordances:
        return []
    out: list[Definition] = []
    known = {d.name for d in config.definitions}
    for name in dict.fromkeys(a.strip() for a in affordances):
        if name in known or has_folder(name) or _registered(name):
            continue
        # the row is for the use's own user (its scale field); a request's agent scales it later, as any row
        stage = "affordance_definition"
        calls, repairs = provider.calls[stage], provider.repairs[stage]
        answer = llm.define_affordance(DefinitionRequest(affordance=name), provider)
        d = Definition(name=name, row_toml=answer.row_toml, reason=answer.reason, size_basis=answer.size_basis,
                       by=f"{provider.name}:{provider.model}", llm_calls=provider.calls[stage] - calls,
                       llm_repairs=provider.repairs[stage] - repairs)
        register([d])
        out.append(d)
    return out


def _registered(name: str) -> bool:
    try:
        llm.normalize_affordance(name)
    except UnknownAffordanceError:
        return False
    return True
