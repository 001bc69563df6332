"""Meshes: read, repair, decompose into convex hulls (CoACD in a child process), hull quality, the object."""
