"""Stage 7's pictures: each pose of the request with its best plan's end state in the nominal world, for a model
that sees them (:attr:`rail_mj.llm.Provider.sees_pictures`). The offline rules read the physics alone."""

from __future__ import annotations

import numpy as np

from rail_mj.core.errors import RailError
from rail_mj.core.types import RailObject, StablePoses
from rail_mj.imagination.worlds import ImaginedWorlds
from rail_mj.llm import FunctionalPoseRequest, Picture
from rail_mj.render.images import pose_picture

__all__ = ["stage7_pictures"]

_WHAT = ("the object drawn in brown shades (its convex parts as the physics used them), the agents in blue, the "
         "ground's checker squares 10 cm")


def stage7_pictures(obj: RailObject, fragment: str, poses: StablePoses, evidence: ImaginedWorlds,
                    request: FunctionalPoseRequest) -> list[Picture]:
    """One picture per pose of ``request``: the object resting in it with the agents where its best-scoring
    candidate plan left them. None at all where no offscreen renderer can be made (the request goes as text)."""
    world, names = evidence.nominal, evidence.plan_names
    pictures = []
    for p in request.poses:
        best = max(p.candidates, key=lambda c: c.score)
        b = evidence.nominal_rollout(p.pose_index, names.index(best.plan))
        pos, quat = world.outcomes.agent_pos[b], world.outcomes.agent_quat[b]
        try:
            png = pose_picture(obj, fragment, poses[p.pose_index], pos, quat)
        except RailError:
            return []
        mm = np.round(np.asarray(pos) * 1000).astype(int).tolist()  # the key: what is drawn, not its pixels
        pictures.append(Picture(
            caption=(f"Picture of pose {p.pose_index}: its plan {best.plan!r} at its end (score {best.score:.2f}); "
                     f"{_WHAT}."),
            png=png, drawn=f"pose {p.pose_index} plan {best.plan} agents (mm) {mm}"))
    return pictures
