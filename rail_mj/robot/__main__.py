"""``python -m rail_mj.robot``: fetch the Panda model, or run the execution demo.

Exit status and error output follow rail_mj.core.cli: 0 the command ran (failed trials are results, counted
in the success rate), 1 it could not run (the model could not be fetched, an execution could not be set
up), 2 the command line was wrong and nothing ran, 130 interrupted; errors are ``error:`` lines on stderr.
``--json`` names the summary file, so there is no JSON error object on stdout.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from rail_mj.affordances import load_files
from rail_mj.core.cli import EXIT_OK, report_error
from rail_mj.core.errors import RailError
from rail_mj.profiles import PROFILE_DIR_ENV, check_profile_dir
from rail_mj.robot.control import RobotConfig
from rail_mj.robot.demo import DEMO_AFFORDANCES, run_demo
from rail_mj.robot.model import fetch_panda

__all__ = ["main"]


def _positive(kind: type):
    def parse(text: str):
        value = kind(text)
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
        return value

    parse.__name__ = kind.__name__  # argparse names the type in "invalid int value"
    return parse


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rail_mj.robot", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fetch", action="store_true", help="download and verify the Menagerie Panda into the cache")
    parser.add_argument("--demo", action="store_true", help="execute imagined interactions with the Panda")
    parser.add_argument("--experiment", action="store_true",
                        help="the paper's robot experiment: request -> wrist-camera scan -> imagination as placed "
                             "(scan and true mesh) -> Panda execution -> judge; resumable (JSONL next to --json)")
    parser.add_argument("--no-scan", action="store_true",
                        help="--experiment without the scan: imagine on the true mesh (and say so)")
    parser.add_argument("--affordance", action="append", choices=sorted(DEMO_AFFORDANCES),
                        help="repeatable; default: all")
    parser.add_argument("--affordances-file", action="append", type=Path, default=[], metavar="F",
                        help="an affordance file (TOML) whose rows are registered before anything runs (an "
                             "override changes how a built-in affordance is imagined); repeatable")
    parser.add_argument("--profile-dir", type=Path, metavar="DIR",
                        help="a profile folder in the paper authors' format, or a folder of them named by affordance, "
                             "that every imagination of the run reads (as $RAIL_MJ_PROFILE_DIR)")
    parser.add_argument("--trials", type=_positive(int), default=4, help="objects per affordance")
    parser.add_argument("--planner", choices=("imagined", "scripted"), default="imagined",
                        help="imagined: classify -> functional pose -> best plan (default); scripted: hand-written "
                             "plans in the upright pose, to check the controller alone")
    parser.add_argument("--force-limit", type=_positive(float), default=RobotConfig().force_limit,
                        help="N")
    parser.add_argument("--json", type=Path, help="write the summary here")
    parser.add_argument("--video", "--render", dest="video", type=Path,
                        help="folder for an mp4 of each affordance's first trial (AFFORDANCE_OBJECT.mp4)")
    args = parser.parse_args(argv)
    if not (args.fetch or args.demo or args.experiment):
        parser.error("give --fetch, --demo and/or --experiment")
    try:
        load_files(args.affordances_file)
        if args.profile_dir is not None:
            os.environ[PROFILE_DIR_ENV] = str(check_profile_dir(args.profile_dir))
        if args.fetch:
            print(f"Panda model downloaded and verified in {fetch_panda()}")
        if args.demo:
            summary = run_demo(args.affordance, args.trials, config=RobotConfig(force_limit=args.force_limit),
                               planner=args.planner, json_path=args.json, video=args.video)
            print(f"success rate {summary['success_rate']:.1%} over {summary['n_trials']} trials, "
                  f"{summary['n_affordances']} affordances; peak hand contact force "
                  f"{summary['max_peak_force']:.1f} N (limit {summary['force_limit']:.1f} N), "
                  f"{summary['n_force_events']} force-limit events")
        if args.experiment:
            from rail_mj.robot.experiment import format_table, run_experiment

            summary = run_experiment(scan=not args.no_scan, json_path=args.json, video=args.video,
                                     config=RobotConfig(force_limit=args.force_limit))
            print(format_table(summary["rows"]))
            agree = summary["verdict_agreement"]
            scan_s = summary["scan_seconds_mean"]
            print(f"{summary['n_tasks']} tasks, {summary['n_affordances']} affordances "
                  f"({summary['n_beyond_paper']} beyond the paper's eight); success {summary['success_rate']:.1%}; "
                  f"scan/true verdict agreement {'-' if agree is None else f'{agree:.1%}'}; peak hand force "
                  f"{summary['max_peak_force']:.1f} N = {summary['peak_over_limit']:.2f} x limit; "
                  f"{summary['n_force_events']} force-limit events; scan + fusion "
                  f"{'-' if scan_s is None else f'{scan_s:.1f} s'} per object")
            if summary["scan_note"]:
                print(summary["scan_note"])
    except (RailError, KeyboardInterrupt) as exc:
        return report_error(exc)
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
