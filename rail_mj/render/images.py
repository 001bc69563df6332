"""Pictures of results, for people: the object in a pose with the agents where the imagination left them.

* :func:`render_result` draws one picture: the result's evidence pose (its functional pose when it has one)
  with the agents' final positions, and a caption under it (object, affordance, verdict, pose index and
  probability, plan and score, and what the object is drawn as).
* :func:`render_contact_sheet` draws every stable pose with its best-scoring plan as one grid image; it
  re-runs those rollouts (one batched call) because a result keeps the final agents of one rollout only.
* :func:`~rail_mj.render.captions.nothing_to_draw` says why a result has no picture (a failed case, a failed
  dimension check).

The scene and its camera are :mod:`rail_mj.render.scene`, the captions :mod:`rail_mj.render.captions`, the
files :mod:`rail_mj.render.files`.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from PIL import Image, ImageDraw

from rail_mj import llm
from rail_mj.core.errors import RailError
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject, StablePose
from rail_mj.imagination import imagine
from rail_mj.imagination.inputs import agent_setup, trajectory_array
from rail_mj.mesh import load_object
from rail_mj.render.captions import (
    _CAPTION_BG,
    _CAPTION_FG,
    _FUNCTIONAL_RGB,
    _best_plan,
    _drawn_as,
    _notes,
    _verdict,
    caption,
    nothing_to_draw,
    with_caption,
)
from rail_mj.render.files import write_image
from rail_mj.render.scene import GROUND_SQUARE_M, _draw, _placement_state, _scene, placed_state

__all__ = ["ContactSheet", "result_profile", "render_result", "render_contact_sheet", "pose_picture"]


@dataclass(frozen=True)
class ContactSheet:
    """A written contact sheet: one tile per stable pose, row-major, each with its best-scoring plan."""

    path: Path
    tiles: tuple[tuple[int, int], ...]  # (stable pose index, plan index) per tile
    columns: int
    tile_size: tuple[int, int]  # (width, height) of a tile's picture, caption excluded


def _load(obj: RailObject | str | Path, units: float, up: Literal["z", "y"]) -> RailObject:
    if isinstance(obj, RailObject):
        return obj
    return load_object(Path(obj), units=units, up=up)


def result_profile(obj: RailObject, result: AffordanceResult, profile=None):
    """The :class:`~rail_mj.llm.ImaginationProfile` ``result`` was imagined with: ``profile`` when given, else
    asked again of the result's provider (the offline library, or the LLM answer cache). A profile whose agent or
    plans differ from the result's is refused (RailError)."""
    if profile is None:
        profile = llm.generate_profile(result.requested, [float(d) for d in obj.obb_dims], result.provider or "offline")
    if profile.agent.mjcf != result.agent_fragment or [p.name for p in profile.plans.plans] != result.plans:
        raise RailError(
            f"{result.object} / {result.requested}: the profile's agent or plans are not the ones the result was "
            "imagined with (another provider, model or cache); pass the profile the result came from"
        )
    return profile


