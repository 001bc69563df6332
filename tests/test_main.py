"""The one ``rail-mj`` command line: subcommands dispatch to each tool's ``main``; no subcommand is ``classify``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import trimesh
from pydantic import ValidationError

from rail_mj.__main__ import COMMANDS, main
from rail_mj.core.errors import ConfigError
from rail_mj.imagination.config import THREADS_ENV, ImaginationConfig
from rail_mj.pipeline.chain import Pipeline, object_task
from rail_mj.pipeline.config import RunConfig
from rail_mj.pipeline.parallel import run_tasks
from rail_mj.pipeline.tasks import ObjectTask
from rail_mj.stable_poses import StablePoseConfig
from rail_mj.stable_poses.config import drop_physics

pytestmark = pytest.mark.usefixtures("shared_cache")


def test_classify_is_the_default_command(tmp_path: Path, capsys) -> None:
    box = tmp_path / "slab.stl"
    trimesh.creation.box(extents=(0.25, 0.25, 0.02)).export(box)
    args = [str(box), "-a", "plate", "--provider", "offline", "--backend", "native", "--json"]
    assert main(["classify", *args]) == 0
    with_command = [json.loads(s) for s in capsys.readouterr().out.splitlines()]
    assert main(args) == 0
    without = [json.loads(s) for s in capsys.readouterr().out.splitlines()]
    assert [r["requested"] for r in with_command] == ["plate"]
    drop = lambda r: {k: v for k, v in r.items() if k != "timings"}  # noqa: E731
    assert list(map(drop, with_command)) == list(map(drop, without))


@pytest.mark.parametrize("command, prog", [("eval", "rail_mj.eval"), ("dataset", "rail_mj.dataset"),
                                           ("robot", "rail_mj.robot"), ("classify", "rail_mj")])
def test_each_command_is_its_tools_main(command: str, prog: str, capsys) -> None:
    with pytest.raises(SystemExit) as exit_:
        main([command, "--help"])
    assert exit_.value.code == 0
    assert f"usage: python -m {prog} " in capsys.readouterr().out


def test_help_lists_the_commands(capsys) -> None:
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert all(f"\n  {name} " in out for name in COMMANDS)


@pytest.mark.parametrize("argv", [["evaluate", "--out", "x"], []])
def test_an_unknown_or_missing_command_is_a_usage_error(argv: list[str], capsys) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "error: " in err and "classify, eval, dataset, robot" in err


def test_python_dash_m_runs_the_dispatcher() -> None:
    out = subprocess.run([sys.executable, "-m", "rail_mj", "nope"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "unknown command 'nope'" in out.stderr


# ---- the config tree ---------------------------------------------------------------------------------------


def test_run_config_nests_each_stages_config_with_todays_defaults() -> None:
    cfg = RunConfig()
    assert cfg.decomposition is None
    assert cfg.stable_poses == StablePoseConfig(n_drops=64) and cfg.stable_poses.physics == drop_physics()
    assert drop_physics() == ImaginationConfig(settle_speed=0.005)
    assert cfg.imagination == ImaginationConfig()
    with pytest.raises(ValidationError, match="stable_poses.n_drops"):
        RunConfig(stable_poses={"n_drops": 0})
    with pytest.raises(ValidationError, match=r"ImaginationConfig.timestep must be a number in \(0, 0.02\]"):
        RunConfig(imagination={"timestep": -1.0})


def test_unset_threads_are_the_running_process_s(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(THREADS_ENV, raising=False)
    built = RunConfig(imagination=ImaginationConfig(nthread=5))  # as a parent builds a task's config
    monkeypatch.setenv(THREADS_ENV, "3")  # as a worker's environment says
    here = Pipeline(built.model_copy(update={"provider": "offline", "backend": "native"})).config
    assert here.imagination.nthread == 5  # set: kept
    assert here.stable_poses.physics.nthread == 3  # left to the default: this process's
    assert here.stable_poses == StablePoseConfig(n_drops=64, physics=ImaginationConfig(settle_speed=0.005, nthread=3))


def test_a_task_callable_must_be_importable_by_name() -> None:
    task = object_task(0, "x.obj", ["cup"], RunConfig())
    unnamed = ObjectTask(**{**task.__dict__, "run": lambda t: "{}"})
    with pytest.raises(ConfigError, match="module-level function"):
        run_tasks([unnamed], workers=1)
