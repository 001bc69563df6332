"""``rail_mj.rank`` and ``--rank``: what is this object for, most probable first (issue 22, part 3)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rail_mj.core.results import AffordanceResult
from rail_mj.dataset import shapes
from rail_mj.pipeline import cli
from rail_mj.pipeline.config import RunConfig
from rail_mj.pipeline.rank import rank, ranked
from rail_mj.stable_poses import StablePoseConfig

pytestmark = pytest.mark.usefixtures("shared_cache")


@pytest.fixture(scope="module")
def mug(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rank") / "mug.stl"
    shapes.GENERATORS["cup"](np.random.default_rng(0)).mesh.export(path)
    return path


def _result(name: str, probability: float, functional: bool, error: str | None = None) -> AffordanceResult:
    return AffordanceResult(object="o", affordance=name, requested=name, probability=probability,
                            functional=functional, error=error)


def test_ranked_orders_by_probability_then_verdict_then_name_with_failures_last() -> None:
    rs = [_result("b", 0.2, False), _result("x", 0.9, False, error="MeshError: broken"), _result("c", 0.7, True),
          _result("a", 0.2, False), _result("d", 0.7, False)]
    assert [r.affordance for r in ranked(rs)] == ["c", "d", "a", "b", "x"]


def test_a_mugs_cup_ranks_above_its_chair(mug: Path) -> None:
    config = RunConfig(provider="offline", stable_poses=StablePoseConfig(n_drops=16))
    (ranking,) = rank([mug], ["chair", "cup", "plate"], config=config, workers=1, progress=False)
    names = [r.affordance for r in ranking.results]
    assert names.index("cup") < names.index("chair"), [(r.affordance, r.probability) for r in ranking.results]
    assert ranking.best is not None and ranking.best.affordance == "cup"


def test_rank_cli_prints_one_json_line_per_affordance_most_probable_first(mug: Path, capsys) -> None:
    assert cli.main([str(mug), "--rank", "-a", "chair", "-a", "cup", "--json"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["requested"] for r in lines][0] == "cup" and len(lines) == 2
    assert lines[0]["probability"] >= lines[1]["probability"]


def test_without_rank_an_affordance_is_required(mug: Path, capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        cli.main([str(mug)])
    assert exc.value.code == 2 and "--rank" in capsys.readouterr().err
