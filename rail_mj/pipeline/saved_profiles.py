"""``--save-profile``: the profile a run imagined a use with, written as a profile folder in the paper authors'
format (:func:`rail_mj.profiles.save_profile`) for ``--profile-dir`` to read back, by every command that imagines.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from rail_mj.core.errors import RailError
from rail_mj.core.results import AffordanceResult
from rail_mj.pipeline.chain import Pipeline
from rail_mj.pipeline.config import RunConfig
from rail_mj.profiles import save_profile

__all__ = ["save_profiles"]


def save_profiles(folder: Path, cases: Sequence[tuple[AffordanceResult, Sequence[float] | np.ndarray]],
                  config: RunConfig) -> bool:
    """Write the profile of each ``(result, its object's OBB dims)`` as ``folder/<affordance>/``, its via-points for
    the pose shown (the functional one, else the best-scoring one), the first case of each affordance only; print
    what was written to stderr. False when one could not be written (its error printed); failed cases are skipped.
    """
    done = [(r, dims) for r, dims in cases if not r.error]
    if not done:
        print(f"no profile written to {folder}: every case failed", file=sys.stderr)
        return True
    pipe = Pipeline(config.model_copy(update={"provider": done[0][0].provider}))
    ok, seen = True, set()
    for r, dims in done:
        if r.affordance in seen:
            continue
        seen.add(r.affordance)
        pose = r.functional_pose or (r.stable_poses[r.evidence_pose] if r.evidence_pose is not None else None)
        try:
            path = save_profile(pipe.profile(r.requested, dims), folder / r.affordance.replace(" ", "_"),
                                half_extents=pose.half_extents if pose is not None else None,
                                origin=config.profile_origin)
        except RailError as exc:  # e.g. an agent shape URDF lacks: that profile is not written, the rest are
            print(f"error: {r.object}: {r.requested!r}: no profile written: {exc}", file=sys.stderr)
            ok = False
            continue
        print(f"wrote {path}", file=sys.stderr)
    return ok
