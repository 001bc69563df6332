"""Generated scoring code: allow-listed statically, run over whole batches in a sandboxed worker.

See :mod:`rail_mj.scoring.validate` for what source may contain,
:mod:`rail_mj.scoring.pool` / :mod:`rail_mj.scoring.sandbox` for the worker and
:mod:`rail_mj.scoring.probe` for the synthetic batch candidates are tried on.
"""

from rail_mj.scoring.function import ScoringFunction, compile_scoring
from rail_mj.scoring.pool import WorkerStartError, close_workers, warm_up, worker_count
from rail_mj.scoring.probe import probe_outcomes
from rail_mj.scoring.validate import RejectedCodeError, check_source, scoring_rules

__all__ = [
    "ScoringFunction",
    "compile_scoring",
    "check_source",
    "scoring_rules",
    "RejectedCodeError",
    "WorkerStartError",
    "probe_outcomes",
    "warm_up",
    "close_workers",
    "worker_count",
]
