"""Stable poses: batched drops, verified quasi-static poses, clustering, the spill basin of each pose."""
