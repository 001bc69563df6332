"""compile_scoring: checked, compiled scoring code that runs in the sandbox over whole batches."""

from __future__ import annotations

import hashlib
import marshal
import math

import numpy as np

from rail_mj.core.errors import ConfigError, UnsafeCodeError
from rail_mj.core.types import SCORING_ARGS, Outcomes
from rail_mj.scoring.pool import run_in_worker
from rail_mj.scoring.sandbox import SOURCE_FILENAME
from rail_mj.scoring.validate import check_source

__all__ = ["ScoringFunction", "compile_scoring", "MAX_TIMEOUT_S", "MIN_MEMORY_MB"]

MAX_TIMEOUT_S = 600.0
MIN_MEMORY_MB = 16


class ScoringFunction:
    """A generated ``score`` function, checked against the allow-list, run in a worker process.

    Call it with an :class:`~rail_mj.core.types.Outcomes` or with the arrays of
    :data:`~rail_mj.core.types.SCORING_ARGS` by name; it returns float64 scores of
    shape (B,) (success when > 0) or raises ``ScoringRuntimeError``. Each call
    may run ``timeout_s`` seconds of wall time and allocate at least ``memory_mb``
    MB (at most :data:`~rail_mj.scoring.pool.RESTING_SLACK_MB` more) beyond
    the worker's resting size and its inputs.
    """

    __slots__ = ("source", "timeout_s", "memory_mb", "digest", "_code")

    def __init__(self, source: str, *, timeout_s: float = 2.0, memory_mb: int = 1024) -> None:
        if not (isinstance(timeout_s, (int, float)) and math.isfinite(timeout_s) and 0 < timeout_s <= MAX_TIMEOUT_S):
            raise ConfigError(f"timeout_s must be a number in (0, {MAX_TIMEOUT_S}] seconds, got {timeout_s!r}")
        if not (isinstance(memory_mb, int) and memory_mb >= MIN_MEMORY_MB):
            raise ConfigError(f"memory_mb must be an int >= {MIN_MEMORY_MB}, got {memory_mb!r}")
        tree = check_source(source)
        try:
            code = compile(tree, SOURCE_FILENAME, "exec", dont_inherit=True)
        except (SyntaxError, ValueError, RecursionError, MemoryError) as exc:
            raise UnsafeCodeError(f"scoring source does not compile: {type(exc).__name__}: {exc}") from None
        self.source = source
        self.timeout_s = float(timeout_s)
        self.memory_mb = memory_mb
        self._code = marshal.dumps(code)
        self.digest = hashlib.sha256(self._code).hexdigest()

    def __repr__(self) -> str:
        return f"ScoringFunction(digest={self.digest[:12]}, timeout_s={self.timeout_s}, memory_mb={self.memory_mb})"

    def __call__(self, outcomes: Outcomes | None = None, **arrays: np.ndarray) -> np.ndarray:
        named = _scoring_arrays(outcomes, arrays)
        batch = named["agent_pos"].shape[0]
        if batch == 0:
            return np.zeros(0, dtype=np.float64)
        return run_in_worker(self._code, self.digest, named, batch, self.timeout_s, self.memory_mb)


def _scoring_arrays(outcomes: Outcomes | None, arrays: dict) -> dict[str, np.ndarray]:
    """The SCORING_ARGS arrays, contiguous, numeric, all with the same leading batch axis."""
    if outcomes is not None:
        if arrays:
            raise ConfigError(f"pass either an Outcomes or the arrays by name, not both (got also {sorted(arrays)})")
        if not isinstance(outcomes, Outcomes):
            raise ConfigError(f"outcomes must be rail_mj.core.types.Outcomes, got {type(outcomes).__name__}")
        arrays = outcomes.scoring_kwargs()
    missing = [n for n in SCORING_ARGS if n not in arrays]
    unknown = sorted(set(arrays) - set(SCORING_ARGS))
    if missing or unknown:
        raise ConfigError(f"scoring arrays must be exactly {', '.join(SCORING_ARGS)}; "
                          f"missing {missing or 'none'}, unknown {unknown or 'none'}")
    named = {}
    for name in SCORING_ARGS:
        arr = np.ascontiguousarray(arrays[name])
        if arr.dtype.kind not in "biuf":
            raise ConfigError(f"scoring array {name!r} must be bool, int or float, got dtype {arr.dtype}")
        if arr.ndim == 0:
            raise ConfigError(f"scoring array {name!r} must have a leading batch axis, got a scalar")
        named[name] = arr.astype(arr.dtype.newbyteorder("="), copy=False)
    batch = named["agent_pos"].shape[0]
    wrong = {n: a.shape for n, a in named.items() if a.shape[0] != batch}
    if wrong:
        raise ConfigError(f"every scoring array must have batch size {batch} (from agent_pos) first; got {wrong}")
    return named


def compile_scoring(source: str, *, timeout_s: float = 2.0, memory_mb: int = 1024) -> ScoringFunction:
    """Check ``source`` against the allow-list and compile it (UnsafeCodeError names line and construct)."""
    return ScoringFunction(source, timeout_s=timeout_s, memory_mb=memory_mb)
