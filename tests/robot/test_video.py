"""The robot's video: an mp4 (imageio + its bundled ffmpeg) whose fixed camera keeps the arm and the agent in view,
with a caption under every frame."""

from __future__ import annotations

import numpy as np

from rail_mj.robot import RobotConfig, execute
from rail_mj.robot import executor as robot_executor
from rail_mj.robot import video as robot_video
from rail_mj.robot.demo import make_object, plan_offline


def test_execution_video_is_an_mp4_with_the_arm_the_agent_and_a_caption(panda_folder, tmp_path, monkeypatch):
    import imageio.v2 as imageio

    monkeypatch.setattr(robot_video, "VIDEO_SIZE", (160, 120))  # small frames: the test is about the file
    obj = make_object("cup", 0)
    case = plan_offline(obj, "cup")
    cfg = RobotConfig(settle_time=0.5)
    video = tmp_path / "cup.mp4"
    res = execute(obj, case.pose, case.agent_fragment, case.via_poses, case.scoring, config=cfg, render=video,
                  affordance="cup")
    assert res.reachable and res.success
    with imageio.get_reader(video) as reader:
        frames = np.stack([frame for frame in reader]).astype(int)
    expected = res.timings["sim_time"] * robot_video.VIDEO_FPS
    assert frames.shape[1] > 120 and frames.shape[2:] == (160, 3) and abs(len(frames) - expected) <= 2
    first = frames[0, :120]  # the picture; the caption band is under it
    r, g, b = first[..., 0], first[..., 1], first[..., 2]
    assert np.sum((b > 120) & (b > r + 60) & (b > g + 30)) > 0  # the blue ball in the hand
    arm = (np.abs(r - g) < 12) & (np.abs(g - b) < 12) & (r > 120)  # the Panda's white links
    assert arm[:60].mean() > 0.03  # in the upper half of the picture, above the table
    band = frames[-1, 120:]
    r, g, b = band[..., 0], band[..., 1], band[..., 2]
    assert np.median(band) > 200  # a light band ...
    assert np.sum((g > r + 50) & (g > b + 30)) > 20  # ... with the verdict line in green (a success)
    assert np.sum(band.max(axis=2) < 90) > 100  # and dark text (force, phase)


def test_caption_names_object_affordance_verdict_and_peak_force(panda_folder):
    obj = make_object("cup", 0)
    case = plan_offline(obj, "cup")
    res = execute(obj, case.pose, case.agent_fragment, case.via_poses, case.scoring,
                  config=RobotConfig(settle_time=0.5))
    head, forces = robot_executor.caption_lines(obj.name, "cup", res)
    assert head.startswith(f"{obj.name} - affordance 'cup' - SUCCESS (score +")
    assert f"peak hand force {res.peak_force:.1f} N (limit {res.force_limit:.1f} N" in forces
    assert f"{len(res.force_events)} force-limit events" in forces and "IK by mink" in forces
    far = case.via_poses.copy()
    far[:, 0] += 1.5
    miss = execute(obj, case.pose, case.agent_fragment, far, case.scoring)
    assert "UNREACHABLE" in robot_executor.caption_lines(obj.name, None, miss)[0]
    assert "affordance not given" in robot_executor.caption_lines(obj.name, None, miss)[0]
