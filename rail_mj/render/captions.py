"""What a picture says: whether a result has one at all, its caption lines and the caption band under it."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from rail_mj.core.errors import RailError
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.render.scene import GROUND_SQUARE_M, _View

__all__ = [
    "nothing_to_draw",
    "caption",
    "with_caption",
]

_CAPTION_BG = (250, 250, 247)
_CAPTION_FG = (20, 20, 20)
_FUNCTIONAL_RGB = (30, 150, 60)


# ---------------------------------------------------------------- what can be drawn


def nothing_to_draw(result: AffordanceResult) -> str | None:
    """Why ``result`` has no picture, in plain words; None when it has one."""
    head = f"{result.object} / {result.requested}: nothing to draw"
    if result.error:
        return f"{head}: the case failed ({result.error})"
    if result.dims_fit is False and not result.scores:  # an unusual size is still imagined; an absurd one not
        reason = "; ".join(result.analyzer_reasons) or "the object's size is outside the affordance's range"
        return f"{head}: the dimension check failed, so no interaction was imagined ({reason})"
    if result.evidence_pose is None or not result.stable_poses:
        return f"{head}: the result holds no imagined rollout"
    return None


def _best_plan(result: AffordanceResult, pose: int) -> int:
    """The plan of the result's kept rollout for ``pose`` (its best plan when that is the functional pose)."""
    if result.best_plan is not None and result.functional_pose is not None and pose == result.functional_pose.index:
        return result.best_plan.index
    return int(np.argmax(result.scores[pose])) if result.scores else 0


# ---------------------------------------------------------------- captions


def _font(size: int):
    return ImageFont.load_default(size=size)


def _wrap(text: str, font, width: int) -> list[str]:
    words, lines, line = text.split(), [], ""
    for w in words:
        trial = f"{line} {w}".strip()
        if line and font.getlength(trial) > width:
            lines.append(line)
            line = w
        else:
            line = trial
    return lines + ([line] if line else [])


def with_caption(pixels: np.ndarray, lines: Sequence[tuple[str, tuple[int, int, int]]], size: int) -> np.ndarray:
    """The picture with a caption band under it; each line wraps to the picture's width."""
    font = _font(size)
    h, w = pixels.shape[:2]
    pad, step = max(4, size // 2), int(size * 1.3)
    rows = [(part, colour) for text, colour in lines for part in _wrap(text, font, w - 2 * pad)]
    band = 2 * pad + step * len(rows)
    img = Image.new("RGB", (w, h + band), _CAPTION_BG)
    img.paste(Image.fromarray(pixels), (0, 0))
    draw = ImageDraw.Draw(img)
    for k, (text, colour) in enumerate(rows):
        draw.text((pad, h + pad + k * step), text, fill=colour, font=font)
    return np.asarray(img)


def _drawn_as(obj: RailObject, draw_mesh: bool) -> str:
    if draw_mesh:
        return f"object drawn as its original mesh ({len(obj.mesh.faces)} faces)"
    return f"object drawn as its {len(obj.hulls)} CoACD convex hulls (one shade per hull)"


def _verdict(result: AffordanceResult) -> str:
    asked = "" if result.requested == result.affordance else f" (asked: {result.requested!r})"
    return (f"{result.object} - affordance {result.affordance!r}{asked} - "
            f"{'FUNCTIONAL' if result.functional else 'NOT FUNCTIONAL'}")


def _pose_line(result: AffordanceResult, pose: int, plan: int) -> str:
    p = result.stable_poses[pose]
    score = result.scores[pose][plan] if result.scores else float("nan")
    name = result.plans[plan] if plan < len(result.plans) else "?"
    return (f"pose #{p.index} (p = {p.probability:.2f}, of {len(result.stable_poses)}) - plan {name!r} - "
            f"score {score:.2f}")


def _notes(view: _View, n_agents: int) -> str:
    notes = [f"agents in blue ({n_agents})", f"ground squares {100 * GROUND_SQUARE_M:.0f} cm"]
    if view.translucent:
        notes.append(f"object drawn translucent: {view.hidden} agents are behind it in every good view")
    return "; ".join(notes)


def caption(result: AffordanceResult, obj: RailObject, *, draw_mesh: bool = False) -> list[str]:
    """The caption lines of :func:`render_result`'s picture (before the view's notes): object, affordance and
    verdict; the pose drawn, its probability, its plan and score; what the object is drawn as."""
    why = nothing_to_draw(result)
    if why is not None:
        raise RailError(why)
    assert result.evidence_pose is not None  # nothing_to_draw says so
    pose = int(result.evidence_pose)
    kept = "functional pose" if result.functional else "best-scoring rollout (no functional pose)"
    return [_verdict(result), f"{kept}: {_pose_line(result, pose, _best_plan(result, pose))}",
            _drawn_as(obj, draw_mesh)]
