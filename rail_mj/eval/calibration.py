"""Calibration of the verdicts' probabilities against the labels: the Brier score and a reliability diagram.

The Brier score is the mean of ``(probability - label)**2`` over the cases (0 is perfect; always saying 0.5 scores
0.25). The reliability diagram bins the cases by probability and plots each bin's fraction of positive labels
against its mean probability: a calibrated method lies on the diagonal (a probability of 0.8 is right 80% of the
time). The PNG is drawn with Pillow, a dependency already (no plotting library).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

__all__ = ["BINS", "brier", "reliability", "calibration", "draw_reliability"]

#: Ten equal bins of probability: the usual reliability diagram's resolution.
BINS = 10
_SIZE, _MARGIN = 480, 60  # pixels: the plot's square and the margin for the axes' labels


def brier(probabilities: Sequence[float] | np.ndarray, labels: Sequence[bool] | np.ndarray) -> float | None:
    """Mean squared difference between each probability and its label (1 or 0); None without cases."""
    if not len(probabilities):
        return None
    p, y = np.asarray(probabilities, dtype=float), np.asarray(labels, dtype=float)
    return float(np.mean((p - y) ** 2))


def reliability(probabilities: Sequence[float] | np.ndarray, labels: Sequence[bool] | np.ndarray,
                bins: int = BINS) -> list[dict]:
    """Per bin of probability ([i/bins, (i+1)/bins), the last one closed): its cases, mean probability and
    fraction of positive labels (None in an empty bin)."""
    p, y = np.asarray(probabilities, dtype=float), np.asarray(labels, dtype=float)
    idx = np.minimum((p * bins).astype(int), bins - 1) if len(p) else np.zeros(0, dtype=int)
    out = []
    for i in range(bins):
        sel = idx == i
        n = int(sel.sum())
        out.append({"lo": i / bins, "hi": (i + 1) / bins, "n": n,
                    "mean_probability": float(p[sel].mean()) if n else None,
                    "positive_fraction": float(y[sel].mean()) if n else None})
    return out


def calibration(lines: Sequence[dict]) -> dict[str, Any]:
    """The summary's calibration block from results lines; a failed case is left out (it has no probability)."""
    ok = [ln for ln in lines if ln["error"] is None]
    probs = [float(ln["result"].get("probability", 0.0)) for ln in ok]
    labels = [bool(ln["label"]) for ln in ok]
    return {"brier": brier(probs, labels), "n": len(ok), "bins": reliability(probs, labels)}


def draw_reliability(block: dict, path: Path) -> Path:
    """The reliability diagram of a :func:`calibration` block as a PNG at ``path``."""
    w = _SIZE + 2 * _MARGIN
    img = Image.new("RGB", (w, w), "white")
    d = ImageDraw.Draw(img)

    def xy(px: float, py: float) -> tuple[float, float]:
        return _MARGIN + px * _SIZE, _MARGIN + (1.0 - py) * _SIZE

    d.rectangle([xy(0, 1), xy(1, 0)], outline="black")
    for t in np.linspace(0, 1, 6):
        d.line([xy(t, 0), (xy(t, 0)[0], xy(t, 0)[1] + 5)], fill="black")
        d.text((xy(t, 0)[0] - 8, xy(t, 0)[1] + 8), f"{t:.1f}", fill="black")
        d.line([xy(0, t), (xy(0, t)[0] - 5, xy(0, t)[1])], fill="black")
        d.text((xy(0, t)[0] - 32, xy(0, t)[1] - 6), f"{t:.1f}", fill="black")
    total = max(1, sum(b["n"] for b in block["bins"]))
    points = []
    for b in block["bins"]:
        if not b["n"]:
            continue
        # a bar per bin: its fraction of positives, its width the bin's, shaded by its share of the cases
        shade = int(230 - 150 * math.sqrt(b["n"] / total))
        d.rectangle([xy(b["lo"], b["positive_fraction"]), xy(b["hi"], 0)], fill=(shade, shade, 255),
                    outline=(60, 60, 160))
        points.append(xy(b["mean_probability"], b["positive_fraction"]))
        d.text((xy(b["lo"], 0)[0] + 2, xy(0, 0)[1] - 14), str(b["n"]), fill="black")
    d.line([xy(0, 0), xy(1, 1)], fill=(110, 110, 110), width=1)  # perfect calibration, over the bars
    if len(points) > 1:
        d.line(points, fill=(200, 30, 30), width=2)
    for x, y in points:
        d.ellipse([x - 4, y - 4, x + 4, y + 4], fill=(200, 30, 30))
    score = "-" if block["brier"] is None else f"{block['brier']:.4f}"
    d.text((_MARGIN, 20), f"reliability: {block['n']} cases, Brier score {score}", fill="black")
    d.text((_MARGIN + _SIZE // 2 - 60, w - 30), "predicted probability", fill="black")
    d.text((4, _MARGIN - 30), "fraction functional", fill="black")
    path.parent.mkdir(parents=True, exist_ok=True)
    img.save(path)
    return path
