"""The robot's video: an mp4 (imageio + its bundled ffmpeg) whose fixed camera keeps the arm and the agent in view."""

from __future__ import annotations

import numpy as np
import pytest

from rail_mj.errors import RobotError
from rail_mj.robot import RobotConfig, execute
from rail_mj.robot import executor as robot_executor
from rail_mj.robot.demo import make_object, plan_offline
from rail_mj.robot.model import panda_dir


@pytest.fixture(scope="module")
def panda_folder():
    try:
        return panda_dir()
    except RobotError as exc:  # no cache and no registry access
        pytest.skip(f"Panda model unavailable: {exc}")


def test_execution_video_is_an_mp4_with_the_arm_and_the_agent(panda_folder, tmp_path, monkeypatch):
    import imageio.v2 as imageio

    monkeypatch.setattr(robot_executor, "VIDEO_SIZE", (160, 120))  # small frames: the test is about the file
    obj = make_object("cup", 0)
    case = plan_offline(obj, "cup")
    cfg = RobotConfig(settle_time=0.5)
    video = tmp_path / "cup.mp4"
    res = execute(obj, case.pose, case.agent_fragment, case.via_poses, case.scoring, config=cfg, render=video)
    assert res.reachable
    with imageio.get_reader(video) as reader:
        frames = np.stack([frame for frame in reader]).astype(int)
    expected = res.timings["sim_time"] * robot_executor.VIDEO_FPS
    assert frames.shape[1:] == (120, 160, 3) and abs(len(frames) - expected) <= 2
    first = frames[0]
    r, g, b = first[..., 0], first[..., 1], first[..., 2]
    assert np.sum((b > 120) & (b > r + 60) & (b > g + 30)) > 0  # the blue ball in the hand
    arm = (np.abs(r - g) < 12) & (np.abs(g - b) < 12) & (r > 120)  # the Panda's white links
    assert arm[:60].mean() > 0.03  # in the upper half of the picture, above the table
