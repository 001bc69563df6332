"""Stable poses: batched drops, verified quasi-static poses, clustering, the spill basin of each pose."""

from rail_mj.stable_poses.basin import spill_basin
from rail_mj.stable_poses.config import StablePoseConfig
from rail_mj.stable_poses.poses import find_stable_poses, pose_from_up

__all__ = ["StablePoseConfig", "find_stable_poses", "pose_from_up", "spill_basin"]
