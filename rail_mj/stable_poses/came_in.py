"""Which stable pose an object came in, and how likely another pose is the one it was made to stand in.

The physics tells whether a use works in a pose; it cannot tell whether the object was made for that use in that
pose (a shelf box lying on its back holds what is dropped in as a basket does). How the object came is evidence: a
mesh file, or an object a robot finds on a table, stands as it was made to stand or as it fell. With even odds
between the two (:data:`PLACED`), an object that came at rest in pose A, whose drops end in A with frequency
``p_A`` (:attr:`StablePose.probability`), was made to stand in another pose B rather than in A with probability

    P(B | came in A) = (1 - PLACED) p_A / (PLACED + 2 (1 - PLACED) p_A)  =  p_A / (1 + 2 p_A)

(the likelihood of coming in A is ``PLACED + (1 - PLACED) p_A`` if A is the pose it was made for, ``(1 - PLACED)
p_A`` if B is, and A and B are equally likely before). It is at most 1/3: a use that works only in a pose other than
the one the object came in stays below :data:`rail_mj.affordances.prior.FUNCTIONAL`, and where it works in both,
the pose it came in is the functional one (a plate's face up, not its foot). An object that came turned over, its
cavity opening through the bottom of its box and not the top (:mod:`rail_mj.stable_poses.shape`), was either stored
so, a cup or a bowl upside down to drain or keep dust out, made for the pose its cavity opens up in; or it stands as
it was made to stand or as it fell, a display riser or a cover on its open side. With even odds between the two
(:data:`STORED_TURNED`), another pose is the one it was made for with probability ``(1 + P(B | came in A)) / 2``,
between 1/2 and 2/3: a use that works only with the cavity up is no longer certain, and a cup stored upside down is
still a cup. One that came in an arbitrary orientation (``RailObject.oriented`` False: a generated set's random
rotations, a scan whose up is unknown) or in no stable pose (tilted, in the air) says nothing of how it is used:
every pose's factor is 1.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from rail_mj.core.profile import PoseShape
from rail_mj.core.types import RailObject, StablePose
from rail_mj.stable_poses.shape import AS_IT_CAME_DEG, tilt_from_came

__all__ = ["PLACED", "STORED_TURNED", "came_in_pose", "made_to_stand", "turned_over", "design_factors"]

#: The odds that an object came at rest as it was made to stand rather than as it fell: even, for want of
#: evidence either way.
PLACED = 0.5
#: The odds that an object which came turned over was stored so (made for the pose its cavity opens up in) rather
#: than standing as made or as it fell: even, for want of evidence either way.
STORED_TURNED = 0.5


def came_in_pose(obj: RailObject, poses: Sequence[StablePose]) -> int | None:
    """The stable pose ``obj`` came in: the one whose up is closest to its mesh frame's +z, within
    :data:`~rail_mj.stable_poses.shape.AS_IT_CAME_DEG`; None when it came in an arbitrary orientation or in
    none of its stable poses."""
    if not obj.oriented or not poses:
        return None
    tilt = [tilt_from_came(p) for p in poses]
    best = int(np.argmin(tilt))
    return best if tilt[best] <= AS_IT_CAME_DEG else None


def made_to_stand(p_came: float) -> float:
    """The probability that an object which came at rest in a pose whose drops end there with frequency
    ``p_came`` was made to stand in another given pose rather than in that one (module docstring)."""
    p = min(1.0, max(0.0, float(p_came)))
    return (1.0 - PLACED) * p / (PLACED + 2.0 * (1.0 - PLACED) * p)


def turned_over(shape: PoseShape) -> bool:
    """Whether an object whose shape as it stands is ``shape`` stands turned over: its cavity opens through the
    bottom of its box and not the top."""
    return "bottom" in shape.open_faces and "top" not in shape.open_faces


def design_factors(obj: RailObject, poses: Sequence[StablePose],
                   came_shape: Callable[[], PoseShape]) -> list[tuple[str, float] | None]:
    """Per stable pose, the probability that ``obj`` was made to stand in it, in words and as a number, from the
    pose it came in: None (no factor) for that pose, and for every pose without evidence; :func:`made_to_stand`
    for every other, or, where it came turned over, that weighed evenly with its having been stored so (module
    docstring). ``came_shape`` gives the object's shape facts as it came (measured only when it came in a stable
    pose)."""
    came = came_in_pose(obj, poses)
    if came is None:
        return [None for _ in poses]
    p = float(poses[came].probability)
    if turned_over(came_shape()):
        factor = STORED_TURNED + (1.0 - STORED_TURNED) * made_to_stand(p)
        other = (f"made to stand this way, having come turned over in pose {came} (its cavity opening down: stored so, "
                 f"or standing as made or as it fell; drops end there {p:.0%} of the time)", factor)
    else:
        other = (f"made to stand this way, having come in pose {came} (drops end there {p:.0%} of the time)",
                 made_to_stand(p))
    return [None if i == came else other for i in range(len(poses))]
