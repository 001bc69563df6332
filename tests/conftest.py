"""Shared test set-up: CPU JAX without async dispatch (MJX loops deadlocked with it here); the Panda model."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax  # noqa: E402

jax.config.update("jax_cpu_enable_async_dispatch", False)


from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from rail_mj.core.errors import RobotError  # noqa: E402
from rail_mj.core.paths import CACHE_ENV  # noqa: E402
from rail_mj.robot.model import panda_dir  # noqa: E402


@pytest.fixture(scope="session")
def panda_folder():
    """The Menagerie Panda's folder (fetched into the cache on first use); skips when it cannot be had."""
    try:
        return panda_dir()
    except RobotError as exc:  # no cache and no registry access
        pytest.skip(f"Panda model unavailable: {exc}")


@pytest.fixture
def shared_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    """One cache for the whole session (hulls and stable poses computed once), for modules that use it
    (``pytestmark = pytest.mark.usefixtures("shared_cache")``)."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path_factory.getbasetemp() / "cache"))


@pytest.fixture(scope="module")
def module_cache(tmp_path_factory: pytest.TempPathFactory):
    """One cache for a module's runs, so their hulls and stable poses are computed once and no other module's
    are seen (runs that crash or kill workers, whose cache state the module checks)."""
    path: Path = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(CACHE_ENV, str(path))
        yield path