def render_result(
    obj: RailObject | str | Path,
    result: AffordanceResult,
    path: str | Path,
    *,
    units: float = 1.0,
    up: Literal["z", "y"] = "z",
    draw_mesh: bool = False,
    width: int = 640,
    height: int = 480,
) -> Path:
    """Write a picture of the result's evidence pose (its functional pose when it has one) with the final
    agents of that rollout, and a caption. ``obj`` is the loaded object or its mesh file (read with ``units``
    and ``up``, as it was classified). Raises RailError, with :func:`nothing_to_draw`'s words, when the result
    holds no rollout."""
    why = nothing_to_draw(result)
    if why is not None:
        raise RailError(why)
    assert result.evidence_pose is not None  # nothing_to_draw says so
    obj = _load(obj, units, up)
    text = caption(result, obj, draw_mesh=draw_mesh)
    state = _placement_state(result, int(result.evidence_pose), np.asarray(result.evidence_agent_pos), None)
    model, data, body, agents = _scene(obj, result.agent_fragment, state, draw_mesh=draw_mesh, width=width,
                                       height=height)
    pixels, view = _draw(model, data, body, agents, width, height)
    lines = [(text[0], _FUNCTIONAL_RGB if result.functional else _CAPTION_FG), (text[1], _CAPTION_FG),
             (f"{text[2]}; {_notes(view, len(agents))}", _CAPTION_FG)]
    return write_image(path, with_caption(pixels, lines, size=max(12, width // 40)))


def pose_picture(obj: RailObject, fragment: str, pose: StablePose, agent_pos: np.ndarray, agent_quat: np.ndarray,
                 *, width: int = 512, height: int = 384) -> bytes:
    """A PNG of ``obj`` resting in ``pose`` with the agents (``fragment``) at their task-frame end positions and
    orientations, the object in its hull shades, the agents blue, on a 10 cm checker ground: what stage 7's model
    sees of a pose. RailError when no offscreen renderer can be made."""
    state = placed_state(pose, np.asarray(agent_pos, dtype=np.float64), np.asarray(agent_quat, dtype=np.float64))
    model, data, body, agents = _scene(obj, fragment, state, draw_mesh=False, width=width, height=height)
    pixels, _ = _draw(model, data, body, agents, width, height)
    out = io.BytesIO()
    Image.fromarray(pixels).save(out, format="PNG")
    return out.getvalue()


def _columns(n: int) -> int:
    return max(1, min(4, math.ceil(math.sqrt(n))))


def render_contact_sheet(
    obj: RailObject | str | Path,
    result: AffordanceResult,
    path: str | Path,
    *,
    units: float = 1.0,
    up: Literal["z", "y"] = "z",
    draw_mesh: bool = False,
    profile=None,
    tile: tuple[int, int] = (360, 270),
) -> ContactSheet:
    """Write one grid image: every stable pose of the result with its best-scoring plan, the agents where
    that rollout left them (re-imagined in one batched call on the result's backend), each tile captioned,
    the functional pose framed in green, and the result's caption on top.

    ``profile`` is the :class:`~rail_mj.llm.ImaginationProfile` the result was imagined with; by default it
    is asked again of the result's provider (the offline library, or the LLM answer cache). A profile whose
    agent or plans differ from the result's is refused (RailError)."""
    why = nothing_to_draw(result)
    if why is not None:
        raise RailError(why)
    obj = _load(obj, units, up)
    profile = result_profile(obj, result, profile)
    n = len(result.stable_poses)
    plans = [_best_plan(result, i) for i in range(n)]
    poses = [p.to_pose() for p in result.stable_poses]
    trajectories = [[trajectory_array(profile.trajectories.trajectories, p.half_extents, p.basin)[j]]
                    for p, j in zip(poses, plans)]
    outcomes = imagine(obj, poses, agent_setup(profile.agent.mjcf, profile.layout), trajectories,
                       backend=result.backend or "native")

    tw, th = tile
    size = max(11, tw // 30)
    functional = result.functional_pose.index if result.functional_pose is not None else None
    tiles = []
    for i, j in enumerate(plans):
        state = _placement_state(result, i, outcomes.agent_pos[i], outcomes.agent_quat[i],
                                 (outcomes.object_pos[i], outcomes.object_quat[i]))
        model, data, body, agents = _scene(obj, result.agent_fragment, state, draw_mesh=draw_mesh, width=tw, height=th)
        pixels, view = _draw(model, data, body, agents, tw, th)
        mark = " - FUNCTIONAL POSE" if i == functional else ""
        lines = [(f"pose #{i} (p = {result.stable_poses[i].probability:.2f}){mark}",
                  _FUNCTIONAL_RGB if i == functional else _CAPTION_FG),
                 (f"plan {result.plans[j]!r} - score {result.scores[i][j]:.2f}", _CAPTION_FG)]
        if view.translucent:
            lines.append((f"object translucent ({view.hidden} of {len(agents)} agents hidden)", _CAPTION_FG))
        tiles.append(with_caption(pixels, lines, size))
    cols = _columns(n)
    rows = math.ceil(n / cols)
    cell_h = max(t.shape[0] for t in tiles)
    gap = 6
    sheet_w = cols * tw + (cols + 1) * gap
    head = with_caption(np.zeros((0, sheet_w, 3), dtype=np.uint8), [
        (_verdict(result), _FUNCTIONAL_RGB if result.functional else _CAPTION_FG),
        (f"every stable pose (most probable first) with its best-scoring plan; "
         f"{_drawn_as(obj, draw_mesh)}; agents in blue; ground squares {100 * GROUND_SQUARE_M:.0f} cm", _CAPTION_FG),
    ], size=max(13, size + 2))
    sheet = Image.new("RGB", (sheet_w, head.shape[0] + rows * (cell_h + gap) + gap), _CAPTION_BG)
    sheet.paste(Image.fromarray(head), (0, 0))
    draw = ImageDraw.Draw(sheet)
    for k, t in enumerate(tiles):
        x, y = gap + (k % cols) * (tw + gap), head.shape[0] + gap + (k // cols) * (cell_h + gap)
        sheet.paste(Image.fromarray(t), (x, y))
        if k == functional:
            draw.rectangle([x - 3, y - 3, x + tw + 2, y + t.shape[0] + 2], outline=_FUNCTIONAL_RGB, width=3)
    out = write_image(path, np.asarray(sheet))
    return ContactSheet(path=out, tiles=tuple((i, j) for i, j in enumerate(plans)), columns=cols, tile_size=tile)
