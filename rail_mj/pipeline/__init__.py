"""``classify``: the chain end to end for many objects, spread over worker processes or Ray tasks."""

from rail_mj.pipeline.chain import ObjectInput, Pipeline, PoseMode, RunConfig, as_placed_pose, classify

__all__ = ["ObjectInput", "Pipeline", "PoseMode", "RunConfig", "as_placed_pose", "classify"]
