"""The error rule of rail_mj.core.cli in every command line: exit 0/1/2/130, ``error:`` on stderr, JSON errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

import rail_mj.mesh.repair as mesh_repair
import rail_mj.pipeline.chain as pipeline
from rail_mj import llm
from rail_mj.__main__ import main as rail_main
from rail_mj.core.errors import ConfigError, DatasetError, RobotError
from rail_mj.dataset import procedural as dataset
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot import __main__ as robot_cli

pytestmark = pytest.mark.usefixtures("shared_cache")


@pytest.fixture
def garbage_stl(tmp_path: Path) -> Path:
    path = tmp_path / "noise.stl"
    path.write_bytes(np.random.default_rng(0).bytes(4096))
    return path


@pytest.fixture
def no_work(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if any mesh is read or any provider is asked."""
    monkeypatch.setattr(pipeline, "load_object", lambda *a, **k: pytest.fail("no mesh may be read"))
    monkeypatch.setattr(llm, "task_profile", lambda *a, **k: pytest.fail("no provider may be asked"))


@pytest.mark.parametrize("provider", ["offline", "anthropic"])
@pytest.mark.parametrize("name", ["", "   "])
def test_empty_affordance_is_refused_before_any_work(
    garbage_stl: Path, no_work: None, monkeypatch: pytest.MonkeyPatch, capsys, provider: str, name: str
) -> None:
    monkeypatch.setenv("ANTHROPIC_API_KEY", "sk-test-not-used")
    assert rail_main([str(garbage_stl), "-a", "cup", "-a", name, "--provider", provider, "--json"]) == 2
    out, err = capsys.readouterr()
    error = json.loads(out)
    assert error["type"] == "ConfigError" and "non-empty" in error["error"] and "cup, cupboard" in error["error"]
    assert err == f"error: {error['error']}\n"


def test_library_refuses_empty_names_before_any_work(garbage_stl: Path, no_work: None) -> None:
    with pytest.raises(ConfigError, match="no affordance requested.*cup"):
        classify([garbage_stl], [], config=RunConfig(provider="offline"), progress=False)
    with pytest.raises(ConfigError, match="non-empty"):
        pipeline.Pipeline(RunConfig(provider="offline")).classify_object(garbage_stl, ["cup", ""])


def test_unknown_offline_affordance_exits_2_with_the_known_names(garbage_stl: Path, no_work: None, capsys) -> None:
    assert rail_main([str(garbage_stl), "-a", "sofa", "--provider", "offline", "--json"]) == 2
    out, err = capsys.readouterr()
    error = json.loads(out)
    assert error["type"] == "UnknownAffordanceError" and "known: basket, bathtub" in error["error"]
    assert err.startswith("error: no offline imagination profile for affordance 'sofa'")


def test_mesh_error_exits_1_with_an_error_result(garbage_stl: Path, capsys) -> None:
    assert rail_main([str(garbage_stl), "-a", "cup", "--provider", "offline", "--json"]) == 1
    out, err = capsys.readouterr()
    (result,) = [json.loads(line) for line in out.splitlines()]
    assert result["error"].startswith("MeshError: ") and "is not a valid STL file" in result["error"]
    assert result["dims_fit"] is None and result["functional"] is False  # no check ran, none passed
    assert err.startswith("error: ") and "is not a valid STL file" in err

    assert rail_main([str(garbage_stl), "-a", "cup", "--provider", "offline"]) == 1
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("error: ") and "charset" not in err


def test_error_results_never_claim_the_dimension_check_passed(garbage_stl: Path) -> None:
    (result,) = classify([garbage_stl], ["cup"], config=RunConfig(provider="offline"), progress=False)
    assert result.error and result.dims_fit is None


def test_interrupt_exits_130(garbage_stl: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline, "classify", interrupted)
    assert rail_main([str(garbage_stl), "-a", "cup", "--json"]) == 130
    out, err = capsys.readouterr()
    assert json.loads(out) == {"error": "interrupted", "type": "KeyboardInterrupt"} and err == "error: interrupted\n"


