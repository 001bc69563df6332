"""``python -m rail_mj.robot``: fetch the Panda model, or run the execution demo."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rail_mj.errors import RailError
from rail_mj.robot.control import RobotConfig
from rail_mj.robot.demo import DEMO_AFFORDANCES, run_demo
from rail_mj.robot.model import fetch_panda

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rail_mj.robot", description=__doc__)
    parser.add_argument("--fetch", action="store_true", help="download and verify the Menagerie Panda into the cache")
    parser.add_argument("--demo", action="store_true", help="execute imagined interactions with the Panda")
    parser.add_argument("--affordance", action="append", choices=sorted(DEMO_AFFORDANCES),
                        help="repeatable; default: all")
    parser.add_argument("--trials", type=int, default=4, help="objects per affordance")
    parser.add_argument("--planner", choices=("imagined", "scripted"), default="imagined",
                        help="imagined: classify -> functional pose -> best plan (default); scripted: hand-written "
                             "plans in the upright pose, to check the controller alone")
    parser.add_argument("--force-limit", type=float, default=RobotConfig().force_limit, help="N")
    parser.add_argument("--json", type=Path, help="write the summary here")
    parser.add_argument("--video", "--render", dest="video", type=Path,
                        help="folder for PNG frames of each affordance's first trial")
    args = parser.parse_args(argv)
    if not (args.fetch or args.demo):
        parser.error("give --fetch and/or --demo")
    try:
        if args.fetch:
            print(f"Panda model downloaded and verified in {fetch_panda()}")
        if args.demo:
            if args.trials < 1:
                parser.error("--trials must be >= 1")
            summary = run_demo(args.affordance, args.trials, config=RobotConfig(force_limit=args.force_limit),
                               planner=args.planner, json_path=args.json, video=args.video)
            print(f"success rate {summary['success_rate']:.1%} over {summary['n_trials']} trials, "
                  f"{summary['n_affordances']} affordances; peak hand contact force "
                  f"{summary['max_peak_force']:.1f} N (limit {summary['force_limit']:.1f} N), "
                  f"{summary['n_force_events']} force-limit events")
    except RailError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
