"""Image and video files: PNGs and JPEGs by Pillow, mp4 videos by imageio and its bundled ffmpeg.

Nothing in rail_mj writes image files by hand.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
from PIL import Image

from rail_mj.core.errors import ConfigError, RailError

__all__ = ["write_image", "write_frames"]


def write_image(path: str | Path, rgb: np.ndarray) -> Path:
    """Write an (H, W, 3) uint8 image; the format follows the suffix (PNG, JPEG, ...), by Pillow."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8)).save(path)
    except (ValueError, KeyError) as exc:  # Pillow's errors for an unknown suffix
        raise ConfigError(f"cannot write {path}: {exc}; give a .png or .jpg path") from exc
    return path


def write_frames(frames: Sequence[np.ndarray], path: str | Path, *, fps: int = 25) -> Path:
    """Write (H, W, 3) uint8 frames: an H.264 mp4 when ``path`` ends in .mp4 (imageio's bundled ffmpeg),
    else numbered PNGs ``frame_00000.png`` ... in the folder ``path``."""
    if not frames:
        raise RailError(f"no frames to write to {path}")
    path = Path(path)
    if path.suffix.lower() == ".mp4":
        path.parent.mkdir(parents=True, exist_ok=True)
        h, w = frames[0].shape[:2]
        # H.264 with yuv420p needs even sides: crop the last row/column of an odd frame
        even = [np.ascontiguousarray(f[: h - h % 2, : w - w % 2]) for f in frames]
        with imageio.get_writer(path, fps=fps, codec="libx264", pixelformat="yuv420p", macro_block_size=1) as writer:
            for frame in even:
                # imageio types get_writer's result as the base class, without the writer's methods
                writer.append_data(frame)  # pyright: ignore[reportAttributeAccessIssue]
        return path
    path.mkdir(parents=True, exist_ok=True)
    for i, frame in enumerate(frames):
        write_image(path / f"frame_{i:05d}.png", frame)
    return path
