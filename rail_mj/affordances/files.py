"""Affordance files: the registry rows a TOML file (or a package's entry point) defines, parsed and validated.

Registering the rows (the clash rule, ``override``) is :mod:`rail_mj.affordances.registry`'s; this module
only turns a file into rows, or says exactly what is wrong with it (:class:`AffordanceFileError`, naming
the file, the row, the field and what is valid). A file holds one ``[[affordance]]`` table per row::

    [[affordance]]
    name = "birdbath"               # canonical: lower case, words separated by one space
    aliases = ["bird bath"]         # optional; other names get() and the request parser accept
    kind = "container"              # a registered kind (rail_mj.affordances.kinds.KINDS)
    ibd = "A birdbath holds ..."    # the interaction-based definition
    largest = [0.3, 0.9]            # optional, m: typical range of the largest OBB dim, 0 < lo <= hi
    smallest = [0.05, 0.8]          # optional, m: of the smallest OBB dim (both are stage 1's size prior)
    override = false                # optional: true replaces the registered row its names clash with

    [affordance.envelope]           # optional: height, width, length, rest (m) and aspect (H / W),
    height = [0.03, 0.95]           # each [lo, hi] with 0 <= lo <= hi (hi may be inf); left out: any
    aspect = [0.0, 1.0]             # typical ranges: priors, never vetoes (rail_mj.affordances.prior)
    widths = {height = 0.25}        # optional: a quantity's prior width, if not the default one

    [affordance.params]             # optional: the kind's own fields (Kind.params_model), nested tables
    holds_water = true              # for nested models (a container's [affordance.params.droplets])

Installed packages add rows through the entry-point group :data:`ENTRY_POINT_GROUP`: an entry point names
an object (``module:attr``) that is a callable returning, or itself is, an affordance file's path, an
:class:`~rail_mj.affordances.row.Affordance`, or a list of these (see :func:`entry_point_rows`).
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import json
import math
import os
import re
import tomllib
import typing
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rail_mj.affordances.envelope import ANY, Envelope, Range
from rail_mj.affordances.kinds import KINDS
from rail_mj.affordances.row import Affordance
from rail_mj.core.errors import AffordanceFileError, ConfigError

__all__ = ["ENTRY_POINT_GROUP", "FIELDS", "FileRow", "parse", "read", "entry_point_rows", "row_toml"]

#: The entry-point group through which installed packages register affordances.
ENTRY_POINT_GROUP = "rail_mj.affordances"
_REQUIRED = ("name", "kind", "ibd")
#: Every key an ``[[affordance]]`` table may have.
FIELDS = (*_REQUIRED, "largest", "smallest", "aliases", "envelope", "params", "override", "scale")
_ENVELOPE = tuple(f.name for f in dataclasses.fields(Envelope) if f.name != "widths")


@dataclass(frozen=True)
class FileRow:
    """One row a file defines, and whether it may replace the registered rows its names clash with."""

    row: Affordance
    override: bool = False


class _Where:
    """Where a problem is: the file, the row (its number, and its name once read)."""

    def __init__(self, source: str, index: int):
        self.source, self.index = source, index
        self.name: str | None = None

    def fail(self, field: str | None, message: str) -> AffordanceFileError:
        row = f"[[affordance]] #{self.index}" + (f" ({self.name!r})" if self.name else "")
        return AffordanceFileError(f"{self.source}: {row}: " + (f"{field}: " if field else "") + message)


def _canonical(text: str) -> str:
    return re.sub(r"[\s_\-]+", " ", text.strip().lower())


def _name(value: Any, where: _Where, field: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise where.fail(field, f"must be a non-empty string; got {value!r}")
    if _canonical(value) != value:
        raise where.fail(field, f"{value!r} is not canonical: write {_canonical(value)!r} (lower case, words "
                                "separated by one space)")
    return value


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and not math.isnan(value)


def _size_range(value: Any, where: _Where, field: str) -> Range:
    """A stage-1 size range, m: [lo, hi], 0 < lo <= hi, both finite."""
    if not (isinstance(value, list) and len(value) == 2 and all(_number(v) for v in value)
            and 0 < value[0] <= value[1] < math.inf):
        raise where.fail(field, f"must be [lo, hi] in metres with 0 < lo <= hi, both finite; got {value!r}")
    return float(value[0]), float(value[1])


def _envelope(value: Any, where: _Where) -> Envelope:
    if not isinstance(value, dict):
        raise where.fail("envelope", f"must be a table ([affordance.envelope]); got {value!r}")
    unknown = sorted(set(value) - {*_ENVELOPE, "widths"})
    if unknown:
        raise where.fail("envelope", f"unknown key {', '.join(map(repr, unknown))}; valid: "
                                     f"{', '.join(_ENVELOPE)}, widths")
    widths = value.get("widths", {})
    if not isinstance(widths, dict):
        raise where.fail("envelope.widths", f"must be a table of quantity = width; got {widths!r}")
    ranges = {}
    for key, r in value.items():
        if key == "widths":
            continue
        if not (isinstance(r, list) and len(r) == 2 and all(_number(v) for v in r) and 0 <= r[0] <= r[1]):
            raise where.fail(f"envelope.{key}", f"must be [lo, hi] with 0 <= lo <= hi (hi may be inf); got {r!r}")
        ranges[key] = (float(r[0]), float(r[1]))
    try:
        return Envelope(**{key: ranges.get(key, ANY) for key in _ENVELOPE}, widths=tuple(widths.items()))
    except ConfigError as exc:
        raise where.fail("envelope.widths", str(exc)) from None


def _field_value(kind: Any, value: Any, where: _Where, field: str) -> Any:
    """A params field's value checked against its annotated type (a number is >= 0: sizes and counts)."""
    if isinstance(kind, type) and dataclasses.is_dataclass(kind):
        return _model(kind, value, where, field)
    if kind is bool and isinstance(value, bool):
        return value
    if kind is int and isinstance(value, int) and not isinstance(value, bool) and value >= 0:
        return value
    if kind is float and _number(value) and value >= 0:
        return float(value)
    if kind is str and isinstance(value, str):
        return value
    what = {bool: "true or false", int: "a whole number >= 0", float: "a number >= 0 (inf allowed)",
            str: "a string"}.get(kind, str(kind))
    raise where.fail(field, f"must be {what}; got {value!r}")


