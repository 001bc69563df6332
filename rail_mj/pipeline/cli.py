"""``rail-mj classify MESH --affordance NAME`` (or ``python -m rail_mj MESH ...``): one object, one verdict, for people.

Exit status and error output follow rail_mj.core.cli: 0 every case succeeded, 1 some case failed (its
``error:`` line on stderr; with ``--json`` also its result line, carrying ``error``), 2 the command
line was wrong (an empty or unknown affordance, a bad option value) and nothing ran, 130 interrupted.
A picture asked for (``--render``, ``--contact-sheet``) or a scene (``--save-scene DIR``) of a result
that has nothing to draw (its dimension check failed, so nothing was imagined) is not written; a line on
stderr says why, and that alone is not a failure. ``--save-scene`` refuses a non-empty DIR that holds no
previous scene.xml before any work (exit 2). ``--profile-dir`` that is no profile folder is refused before
any work (exit 2); a broken file in it is the error of the cases it serves. A profile that ``--save-profile``
cannot write (an agent shape URDF lacks) is an ``error:`` line and exit 1; the others are written.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rail_mj.core.cli import EXIT_FAILED, EXIT_OK, report_error
from rail_mj.core.errors import RailError

__all__ = ["main", "add_llm_options", "llm_settings", "run_settings"]


def _number(kind: type, lowest: float, strict: bool, what: str):
    """An argparse type: ``kind`` of the text, refused (naming ``what``) below ``lowest`` (or at it, ``strict``)."""
    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        if value < lowest or (strict and value == lowest) or not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}")
        return value
    return parse


def add_llm_options(parser: argparse.ArgumentParser) -> None:
    """``--model``, ``--llm-timeout``, ``--max-repairs``, ``--no-llm-pictures`` and ``--save-affordance``, which every
    command that imagines takes: a model the server names, a slow model waited for, how often a rejected answer goes
    back (defaults: the provider's), whether stage 7 sees pictures, and where the uses the model defined are
    written."""
    from rail_mj.llm.provider_base import LLMConfig

    fields = LLMConfig.model_fields
    parser.add_argument("--model", help="the LLM's model name (anthropic and openai providers; default "
                                         "$RAIL_MJ_MODEL, else the provider's)")
    parser.add_argument("--llm-timeout", type=_number(float, 0.0, True, "a number of seconds > 0"), metavar="SECONDS",
                        help=f"seconds one LLM request may take (default {fields['timeout'].default:g}; a model "
                             "served on a CPU may need minutes)")
    parser.add_argument("--max-repairs", type=_number(int, 0, False, "a whole number >= 0"), metavar="N",
                        help=f"repair rounds per stage after a rejected answer (default "
                             f"{fields['max_retries'].default})")
    parser.add_argument("--no-llm-pictures", dest="llm_pictures", action="store_false", default=None,
                        help="send stage 7 no pictures of the poses (default: a picture of each pose with its "
                             "plan's end state, to a model that takes them; one whose API refuses them is asked "
                             "again as text)")
    parser.add_argument("--save-affordance", type=Path, metavar="DIR",
                        help="write each use outside the registry that the model defined, once proven on its "
                             "prototypes: a row of a kind as DIR/<use>.toml (for --affordances-file), a profile of its "
                             "own as DIR/<use>/ (for --profile-dir); both load with no model")


def run_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The :class:`~rail_mj.pipeline.config.RunConfig` fields of the options given (provider, backend, profile
    folders and origin, the LLM options); one left out keeps RunConfig's default, declared there once."""
    given = {"provider": args.provider, "backend": args.backend, "profile_origin": args.profile_origin,
             "profile_adapt": args.profile_adapt,
             "profile_dir": args.profile_dir}
    return {**{k: v for k, v in given.items() if v is not None}, **llm_settings(args)}


def llm_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The :class:`~rail_mj.pipeline.config.RunConfig` fields of :func:`add_llm_options`' options that were given."""
    given = {"model": args.model, "llm_timeout": args.llm_timeout, "max_retries": args.max_repairs,
             "llm_pictures": args.llm_pictures, "save_affordance": args.save_affordance}
    return {k: v for k, v in given.items() if v is not None}


def _describe(r) -> str:
    lines = [f"{r.object}: {r.requested!r} -> {'FUNCTIONAL' if r.functional else 'not functional'}"]
    for note in r.mesh_notes:
        lines.append(f"  mesh: {note}")
    if r.error is None:
        lines.append(f"  probability {r.probability:.2f}" + (f" (prior: {r.prior})" if r.prior else ""))
    if not r.dims_fit:
        lines.append("  dimension check: unusual sizes for the use" + ("" if r.scores else ", nothing imagined"))
        if r.alternative:
            lines.append(f"  the analyser suggests: {r.alternative}")
    if r.functional_pose is not None:
        p = r.functional_pose
        lines.append(
            f"  functional pose #{p.index} (p={p.probability:.2f}): pos {[round(v, 3) for v in p.pos]}, "
            f"quat {[round(v, 3) for v in p.quat]}, mesh up {[round(v, 2) for v in p.up_in_mesh_frame]}"
        )
    if r.best_plan is not None:
        lines.append(f"  best interaction: {r.best_plan.name} (score {r.best_plan.score:.2f}): "
                     f"{r.best_plan.description}")
    for reason in r.analyzer_reasons:
        lines.append(f"  analyser: {reason}")
    lines.append("  timings: " + ", ".join(f"{k} {v:.2f}s" for k, v in r.timings.items()))
    return "\n".join(lines)


def _ranking(results) -> str:
    """One line per affordance, most probable first: probability, verdict, functional pose and best plan."""
    name = results[0].object if results else ""
    lines = [f"{name}: what it affords, most probable first"]
    for i, r in enumerate(results, 1):
        if r.error:
            lines.append(f"{i:3d}. {r.requested:<14} error: {r.error}")
            continue
        where = ""
        if r.functional_pose is not None:
            plan = f", {r.best_plan.name}" if r.best_plan is not None else ""
            where = f"  pose #{r.functional_pose.index}{plan}"
        verdict = "FUNCTIONAL" if r.functional else "no"
        lines.append(f"{i:3d}. {r.affordance:<14} p={r.probability:.2f}  {verdict:<10}{where}")
    return "\n".join(lines)


def _metres_per_unit(text: str) -> float:
    value = float(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number of metres per mesh unit, got {text}")
    return value


def _picture_path(text: str) -> Path:
    path = Path(text)
    if path.suffix.lower() not in (".png", ".jpg", ".jpeg"):
        raise argparse.ArgumentTypeError(f"must name a .png or .jpg file, got {text}")
    return path


def _outputs(args: argparse.Namespace, results) -> None:
    """Write the requested pictures and scene of the first functional result, else the first one with a
    rollout to draw; when no result has one, say why (that is an answer, not an error)."""
    from rail_mj.render.captions import nothing_to_draw
    from rail_mj.render.images import render_contact_sheet, render_result
    from rail_mj.render.mjcf_export import save_scene

    pictures = [p for p in (args.render, args.contact_sheet) if p is not None]
    nothing = [(f"no picture written to {', '.join(map(str, pictures))}", "no picture written")] if pictures else []
    if args.save_scene is not None:
        nothing.append((f"no scene written to {args.save_scene}", "no scene written"))
    done = [r for r in results if not r.error]
    if not done:
        for to, _ in nothing:
            print(f"{to}: every case failed", file=sys.stderr)
        return
    shown = next((r for r in done if r.functional), next((r for r in done if nothing_to_draw(r) is None), None))
    if shown is None:
        for _, plain in nothing:
            for r in done:
                print(f"{plain}: {nothing_to_draw(r)}", file=sys.stderr)
        return
    from rail_mj.mesh import load_object

    obj = load_object(args.mesh, units=args.units, up=args.up)
    if args.render:
        render_result(obj, shown, args.render, draw_mesh=args.draw_mesh)
        print(f"wrote {args.render}", file=sys.stderr)
    if args.contact_sheet:
        sheet = render_contact_sheet(obj, shown, args.contact_sheet, draw_mesh=args.draw_mesh)
        print(f"wrote {args.contact_sheet} ({len(sheet.tiles)} stable poses)", file=sys.stderr)
    if args.save_scene is not None:
        saved = save_scene(obj, shown, args.save_scene)
        again = " (overwrote the previous scene there)" if saved.overwrote else ""
        print(f"wrote {saved.path}{again}: pose #{saved.pose}, plan {saved.plan_name!r}, {saved.n_agents} agents, "
              f"{len(saved.via_sites)} via-poses; open it with: python -m mujoco.viewer --mjcf {saved.path}",
              file=sys.stderr)


def _saved_affordances(folder: Path, results) -> None:
    """Say where classify wrote the uses the model defined (RunConfig.save_affordance), or that there were none."""
    from rail_mj.pipeline.definitions import file_stem

    names = sorted({file_stem(r.requested) for r in results if r.definition})
    paths = [p for n in names for p in (folder / f"{n}.toml", folder / n) if p.exists()]
    for path in paths:
        print(f"wrote {path}", file=sys.stderr)
    if not paths:
        print(f"no affordance written to {folder}: no requested use was defined by the model here (registered "
              "uses and profile folders need none)", file=sys.stderr)


def _save_profiles(args: argparse.Namespace, results, config) -> bool:
    """``--save-profile``: each result's profile (:func:`rail_mj.pipeline.saved_profiles.save_profiles`)."""
    from rail_mj.mesh import load_object
    from rail_mj.pipeline.saved_profiles import save_profiles

    if all(r.error for r in results):
        return save_profiles(args.save_profile, [], config)
    obj = load_object(args.mesh, units=args.units, up=args.up)
    return save_profiles(args.save_profile, [(r, obj.obb_dims) for r in results], config)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m rail_mj", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("mesh", type=Path, help="OBJ, STL, PLY, OFF, GLB or GLTF file")
    p.add_argument("--affordance", "-a", action="append",
                   help="requested use; repeat for several (required unless --rank, which ranks every registered "
                        "affordance when none is given)")
    p.add_argument("--rank", action="store_true",
                   help="what is this object for: the affordances ranked by probability, each with its functional "
                        "pose; with --json one result line per affordance, most probable first")
    p.add_argument("--affordances-file", action="append", type=Path, default=[], metavar="F",
                   help="an affordance file (TOML) whose rows are registered before the names are checked; "
                        "repeatable (examples/*.toml)")
    p.add_argument("--profile-dir", type=Path, metavar="DIR",
                   help="a profile folder in the paper authors' format (analysis.txt, agent.urdf, arrangement.json, "
                        "plan.json / agents_traj.json, evaluation.py), or a folder of them named by affordance: "
                        "an affordance with a folder is imagined from it, the rest from the provider")
    p.add_argument("--no-profile-adapt", dest="profile_adapt", action="store_false", default=None,
                   help="refuse a profile folder whose agents start inside each other instead of spreading them "
                        "apart as the authors' simulator would (default: adapt, and say so in the result)")
    p.add_argument("--profile-origin", choices=("ground", "center"),
                   help="where the folders' via-points start: the centre of the object's footprint on the ground "
                        "(default) or the centre of its box")
    p.add_argument("--save-profile", type=Path, metavar="DIR",
                   help="write each affordance's profile as DIR/<affordance>/ in the same format (with rail_mj's "
                        "scoring.py and rail_mj.json), for --profile-dir DIR to read back")
    p.add_argument("--units", type=_metres_per_unit, default=1.0, help="metres per mesh unit (0.001 for millimetres)")
    p.add_argument("--up", choices=("z", "y"), default="z", help="the mesh's up axis")
    p.add_argument("--any-orientation", action="store_true",
                   help="the mesh comes in an arbitrary orientation (a scan whose up is unknown): the pose it came "
                        "in is no evidence of the pose it was made to stand in (default: it is; docs/verdicts.md)")
    p.add_argument("--provider",
                   help="auto | offline | anthropic | openai (OPENAI_BASE_URL, OPENAI_API_KEY, RAIL_MJ_MODEL)")
    p.add_argument("--backend", help="auto | native | mjx (default auto)")
    add_llm_options(p)
    p.add_argument("--json", action="store_true", help="print the results as JSON lines")
    p.add_argument("--explain", action="store_true",
                   help="show why: every stable pose (probability, up axis, box size, envelope), each plan's score "
                        "in it, the analyser's rules that fired, and the verdict; with --json under \"explain\"")
    p.add_argument("--render", type=_picture_path, metavar="PNG",
                   help="write a captioned picture of the functional pose (else the best-scoring one) with the agents")
    p.add_argument("--contact-sheet", type=_picture_path, metavar="PNG",
                   help="write one grid picture of every stable pose with its best-scoring plan (re-imagines them)")
    p.add_argument("--save-scene", type=Path, metavar="DIR",
                   help="write the imagined scene (functional pose, else the best-scoring one; agents at the start "
                        "of its plan; the via-poses as sites and keyframes) as DIR/scene.xml with DIR/meshes/ and "
                        "DIR/README.txt, to open with python -m mujoco.viewer --mjcf DIR/scene.xml")
    p.add_argument("--draw-mesh", action="store_true",
                   help="draw the original mesh in the pictures instead of its CoACD hulls")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    p = _parser()
    args = p.parse_args(argv)
    if not args.rank and not args.affordance:
        p.error("the following arguments are required: --affordance/-a (or --rank)")

    from rail_mj.pipeline.chain import classify
    from rail_mj.pipeline.config import ObjectInput, RunConfig
    from rail_mj.pipeline.rank import rank
    from rail_mj.render.explain import explain, format_explanation

    try:
        if args.save_scene is not None:
            from rail_mj.render.mjcf_export import check_scene_dir

            check_scene_dir(args.save_scene)  # before any work
        config = RunConfig(affordances_files=args.affordances_file, **run_settings(args))
        options: dict[str, Any] = dict(progress=False, config=config)
        item = ObjectInput(path=args.mesh, units=args.units, up=args.up, oriented=not args.any_orientation)
        if args.rank:
            results = rank([item], args.affordance, **options)[0].results
            if not args.json and not args.explain:
                print(_ranking(results))
        else:
            results = classify([item], args.affordance, **options)
        for r in results:
            if r.error:
                print(f"error: {r.object}: {r.requested!r}: {r.error}", file=sys.stderr)
            if args.json:
                print(json.dumps({**r.model_dump(mode="json"), "explain": explain(r).model_dump(mode="json")})
                      if args.explain else r.model_dump_json())
            elif args.explain:
                print(format_explanation(explain(r)))
            elif not r.error and not args.rank:
                print(_describe(r))
        if args.render or args.contact_sheet or args.save_scene is not None:
            _outputs(args, results)
        if args.save_affordance is not None:
            _saved_affordances(args.save_affordance, results)
        if args.save_profile is not None and not _save_profiles(args, results, config):
            return EXIT_FAILED
    except (RailError, KeyboardInterrupt) as exc:
        return report_error(exc, json_out=args.json)
    return EXIT_OK if all(r.error is None for r in results) else EXIT_FAILED