def test_bad_units_are_a_usage_error(garbage_stl: Path, capsys) -> None:
    with pytest.raises(SystemExit) as info:
        rail_main([str(garbage_stl), "-a", "cup", "--units", "0"])
    assert info.value.code == 2 and "--units: must be a positive number" in capsys.readouterr().err


def test_decimation_is_reported(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    monkeypatch.setattr(mesh_repair, "FACE_BUDGET", 500)
    path = tmp_path / "block.ply"
    # 768 faces; a block, so its one hull is exact and the hull-quality guard adds no note of its own
    trimesh.creation.box(extents=(0.06, 0.05, 0.04)).subdivide().subdivide().subdivide().export(path)
    # a 6 cm block is no bathtub: the run stops at the dimension check, after loading and stable poses
    assert rail_main([str(path), "-a", "bathtub", "--provider", "offline", "--json"]) == 0
    (result,) = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    (note,) = result["mesh_notes"]
    assert note.startswith("decimated from 768 to ") and note.endswith(" faces (face budget 500)")
    assert result["dims_fit"] is False
    assert rail_main([str(path), "-a", "bathtub", "--provider", "offline"]) == 0
    assert f"  mesh: {note}\n" in capsys.readouterr().out


# ---- python -m rail_mj.robot ----------------------------------------------------------


@pytest.mark.parametrize(
    ("exc", "code", "message"),
    [
        (ConfigError("no demo plan for 'sofa'"), 2, "no demo plan for 'sofa'"),
        (RobotError("the Panda model is missing"), 1, "the Panda model is missing"),
        (KeyboardInterrupt(), 130, "interrupted"),
    ],
)
def test_robot_cli_exit_status(
    monkeypatch: pytest.MonkeyPatch, capsys, exc: BaseException, code: int, message: str
) -> None:
    def run_demo(*args, **kwargs):
        raise exc

    monkeypatch.setattr(robot_cli, "run_demo", run_demo)
    assert robot_cli.main(["--demo", "--trials", "1"]) == code
    assert capsys.readouterr().err == f"error: {message}\n"


@pytest.mark.parametrize("argv", [["--demo", "--trials", "0"], ["--demo", "--force-limit", "-1"], []])
def test_robot_cli_usage_errors_exit_2(monkeypatch: pytest.MonkeyPatch, argv: list[str]) -> None:
    monkeypatch.setattr(robot_cli, "run_demo", lambda *a, **k: pytest.fail("nothing may run"))
    with pytest.raises(SystemExit) as info:
        robot_cli.main(argv)
    assert info.value.code == 2


# ---- python -m rail_mj.dataset --------------------------------------------------------


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--classes", "mug"], "error: unknown classes 'mug'; valid classes: cup"),
        (["--affordances", "sofa"], "error: unknown affordances 'sofa'; valid affordances: cup"),
        (["--per-class", "0"], "error: --per-class must be >= 1, got 0"),
    ],
)
def test_dataset_cli_usage_errors_exit_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys, argv: list[str], message: str
) -> None:
    monkeypatch.setattr(dataset, "generate", lambda *a, **k: pytest.fail("nothing may be generated"))
    assert dataset.main(["--out", str(tmp_path), *argv]) == 2
    assert capsys.readouterr().err.startswith(message)


@pytest.mark.parametrize(
    ("exc", "message"),
    [
        (DatasetError("generator for 'cup' made an invalid mesh: not watertight"), "error: generator for 'cup'"),
        (PermissionError(13, "Permission denied"), "error: cannot write the dataset to "),
    ],
)
def test_dataset_cli_generation_failure_exits_1(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys, exc: Exception, message: str
) -> None:
    def generate(*args, **kwargs):
        raise exc

    monkeypatch.setattr(dataset, "generate", generate)
    assert dataset.main(["--out", str(tmp_path), "--classes", "cup", "--per-class", "1"]) == 1
    assert capsys.readouterr().err.startswith(message)