def _model(model: type, value: Any, where: _Where, field: str) -> Any:
    """An instance of a (frozen dataclass) parameter model from a TOML table, every key checked."""
    if not isinstance(value, dict):
        raise where.fail(field, f"must be a table; got {value!r}")
    fields = [f.name for f in dataclasses.fields(model)]
    unknown = sorted(set(value) - set(fields))
    if unknown:
        valid = ", ".join(fields) if fields else "none (this kind has no parameters)"
        raise where.fail(field, f"unknown key {', '.join(map(repr, unknown))} for {model.__name__}; valid: {valid}")
    hints = typing.get_type_hints(model)
    return model(**{k: _field_value(hints[k], v, where, f"{field}.{k}") for k, v in value.items()})


def _row(table: Any, where: _Where) -> FileRow:
    if not isinstance(table, dict):
        raise where.fail(None, f"must be a table; got {table!r}")
    if "name" in table:
        where.name = _name(table["name"], where, "name")
    unknown = sorted(set(table) - set(FIELDS))
    if unknown:
        raise where.fail(None, f"unknown key {', '.join(map(repr, unknown))}; valid: {', '.join(FIELDS)}")
    missing = [k for k in _REQUIRED if k not in table]
    if missing:
        raise where.fail(None, f"missing {', '.join(missing)} (required: {', '.join(_REQUIRED)})")
    kind = table["kind"]
    if kind not in KINDS:
        raise where.fail("kind", f"unknown kind {kind!r}; valid: {', '.join(sorted(KINDS))}")
    if not isinstance(table["ibd"], str) or not table["ibd"].strip():
        raise where.fail("ibd", f"must be a non-empty string (the interaction-based definition); got "
                                f"{table['ibd']!r}")
    aliases = table.get("aliases", [])
    if not isinstance(aliases, list):
        raise where.fail("aliases", f"must be a list of names; got {aliases!r}")
    aliases = [_name(a, where, "aliases") for a in aliases]
    if len({where.name, *aliases}) != 1 + len(aliases):
        raise where.fail("aliases", f"repeat a name: {[where.name, *aliases]}")
    override = table.get("override", False)
    if not isinstance(override, bool):
        raise where.fail("override", f"must be true or false; got {override!r}")
    params = _model(KINDS[kind].params_model, table.get("params", {}), where, "params")
    scale = table.get("scale", 1.0)
    if not (_number(scale) and 0 < scale < math.inf):
        raise where.fail("scale", f"must be a positive finite number (the row's agent against a person's size: a "
                                  f"doll 0.18); got {scale!r}")
    return FileRow(Affordance(
        table["name"], kind, table["ibd"].strip(),
        *(_size_range(table[k], where, k) if k in table else ANY for k in ("largest", "smallest")),
        envelope=_envelope(table.get("envelope", {}), where),
        aliases=tuple(aliases), params=params, scale=float(scale),
    ), override)


