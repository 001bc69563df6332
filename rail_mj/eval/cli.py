"""``python -m rail_mj.eval``: the paper's Table 1 and Table 2 on a labelled dataset.

The command line of :func:`rail_mj.eval.run.run_eval` (what a run writes, and what a kill can lose, is told
in :mod:`rail_mj.eval.run`) and, as ``python -m rail_mj.eval merge OUT... --out OUT``, of
:func:`rail_mj.eval.merge.merge_runs`. How a case is scored: :data:`rail_mj.eval.summary.RULES` (also
printed in the report). Exit status by the rule of :mod:`rail_mj.core.cli`.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import cast

from pydantic import ValidationError

from rail_mj.core.cli import EXIT_FAILED, EXIT_OK, report_error
from rail_mj.core.errors import ConfigError, RailError
from rail_mj.dataset.ground_truth import FAMILIES
from rail_mj.eval.merge import merge_runs
from rail_mj.eval.run import PLAN_FILE, DatasetConfig, EvalConfig, parse_shard, run_eval
from rail_mj.eval.summary import _tables, _timing_table
from rail_mj.llm.providers import PROVIDERS
from rail_mj.pipeline.cli import add_llm_options, run_settings
from rail_mj.pipeline.tasks import cpu_count
from rail_mj.stable_poses import StablePoseConfig

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m rail_mj.eval", description=cast(str, __doc__).split("\n\n")[0])
    p.add_argument("--dataset", default="procedural", help="'procedural' or a folder with labels.jsonl")
    p.add_argument("--per-class", type=int, help=f"objects per class (procedural; default "
                                                    f"{DatasetConfig.model_fields['per_class'].default})")
    p.add_argument("--seed", type=int,
                   help=f"dataset seed (procedural; default {DatasetConfig.model_fields['seed'].default})")
    p.add_argument("--family", default="core", choices=tuple(FAMILIES),
                   help="procedural class family: core (default, the published set), world (shapes of real meshes, "
                   "scan-like corruption mixed in) or all")
    p.add_argument("--classes", help="comma-separated classes (procedural), default all of the family")
    p.add_argument("--orientation", choices=("random", "as_built"),
                   help="procedural objects in random orientations (default), or standing as built as a real mesh "
                        "file comes (evidence of the pose each was made to stand in)")
    p.add_argument("--affordances", help="comma-separated requested affordances, default all labelled")
    p.add_argument("--affordances-file", action="append", type=Path, default=[], metavar="F",
                   help="an affordance file (TOML) whose rows are registered before the names are checked, here "
                        "and in every worker; repeatable")
    p.add_argument("--profile-dir", type=Path, metavar="DIR",
                   help="a profile folder in the paper authors' format, or a folder of them named by affordance: an "
                        "affordance with a folder is imagined from it, the rest from the provider")
    p.add_argument("--no-profile-adapt", dest="profile_adapt", action="store_false", default=None,
                   help="refuse a profile folder whose agents start inside each other instead of spreading them "
                        "apart as the authors' simulator would (default: adapt, and say so in the result)")
    p.add_argument("--profile-origin", choices=("ground", "center"),
                   help="where the folders' via-points start: the object's footprint centre on the ground, or its "
                        "box centre")
    p.add_argument("--save-profile", type=Path, metavar="DIR",
                   help="after the run, write each affordance's profile (its first case's) as DIR/<affordance>/ in "
                        "the paper authors' format, for --profile-dir DIR to read back")
    p.add_argument("--out", type=Path, required=True, help="output folder (one run at a time)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run in --out")
    p.add_argument("--provider", choices=PROVIDERS, help="default auto")
    p.add_argument("--backend", choices=("auto", "native", "mjx"), help="default auto")
    add_llm_options(p)
    p.add_argument("--drops", type=int, help=f"drops for stable-pose imagination (default "
                                             f"{StablePoseConfig.model_fields['n_drops'].default})")
    p.add_argument("--no-render", action="store_true", help="skip the pictures in report.md")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--workers", type=int, default=None,
                   help=f"worker processes, one object each at a time (default: every core, {cpu_count()} here; "
                        "1 runs in this process); with --ray and no ADDRESS, the local Ray's CPUs")
    p.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                   help="run the objects as Ray tasks on the cluster at ADDRESS, or on a local Ray without one "
                        "(pip install -e '.[cluster]')")
    p.add_argument("--shard", help="i/n: evaluate every n-th labelled object from the i-th (1-based); "
                                   "join the parts with `python -m rail_mj.eval merge`")
    return p


def _merge_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m rail_mj.eval merge",
        description="Join the output folders of one evaluation's --shard runs into the files one serial run writes.",
    )
    p.add_argument("inputs", nargs="+", type=Path, metavar="OUT", help="output folders of the shard runs")
    p.add_argument("--out", type=Path, required=True, help="folder for the merged results (empty, or a merge's)")
    p.add_argument("--no-render", action="store_true", help="skip the pictures in report.md")
    return p


#: The command-line option of each EvalConfig field (by its path in the config), for error messages.
_OPTIONS = {"dataset.per_class": "--per-class", "dataset.seed": "--seed", "run.stable_poses.n_drops": "--drops",
            "run.profile_dir": "--profile-dir"}


def _config(args: argparse.Namespace) -> EvalConfig:
    split = lambda s: [x.strip() for x in s.split(",") if x.strip()] if s else None  # noqa: E731
    run: dict = {"affordances_files": args.affordances_file, **run_settings(args)}
    if args.drops is not None:  # absent: StablePoseConfig's default, its one home
        run["stable_poses"] = {"n_drops": args.drops}
    try:
        return EvalConfig.model_validate({
            "run": run,
            # an option left out keeps the config's default, declared there once
            "dataset": {k: v for k, v in {"source": args.dataset, "per_class": args.per_class, "seed": args.seed,
                                          "family": args.family, "classes": split(args.classes),
                                          "orientation": args.orientation}.items()
                        if v is not None},
            "affordances": split(args.affordances),
            "render": not args.no_render,
        })
    except ValidationError as exc:
        problems = "; ".join(
            f"{_OPTIONS.get(loc, loc)} {e['input']!r}: {e['msg']}"
            for e in exc.errors() for loc in [".".join(map(str, e["loc"]))]
        )
        raise ConfigError(f"bad option value: {problems}") from None


def _save_profiles(folder: Path, out: Path, config: EvalConfig) -> bool:
    """``--save-profile``: each affordance's profile for its first case in ``out/results.jsonl`` (the object loaded
    again, its hulls from the cache)."""
    from rail_mj.core.results import AffordanceResult
    from rail_mj.dataset.labels import read_labels
    from rail_mj.mesh import load_object
    from rail_mj.pipeline.saved_profiles import save_profiles

    root = Path(json.loads((out / PLAN_FILE).read_text())["dataset_root"])
    records = {r.mesh: r for r in read_labels(root)}
    firsts: dict[str, dict] = {}
    for line in (out / "results.jsonl").read_text().splitlines():
        if line.strip():
            ln = json.loads(line)
            if ln.get("error") is None and ln.get("result"):
                firsts.setdefault(ln["affordance"], ln)
    cases = []
    for ln in firsts.values():
        r = records[ln["mesh"]]
        obj = load_object(root / r.mesh, units=r.units, up=r.up, decomposition=config.run.decomposition)
        cases.append((AffordanceResult.model_validate(ln["result"]), obj.obb_dims))
    return save_profiles(folder, cases, config.run)


def _print_outcome(summary: dict, out: Path) -> int:
    print(_tables(summary))
    print("\n" + _timing_table(summary))
    print(f"\nwrote {out / 'results.jsonl'}, {out / 'summary.json'}, {out / 'report.md'}")
    for key, message in summary["errors"].items():
        print(f"error: {key}: {message}", file=sys.stderr)
    if summary.get("missing_shards"):
        print(f"error: shards {', '.join(summary['missing_shards'])} were not given; merge again with them",
              file=sys.stderr)
    if not summary["complete"]:
        print(
            f"error: {out / 'results.jsonl'} does not hold each of the {summary['n_expected']} expected "
            "cases exactly once; "
            + ("rerun the shard runs with --resume, then merge again" if "merged_from" in summary
               else "rerun with --resume"),
            file=sys.stderr,
        )
    return EXIT_OK if summary["complete"] and not summary["errors"] else EXIT_FAILED


def _merge_main(argv: Sequence[str]) -> int:
    args = _merge_parser().parse_args(argv)
    try:
        summary = merge_runs(args.inputs, args.out, render=not args.no_render)
    except RailError as exc:
        return report_error(exc)
    return _print_outcome(summary, args.out)


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; exit status by the rule in :mod:`rail_mj.core.cli`. ``merge ...`` joins shard runs."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["merge"]:
        return _merge_main(argv[1:])
    args = _parser().parse_args(argv)
    try:
        config = _config(args)
        summary = run_eval(
            config, args.out, resume=args.resume, progress=not args.no_progress, workers=args.workers,
            executor="local" if args.ray is None else "ray", ray_address=args.ray or None,
            shard=None if args.shard is None else parse_shard(args.shard),
        )
        if args.save_profile is not None and not _save_profiles(args.save_profile, args.out, config):
            _print_outcome(summary, args.out)
            return EXIT_FAILED
    except KeyboardInterrupt as exc:
        code = report_error(exc)
        print(f"finished lines are in {args.out / 'results.jsonl'}; rerun with --resume", file=sys.stderr)
        return code
    except RailError as exc:
        return report_error(exc)
    return _print_outcome(summary, args.out)
