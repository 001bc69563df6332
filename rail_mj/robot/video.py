"""The execution's video: frame size and rate, the renderer, the fixed camera, the captioned frames written.

One camera keeps the arm and the agent in view for the whole execution; the frames go to an mp4 or a folder of
PNG frames (:func:`rail_mj.render.files.write_frames`), each with its caption under it.
"""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np

from rail_mj.mjcf import OWNER_OTHER
from rail_mj.robot.arm import HOME_QPOS
from rail_mj.robot.scene import RobotScene

__all__ = [
    "VIDEO_SIZE",
    "VIDEO_FPS",
    "video_renderer",
    "video_camera",
    "write_video",
]

#: Video frames: (width, height) in pixels and frames per simulated second.
VIDEO_SIZE = (640, 480)
VIDEO_FPS = 25


def video_renderer(model: mujoco.MjModel) -> mujoco.Renderer:
    """A renderer of :data:`VIDEO_SIZE` frames of ``model`` (its offscreen buffer grown to fit; no shadows, no
    multisampling)."""
    # software GL spends ~0.6 s a frame on the shadow map and multisampling: ~25 ms without them
    model.light_castshadow[:] = False
    model.vis.quality.offsamples = 0
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, VIDEO_SIZE[0])
    model.vis.global_.offheight = max(model.vis.global_.offheight, VIDEO_SIZE[1])
    return mujoco.Renderer(model, height=VIDEO_SIZE[1], width=VIDEO_SIZE[0])


def video_camera(scene: RobotScene, sols: np.ndarray, targets: list[tuple[np.ndarray, np.ndarray]]
                 ) -> mujoco.MjvCamera:
    """One fixed camera for the whole video: from the side of the base-to-object line, a little in front,
    fitted to the arm in its home posture and at every IK solution, the agent's path and the object."""
    from rail_mj.render.scene import fit_camera

    model = scene.model
    data = mujoco.MjData(model)
    robot = scene.geom_owner == OWNER_OTHER
    points = [p for p, _ in targets]
    for q in [HOME_QPOS, *sols]:
        data.qpos[scene.arm.qpos] = q
        mujoco.mj_kinematics(model, data)
        points.extend(data.geom_xpos[robot])
    signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    points.extend(scene.task_origin + signs * scene.half_extents)
    side = math.degrees(math.atan2(scene.task_origin[1], scene.task_origin[0])) + 120.0
    return fit_camera(np.array(points), side, -22.0, fovy=float(model.vis.global_.fovy),
                      aspect=VIDEO_SIZE[0] / VIDEO_SIZE[1])


def write_video(frames: list[np.ndarray], frame_info: list[tuple[float, str, float]], limit: float, path: Path,
                lines: list[str], success: bool) -> None:
    """Every frame (``frame_info``: its time s, phase and hand force N) with the caption under it: the fixed
    ``lines``, then the frame's time, phase and hand force (red over the force ``limit``, N)."""
    from rail_mj.render.captions import with_caption
    from rail_mj.render.files import write_frames

    ok = (30, 150, 60) if success else (190, 40, 30)
    size = max(10, VIDEO_SIZE[0] // 40)
    captioned = []
    for pixels, (t, phase, force) in zip(frames, frame_info):
        live = f"t = {t:5.2f} s - {phase} - hand force {force:5.1f} N" + (" - FORCE LIMIT" if force > limit else "")
        captioned.append(with_caption(pixels, [(lines[0], ok), (lines[1], (20, 20, 20)),
                                               (live, (190, 40, 30) if force > limit else (20, 20, 20))], size))
    # a live line that wraps on a narrow frame makes its band taller: an mp4 needs one frame size
    height = max(f.shape[0] for f in captioned)
    captioned = [np.pad(f, ((0, height - f.shape[0]), (0, 0), (0, 0)), mode="edge") for f in captioned]
    write_frames(captioned, path, fps=VIDEO_FPS)
