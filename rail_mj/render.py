"""Pictures of results: the object in a pose with the agents where the imagination left them.

Headless: ``import rail_mj`` sets ``MUJOCO_GL=egl`` unless it is set (MuJoCo reads it at import).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rail_mj.errors import RailError
from rail_mj.results import AffordanceResult
from rail_mj.types import AgentSetup, RailObject

__all__ = ["render_result", "render_png"]


def render_png(model, data, path: Path, *, width: int = 640, height: int = 480, lookat=None, distance=None) -> Path:
    """Render one frame of ``data`` with a free camera aimed at ``lookat`` and write a PNG."""
    import mujoco

    try:
        renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:  # MuJoCo raises plain exceptions when no GL context can be made
        raise RailError(f"cannot create an offscreen renderer ({exc}); set MUJOCO_GL=egl or osmesa") from exc
    cam = mujoco.MjvCamera()
    cam.lookat[:] = lookat if lookat is not None else model.stat.center
    cam.distance = distance if distance is not None else 2.5 * model.stat.extent
    cam.azimuth, cam.elevation = 135.0, -55.0  # steep enough to see into containers
    renderer.update_scene(data, camera=cam)
    pixels = renderer.render()
    renderer.close()
    _write_png(path, pixels)
    return path


def _write_png(path: Path, rgb: np.ndarray) -> None:
    """Minimal PNG writer (no imaging dependency): 8-bit RGB, zlib-compressed rows."""
    import struct
    import zlib

    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[i].astype(np.uint8).tobytes() for i in range(h))

    def chunk(tag: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF)

    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(raw, 6))
        + chunk(b"IEND", b"")
    )


def render_result(
    obj: RailObject | str | Path, result: AffordanceResult, path: Path, *, units: float = 1.0, up: str = "z"
) -> Path:
    """The object in the result's evidence pose (its functional pose when it has one) with the agents."""
    import mujoco

    from rail_mj.mjcf import build_scene
    from rail_mj.objects import load_object

    if not isinstance(obj, RailObject):
        obj = load_object(Path(obj), units=units, up=up)
    if result.evidence_pose is None:
        raise RailError(f"{result.object} / {result.affordance}: the result holds no imagined rollout to render")
    pose = result.stable_poses[result.evidence_pose]
    h = np.asarray(pose.half_extents)
    agents = None
    if result.agent_fragment and result.evidence_agent_pos:
        agents = AgentSetup(fragment=result.agent_fragment, offsets=np.asarray(result.evidence_agent_pos), collide_agents=True)
    spec = build_scene(
        obj,
        object_pos=pose.pos,
        object_quat=pose.quat,
        object_free=False,
        agents=agents,
        agents_pos=(0.0, 0.0, float(h[2])),  # the task-frame origin of this pose
    )
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return render_png(model, data, path, lookat=np.array([0.0, 0.0, h[2]]), distance=3.5 * float(np.max(h)) + 0.1)
