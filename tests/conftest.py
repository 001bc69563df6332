"""Shared test set-up: CPU JAX without async dispatch (MJX loops deadlocked with it here)."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax  # noqa: E402

jax.config.update("jax_cpu_enable_async_dispatch", False)
