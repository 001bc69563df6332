"""The path of one verdict through the packages: ``Pipeline.run`` for ``cup`` on a generated mug, traced.

    python benchmarks/verdict_path.py [--affordance cup] [--object cup]

The profile (stages 1-6) and the compiled scoring code are made by a first, untraced run and reused; the second run
is traced with ``sys.setprofile``. Over the call events inside ``rail_mj`` it counts the stays (maximal runs of
calls in one top-level package), the packages, the returns (stays in a package already left), the climbs (a call
from a lower layer into a higher one: core < affordances, mesh, mjcf, stable_poses < imagination, scoring < llm,
profiles < pipeline) and the calls that enter ``rail_mj/llm/offline.py`` from outside it. Run it on two checkouts
(``PYTHONPATH=OTHER python benchmarks/verdict_path.py``) to compare them.
"""

from __future__ import annotations

import argparse
import os
import sys
from types import FrameType
from typing import Any

os.environ.setdefault("JAX_PLATFORMS", "cpu")

from rail_mj.pipeline.chain import Pipeline  # noqa: E402
from rail_mj.pipeline.config import RunConfig  # noqa: E402
from rail_mj.robot.demo import make_object  # noqa: E402

LAYER = {"core": 0, "affordances": 1, "mesh": 1, "mjcf": 1, "stable_poses": 1, "imagination": 2, "scoring": 2,
         "llm": 3, "profiles": 3, "pipeline": 4}
OFFLINE = os.path.join("llm", "offline.py")


def _package(path: str) -> str | None:
    """The top-level package of a file inside rail_mj, else None."""
    if f"{os.sep}rail_mj{os.sep}" not in path:
        return None
    rel = path.split(f"{os.sep}rail_mj{os.sep}", 1)[1]
    return rel.split(os.sep)[0] if os.sep in rel else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--affordance", default="cup")
    parser.add_argument("--object", default="cup", help="a procedural class made by rail_mj.robot.demo.make_object")
    args = parser.parse_args(argv)
    pipe = Pipeline(RunConfig(provider="offline", backend="native"))
    obj = make_object(args.object, 0)
    poses = pipe.stable_poses(obj)
    pipe.run(obj, poses, args.affordance)
    stays: list[str] = []
    counts = {"climbs": 0, "offline": 0}

    def on_call(frame: FrameType, event: str, _arg: Any) -> None:
        if event != "call":
            return
        here = _package(frame.f_code.co_filename)
        if here is None:
            return
        caller = frame.f_back
        if frame.f_code.co_filename.endswith(OFFLINE) and not (caller and caller.f_code.co_filename.endswith(OFFLINE)):
            counts["offline"] += 1
        above = _package(caller.f_code.co_filename) if caller else None
        if above in LAYER and here in LAYER and LAYER[here] > LAYER[above]:
            counts["climbs"] += 1
        if not stays or stays[-1] != here:
            stays.append(here)

    sys.setprofile(on_call)
    try:
        pipe.run(obj, poses, args.affordance)
    finally:
        sys.setprofile(None)
    seen: set[str] = set()
    returns = 0
    for p in stays:
        returns += p in seen
        seen.add(p)
    print(f"{args.affordance} on a generated {args.object}: {len(stays)} stays in {len(seen)} packages, "
          f"{returns} returns, {counts['climbs']} climbs, {counts['offline']} entries into llm/offline.py")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
