"""Shared test set-up: CPU JAX without async dispatch (MJX loops deadlocked with it here); the Panda model."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax  # noqa: E402

jax.config.update("jax_cpu_enable_async_dispatch", False)


import pytest  # noqa: E402

from rail_mj.core.errors import RobotError  # noqa: E402
from rail_mj.robot.model import panda_dir  # noqa: E402


@pytest.fixture(scope="session")
def panda_folder():
    """The Menagerie Panda's folder (fetched into the cache on first use); skips when it cannot be had."""
    try:
        return panda_dir()
    except RobotError as exc:  # no cache and no registry access
        pytest.skip(f"Panda model unavailable: {exc}")