def parse(text: str, source: str) -> list[FileRow]:
    """The rows of an affordance file's text; ``source`` names the file in errors."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise AffordanceFileError(f"{source}: not valid TOML: {exc}") from None
    unknown = sorted(set(data) - {"affordance"})
    if unknown:
        raise AffordanceFileError(f"{source}: unknown top-level key {', '.join(map(repr, unknown))}; an "
                                  "affordance file holds only [[affordance]] tables")
    tables = data.get("affordance")
    if isinstance(tables, dict):
        raise AffordanceFileError(f"{source}: write each row as [[affordance]] (an array of tables), not "
                                  "[affordance]")
    if not tables:
        raise AffordanceFileError(f"{source}: defines no affordance; add an [[affordance]] table")
    return [_row(table, _Where(source, i)) for i, table in enumerate(tables, 1)]


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string takes JSON's escapes
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"no TOML value for {value!r}")


def _toml_table(header: str, table: dict[str, Any]) -> list[str]:
    """``[header]`` and its keys, then its nested tables, each under its dotted header."""
    lines = [f"[{header}]"] + [f"{k} = {_toml_value(v)}" for k, v in table.items() if not isinstance(v, dict)]
    for k, v in table.items():
        if isinstance(v, dict) and v:
            lines += ["", *_toml_table(f"{header}.{k}", v)]
    return lines


def _changed(params: Any) -> dict[str, Any]:
    """A (frozen dataclass) parameter model's fields that differ from their defaults, nested models as tables."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(params):
        value, default = getattr(params, f.name), f.default
        if value == default:
            continue
        out[f.name] = _changed(value) if dataclasses.is_dataclass(value) else value
    return out


def row_toml(row: Affordance) -> str:
    """``row`` as one ``[[affordance]]`` table of an affordance file: :func:`parse` reads it back to the same row
    (the kind's params only where they differ from the kind's defaults)."""
    top: dict[str, Any] = {"name": row.name, "aliases": list(row.aliases), "kind": row.kind, "ibd": row.ibd}
    if row.scale != 1.0:
        top["scale"] = row.scale
    for key in ("largest", "smallest"):
        if getattr(row, key) != ANY:
            top[key] = list(getattr(row, key))
    if not row.aliases:
        del top["aliases"]
    lines = ["[[affordance]]"] + [f"{k} = {_toml_value(v)}" for k, v in top.items()]
    ranges = {name: list(getattr(row.envelope, name)) for name in _ENVELOPE if getattr(row.envelope, name) != ANY}
    if ranges or row.envelope.widths:
        lines += ["", "[affordance.envelope]"] + [f"{k} = {_toml_value(v)}" for k, v in ranges.items()]
        if row.envelope.widths:
            widths = ", ".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in row.envelope.widths)
            lines.append(f"widths = {{{widths}}}")
    params = _changed(row.params)
    if params:
        lines += ["", *_toml_table("affordance.params", params)]
    return "\n".join(lines) + "\n"


def read(path: str | os.PathLike[str]) -> list[FileRow]:
    """The rows of the affordance file at ``path`` (see the module's doc)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise AffordanceFileError(f"{path}: cannot read the affordance file: {exc}") from None
    return parse(text, str(path))


def _plugin_rows(value: Any, source: str) -> list[FileRow]:
    items: Iterable[Any] = [value] if isinstance(value, (str, os.PathLike, Affordance)) else value
    rows: list[FileRow] = []
    try:
        items = list(items)
    except TypeError:
        items = [value]
    for item in items:
        if isinstance(item, Affordance):
            rows.append(FileRow(item))
        elif isinstance(item, (str, os.PathLike)):
            try:
                rows.extend(read(item))
            except AffordanceFileError as exc:
                raise AffordanceFileError(f"{source}: {exc}") from None
        else:
            raise AffordanceFileError(f"{source}: gave a {type(item).__name__}; an entry point gives affordance "
                                      "file paths or Affordance rows (or a callable returning them)")
    return rows


def entry_point_rows() -> list[tuple[str, list[FileRow]]]:
    """(source, rows) of every installed entry point of :data:`ENTRY_POINT_GROUP`, in discovery order.

    An entry point names an object (``module:attr``); a callable is called with no arguments. The object (or
    what the call returns) is an affordance file's path, an Affordance row, or a list of these; a file's rows
    may set ``override``, a row object never overrides. Anything else, a failed import or call, and a malformed
    file are an :class:`AffordanceFileError` naming the entry point and its distribution.
    """
    found = []
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        dist = getattr(ep, "dist", None)
        source = (f"entry point {ep.name!r} ({ep.value}) of the distribution "
                  f"{dist.name if dist is not None else 'unknown'!r}")
        try:
            value = ep.load()
            if callable(value) and not isinstance(value, type):
                value = value()
        except Exception as exc:  # noqa: BLE001 - a plugin's failure, whatever it is, is reported as the plugin's
            raise AffordanceFileError(f"{source}: failed: {type(exc).__name__}: {exc}") from exc
        found.append((source, _plugin_rows(value, source)))
    return found
