"""``classify``: the chain end to end for many objects, spread over worker processes or Ray tasks."""

from rail_mj.pipeline.chain import Pipeline, as_placed_pose, classify
from rail_mj.pipeline.config import ObjectInput, PoseMode, RunConfig, RunOptions

__all__ = ["ObjectInput", "Pipeline", "PoseMode", "RunConfig", "RunOptions", "as_placed_pose", "classify"]
