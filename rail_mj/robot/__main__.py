"""``python -m rail_mj.robot``: fetch the Panda model, run the execution demo or the experiment, or carry out
one request on your own objects: ``--request "put the apple in the bowl" --object bowl.obj [--object ...]``.

The objects stand side by side on the table, upright as given (``--units``, ``--up``, ``--yaw``: once for all,
or once per ``--object``; ``--at X,Y`` places one, world metres); each is scanned and imagined as placed; the
robot executes on the object that affords the request best, or declines saying why. A request that names no
known use, a file that does not load, an object off the table, out of reach or overlapping another is an error
(exit 1) and nothing moves; a decline is a result (exit 0).

Exit status and error output follow rail_mj.core.cli: 0 the command ran (failed trials are results, counted
in the success rate), 1 it could not run (the model could not be fetched, an execution could not be set
up), 2 the command line was wrong and nothing ran, 130 interrupted; errors are ``error:`` lines on stderr.
``--json`` names the summary file, so there is no JSON error object on stdout.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

from rail_mj.affordances import load_files
from rail_mj.core.cli import EXIT_OK, report_error
from rail_mj.core.errors import RailError
from rail_mj.core.runfiles import atomic_write_text
from rail_mj.llm.providers import PROVIDERS
from rail_mj.pipeline.cli import add_llm_options, llm_settings
from rail_mj.pipeline.config import RunConfig
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


def _xy(text: str) -> tuple[float, float]:
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be X,Y in metres, got {text!r}") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return x, y


def _per_object(parser: argparse.ArgumentParser, name: str, values: list, n: int, default) -> list:
    """A per-object option: absent (the default for all), given once (for all), or once per --object."""
    if not values:
        return [default] * n
    if len(values) == 1:
        return values * n
    if len(values) != n:
        parser.error(f"--{name} given {len(values)} times for {n} --object files; give it once or once per object")
    return values


def _object_specs(parser: argparse.ArgumentParser, args: argparse.Namespace) -> list:
    from rail_mj.robot.run import ObjectSpec

    n = len(args.object)
    if n == 0:
        parser.error("--request needs at least one --object MESH")
    if args.at and len(args.at) != n:
        parser.error(f"--at given {len(args.at)} times for {n} --object files; give it once per object or not at all")
    units = _per_object(parser, "units", args.units, n, 1.0)
    ups = _per_object(parser, "up", args.up, n, "z")
    yaws = _per_object(parser, "yaw", args.yaw, n, 0.0)
    ats = args.at or [None] * n
    return [ObjectSpec(path=p, units=u, up=a, yaw=w, xy=xy)
            for p, u, a, w, xy in zip(args.object, units, ups, yaws, ats)]


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{value:.1%}"


def _request_report(out: dict) -> str:
    """What the robot did with a request, in lines: each object's verdict, then the outcome."""
    lines = [f"request {out['request']!r}: agent {out['agent']!r}, affordance {out['affordance']!r}, "
             f"preposition {out['preposition']!r}"]
    for o in out["objects"]:
        p = "" if o["probability"] is None else f", probability {o['probability']:.2f}"
        lines.append(f"  {o['name']} at {o['xy']}: {'affords' if o['functional'] else 'does not afford'} it "
                     f"({o['used']}{p}): {o['verdict'].get('error') or o['verdict'].get('reason', '')}")
    if out["declined"]:
        lines.append(f"declined, nothing executed: {out['reason']}")
    else:
        judge = out["judge"] or {}
        lines.append(f"chose {out['chosen']!r}, executed plan {out['plan']!r}: judge "
                     f"{'SUCCESS' if out['success'] else 'FAILURE'} ({judge.get('reason', out['message'])}); plan's "
                     f"own score {out['plan_score']}; peak hand force {out['peak_force']:.1f} N "
                     f"(limit {out['force_limit']:.1f} N)")
    return "\n".join(lines)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m rail_mj.robot", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fetch", action="store_true", help="download and verify the Menagerie Panda into the cache")
    parser.add_argument("--demo", action="store_true", help="execute imagined interactions with the Panda")
    parser.add_argument("--experiment", action="store_true",
                        help="the paper's robot experiment: request -> wrist-camera scan -> imagination as placed "
                             "(scan and true mesh) -> Panda execution -> judge; resumable (JSONL next to --json)")
    parser.add_argument("--no-scan", action="store_true",
                        help="--experiment / --request without the scan: imagine on the true mesh (and say so)")
    parser.add_argument("--request", metavar="TEXT", help='a request in words, e.g. "put the apple in the bowl"')
    parser.add_argument("--object", action="append", type=Path, default=[], metavar="MESH",
                        help="a mesh file (OBJ, STL, PLY, OFF, GLB, GLTF) on the table; repeatable")
    parser.add_argument("--units", action="append", type=_positive(float), default=[], metavar="U",
                        help="metres per mesh unit (default 1); once for all objects or once per --object")
    parser.add_argument("--up", action="append", choices=("z", "y"), default=[],
                        help="the mesh's up axis (default z); once for all or once per --object")
    parser.add_argument("--yaw", action="append", type=float, default=[], metavar="DEG",
                        help="turn about the vertical, degrees (default 0); once for all or once per --object")
    parser.add_argument("--at", action="append", type=_xy, default=[], metavar="X,Y",
                        help="where an object stands (world m, the table's centre is at 0.55,0); once per --object")
    parser.add_argument("--affordance", action="append", choices=sorted(DEMO_AFFORDANCES),
                        help="repeatable; default: all")
    parser.add_argument("--affordances-file", action="append", type=Path, default=[], metavar="F",
                        help="an affordance file (TOML) whose rows are registered before anything runs (an "
                             "override changes how a built-in affordance is imagined); repeatable")
    parser.add_argument("--profile-dir", type=Path, metavar="DIR",
                        help="a profile folder in the paper authors' format, or a folder of them named by affordance, "
                             "that every imagination of the run reads (as $RAIL_MJ_PROFILE_DIR)")
    parser.add_argument("--provider", default="offline", choices=PROVIDERS,
                        help="who reads --request and --experiment's sentences and imagines (default offline; "
                             "--demo always uses the offline library)")
    add_llm_options(parser)
    parser.add_argument("--trials", type=_positive(int), default=4, help="objects per affordance")
    parser.add_argument("--planner", choices=("imagined", "scripted"), default="imagined",
                        help="imagined: classify -> functional pose -> best plan (default); scripted: hand-written "
                             "plans in the upright pose, to check the controller alone")
    parser.add_argument("--force-limit", type=_positive(float), default=RobotConfig().force_limit,
                        help="N")
    parser.add_argument("--json", type=Path, help="write the summary here")
    parser.add_argument("--save-profile", type=Path, metavar="DIR",
                        help="with --request: write the profile the chosen object was imagined with as "
                             "DIR/<affordance>/ in the paper authors' format, for --profile-dir DIR to read back")
    parser.add_argument("--video", "--render", dest="video", type=Path,
                        help="folder for an mp4 of each affordance's first trial (AFFORDANCE_OBJECT.mp4)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if not (args.fetch or args.demo or args.experiment or args.request):
        parser.error("give --fetch, --demo, --experiment and/or --request TEXT --object MESH")
    specs = _object_specs(parser, args) if args.request is not None else []
    try:
        load_files(args.affordances_file)
        run = RunConfig(provider=args.provider, **llm_settings(args))
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
                                     config=RobotConfig(force_limit=args.force_limit), run=run)
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
            print(f"independent judge: {summary['n_success']}/{summary['n_positive']} requests to execute succeeded; "
                  f"plan's own score agrees with the judge in {_pct(summary['judge_plan_agreement'])}; declines "
                  f"{summary['n_declined_right']}/{summary['n_declines']} with no motion; right object chosen on "
                  f"tables of 3+ in {_pct(summary['right_choice_rate'])} ({summary['n_tables']} tables); "
                  f"{summary['n_real']} tasks with real meshes")
        if args.request is not None:
            from rail_mj.robot.run import run_request

            out = run_request(args.request, specs, scan=not args.no_scan, video=args.video,
                              config=RobotConfig(force_limit=args.force_limit), run=run,
                              save_profile=args.save_profile)
            if args.json is not None:
                atomic_write_text(args.json, json.dumps(out, indent=2))
            print(_request_report(out))
    except (RailError, KeyboardInterrupt) as exc:
        return report_error(exc)
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
