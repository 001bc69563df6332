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
still a cup. One that came in no stable pose (tilted, in the air) says nothing of how it is used: every pose's factor
is 1.

One that came in an arbitrary orientation (``RailObject.oriented`` False: a generated set's random rotations, a scan
whose up is unknown) came in a pose no one saw, so the physics cannot tell which pose it was made for (a box on its
back and a basket standing are one shape; only how it came tells them apart). Had it been seen coming in A, a pose D
would carry 1 if A is D, else the factor above (turned over or not). An object made to stand in D comes in D placed
so (:data:`PLACED`) or fallen there (``p_D``), and in another pose A fallen there (``p_A``), so D's factor on average
over how it comes is

    f(D) = PLACED + (1 - PLACED) (p_D + sum over A != D of p_A P(D | came in A)).

With even odds among its stable poses for the one it was made for, for want of evidence, every pose carries the mean
of f over them: the physics still picks the pose (a factor common to all poses moves none past another), and the
probability says what the missing up costs. It is 1 for an object with one stable pose and lower the more evenly
drops spread over more poses: a bowl that lands upright three times in four keeps most of its certainty, a chair with
six poses about equally likely the least.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from rail_mj.core.profile import PoseShape
from rail_mj.core.types import RailObject, StablePose
from rail_mj.stable_poses.shape import AS_IT_CAME_DEG, tilt_from_came

__all__ = ["PLACED", "STORED_TURNED", "came_in_pose", "made_to_stand", "turned_over", "made_for_other",
           "design_factors", "common_factor"]

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


def made_for_other(p_came: float, came_turned_over: bool) -> float:
    """The probability that an object which came at rest in a pose whose drops end there with frequency ``p_came``
    (``came_turned_over``: its cavity opening down there) was made to stand in another given pose (module
    docstring)."""
    made = made_to_stand(p_came)
    return STORED_TURNED + (1.0 - STORED_TURNED) * made if came_turned_over else made


def _up_unknown(poses: Sequence[StablePose], pose_shape: Callable[[int], PoseShape]) -> list[tuple[str, float] | None]:
    """Per stable pose of an object that came in an arbitrary orientation, the factor of its having been made to
    stand as the physics finds it, the same for every pose (module docstring); None (1) where it has one pose."""
    n = len(poses)
    if n < 2:
        return [None for _ in poses]
    p = np.clip(np.asarray([float(q.probability) for q in poses]), 0.0, None)
    p = p / p.sum() if p.sum() > 0 else np.full(n, 1.0 / n)
    # a pose no drop ends in is never the one it came in: its shape is not needed
    other = np.asarray([made_for_other(p[a], turned_over(pose_shape(a))) if p[a] > 0 else 0.0 for a in range(n)])
    # f(D) = PLACED + (1 - PLACED) (p_D + sum over A != D of p_A other_A)
    came_elsewhere = float(np.sum(p * other)) - p * other
    factor = float(np.mean(PLACED + (1.0 - PLACED) * (p + came_elsewhere)))
    words = (f"made to stand as it is used, its up unknown (what the pose it came in would have told, on average "
             f"over how it comes, each of its {n} stable poses as likely the one it was made for)")
    return [(words, factor) for _ in poses]


def design_factors(obj: RailObject, poses: Sequence[StablePose], came_shape: Callable[[], PoseShape],
                   pose_shape: Callable[[int], PoseShape]) -> list[tuple[str, float] | None]:
    """Per stable pose, the probability that ``obj`` was made to stand in it, in words and as a number: from the
    pose it came in, None (no factor) for that pose and :func:`made_for_other` for every other; for an object that
    came in an arbitrary orientation, that averaged over the pose it would have come in; None for every pose of one
    that came in none of its stable poses (module docstring). ``came_shape`` gives the object's shape facts as it
    came (measured only when it came in a stable pose), ``pose_shape`` those of a stable pose (measured only for an
    object in an arbitrary orientation)."""
    if not obj.oriented:
        return _up_unknown(poses, pose_shape)
    came = came_in_pose(obj, poses)
    if came is None:
        return [None for _ in poses]
    p = float(poses[came].probability)
    if turned_over(came_shape()):
        other = (f"made to stand this way, having come turned over in pose {came} (its cavity opening down: stored so, "
                 f"or standing as made or as it fell; drops end there {p:.0%} of the time)", made_for_other(p, True))
    else:
        other = (f"made to stand this way, having come in pose {came} (drops end there {p:.0%} of the time)",
                 made_for_other(p, False))
    return [None if i == came else other for i in range(len(poses))]


def common_factor(design: Sequence[tuple[str, float] | None]) -> float:
    """The factor every pose of ``design`` (:func:`design_factors`) carries alike: an object of unknown up's; 1 where
    the poses' factors differ or there are none. It tells nothing of which pose is the functional one."""
    values = {None if d is None else d[1] for d in design}
    if len(values) != 1:
        return 1.0
    value = values.pop()
    return 1.0 if value is None else float(value)
