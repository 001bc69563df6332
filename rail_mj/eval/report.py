"""``report.md`` of an evaluation: the tables, the timings, the rules and a picture of each misclassified case."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from rail_mj.core.errors import RailError
from rail_mj.core.results import AffordanceResult
from rail_mj.core.runfiles import atomic_write_text
from rail_mj.dataset.labels import read_labels
from rail_mj.eval.calibration import calibration, draw_reliability
from rail_mj.eval.summary import RULES, _tables, _timing_table
from rail_mj.render.captions import nothing_to_draw
from rail_mj.render.images import render_result

__all__ = ["RELIABILITY_PNG", "write_report"]

#: The reliability diagram, next to report.md.
RELIABILITY_PNG = "reliability.png"


def _calibration_table(block: dict) -> str:
    """The reliability bins with cases as a table: cases, mean probability and fraction functional per bin."""
    rows = "".join(
        f"| {b['lo']:.1f}-{b['hi']:.1f} | {b['n']} | {b['mean_probability']:.2f} | {b['positive_fraction']:.2f} |\n"
        for b in block["bins"] if b["n"]
    )
    return ("| probability | cases | mean probability | fraction functional |\n|---|---|---|---|\n" + rows)


def write_report(out: Path, summary: dict, lines: Sequence[dict], root: Path, *, render: bool) -> None:
    """report.md: the tables, timings, the rules, and each misclassified case with a picture."""
    wrong = [ln for ln in lines if not ln["correct"]]
    block = summary.get("calibration") or calibration(lines)
    draw_reliability(block, out / RELIABILITY_PNG)
    parts = [
        "# rail_mj evaluation\n",
        _tables(summary),
        "\n## Calibration\n\n" + _calibration_table(block) + f"\n![reliability diagram]({RELIABILITY_PNG})\n",
        "\n## Timing\n\n" + _timing_table(summary),
        "\n## Rules\n\n" + RULES.strip() + "\n",
        f"\n## Misclassified cases ({len(wrong)})\n",
    ]
    if render and wrong:
        (out / "renders").mkdir(exist_ok=True)
        how = {r.mesh: r for r in read_labels(root)}  # each mesh is drawn read as it was classified
    for ln in wrong:
        r = AffordanceResult.model_validate(ln["result"])
        verdict = "error" if ln["error"] else ("functional" if ln["predicted"] else "not functional")
        parts.append(
            f"\n### {ln['mesh']} — {ln['affordance']}: predicted {verdict}, label "
            f"{'functional' if ln['label'] else 'not functional'}\n\n"
            + (f"Error: {ln['error']}\n" if ln["error"] else "Reasons: " + "; ".join(r.analyzer_reasons) + "\n")
        )
        if render and not ln["error"] and nothing_to_draw(r) is not None:
            parts.append(f"\n({nothing_to_draw(r)})\n")
        elif render and not ln["error"]:
            png = out / "renders" / (ln["key"].replace("/", "_").replace("::", "__") + ".png")
            try:
                label = how[ln["mesh"]]
                render_result(root / ln["mesh"], r, png, units=label.units, up=label.up)
                parts.append(f"\n![{ln['key']}](renders/{png.name})\n")
            except RailError as exc:
                parts.append(f"\n(render failed: {exc})\n")
    atomic_write_text(out / "report.md", "".join(parts))
