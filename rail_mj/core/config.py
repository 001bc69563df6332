"""The one way a config says what was wrong: a pydantic validation error as the project's ConfigError.

Every config is a pydantic model whose fields declare their ranges once (``Field(ge=..., le=...)``);
:func:`config_error` reads those declarations back to name, for each bad field, the valid range.
"""

from __future__ import annotations

from typing import Any, get_args

from annotated_types import Ge, Gt, Le, Lt
from pydantic import BaseModel, ValidationError

from rail_mj.core.errors import ConfigError

__all__ = ["valid_range", "config_error"]


def valid_range(model: type[BaseModel], name: str) -> str:
    """``a whole number in [0, 32]``, ``a number > 0``: what field ``name`` of ``model`` takes, from its
    declaration."""
    info = model.model_fields[name]
    args = set(get_args(info.annotation)) or {info.annotation}
    kind = ("True or False" if bool in args else "a whole number" if int in args else "a number" if float in args
            else "a value")
    if type(None) in args:
        kind = f"None or {kind}"
    lo = hi = None
    lo_open = hi_open = False
    for m in info.metadata:
        if isinstance(m, Ge):
            lo = m.ge
        elif isinstance(m, Gt):
            lo, lo_open = m.gt, True
        elif isinstance(m, Le):
            hi = m.le
        elif isinstance(m, Lt):
            hi, hi_open = m.lt, True
    if lo is not None and hi is not None:
        return f"{kind} in {'(' if lo_open else '['}{lo}, {hi}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{kind} {'>' if lo_open else '>='} {lo}"
    if hi is not None:
        return f"{kind} {'<' if hi_open else '<='} {hi}"
    return kind


def config_error(model: type[BaseModel], exc: ValidationError) -> ConfigError:
    """``exc`` as a ConfigError: ``Model.field must be <its declared range>; got <value>`` for each bad field."""
    lines = []
    for e in exc.errors():
        name = str(e["loc"][0]) if e["loc"] else ""
        value: Any = e.get("input")
        if name in model.model_fields and e["type"] == "value_error":  # a validator's own words
            lines.append(f"{model.__name__}.{name} {str(e['msg']).removeprefix('Value error, ')}; got {value!r}")
        elif name in model.model_fields:
            lines.append(f"{model.__name__}.{name} must be {valid_range(model, name)}; got {value!r}")
        else:
            lines.append(f"{model.__name__}: {e['msg']} ({'.'.join(map(str, e['loc']))})")
    return ConfigError("; ".join(lines))
