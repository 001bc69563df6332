"""End to end: the pipeline and `python -m rail_mj.eval` on tiny datasets (offline provider)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from rail_mj.core.errors import UnknownAffordanceError
from rail_mj.core.runfiles import folder_lock
from rail_mj.dataset.labels import read_labels
from rail_mj.dataset.procedural import generate
from rail_mj.eval import cli as eval_cli
from rail_mj.eval import run as rail_eval
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import ObjectInput, RunConfig

SUMMARY_KEYS = {"classification", "functional_pose", "baseline_dims", "timing", "config"}


@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory) -> Path:
    """One cup (affords "cup") and one solid cylinder (affords nothing), in random poses."""
    root = tmp_path_factory.mktemp("ds")
    generate(root, classes=["cup", "solid_cylinder"], per_class=1, seed=3, affordances=["cup"])
    return root


@pytest.fixture(scope="module")
def eval_run(tiny_dataset, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("eval")
    cfg = rail_eval.EvalConfig(dataset={"source": str(tiny_dataset)}, affordances=["cup"], run={"provider": "offline"},
                              render=False)
    rail_eval.run_eval(cfg, out, progress=False)
    return out


def test_classify_positive_and_negative(tiny_dataset):
    records = {r.class_name: r for r in read_labels(tiny_dataset)}
    items = [ObjectInput(path=tiny_dataset / records[c].mesh, name=c) for c in ("cup", "solid_cylinder")]
    cup, cylinder = classify(items, ["cup"], config=RunConfig(provider="offline"), progress=False)
    assert cup.error is None and cylinder.error is None
    assert cup.functional and not cylinder.functional
    # the predicted functional pose puts the labelled opening direction up
    up = records["cup"].functional_up
    dot = sum(a * b for a, b in zip(cup.functional_pose.up_in_mesh_frame, up))
    assert dot > 0.94
    assert cup.best_plan is not None and cup.best_plan.score > 0
    assert len(cup.scores) == len(cup.stable_poses) and len(cup.scores[0]) == len(cup.plans)
    json.loads(cup.model_dump_json())  # JSON-serialisable


def test_classify_unknown_affordance_lists_known(tiny_dataset):
    with pytest.raises(UnknownAffordanceError, match="known"):
        classify([tiny_dataset / "nothing.obj"], ["flux capacitor"], config=RunConfig(provider="offline"),
                 progress=False)


def test_eval_writes_results_summary_report(eval_run):
    lines = [json.loads(s) for s in (eval_run / "results.jsonl").read_text().splitlines()]
    assert len(lines) == 2 and all(ln["error"] is None for ln in lines)
    summary = json.loads((eval_run / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(summary)
    assert summary["classification"]["overall"] == 1.0
    assert set(summary["classification"]["per_affordance"]) == {"cup"}
    assert summary["functional_pose"]["overall"] == 1.0
    assert {"overall", "without_analyzer"} <= set(summary["functional_pose"])
    report = (eval_run / "report.md").read_text()
    assert "Table 1" in report and "Table 2" in report and "dimensions only" in report


def test_resume_skips_finished_lines(eval_run, tiny_dataset, tmp_path):
    out = tmp_path / "resumed"
    shutil.copytree(eval_run, out)
    lines = (out / "results.jsonl").read_text().splitlines()
    # a run killed mid-way: one finished line and a torn one
    (out / "results.jsonl").write_text(lines[0] + "\n" + lines[1][:20])
    cfg = rail_eval.EvalConfig(dataset={"source": str(tiny_dataset)}, affordances=["cup"], run={"provider": "offline"},
                              render=False)
    with pytest.raises(rail_eval.ConfigError, match="--resume"):
        rail_eval.run_eval(cfg, out, progress=False)
    summary = rail_eval.run_eval(cfg, out, resume=True, progress=False)
    kept = [json.loads(s) for s in (out / "results.jsonl").read_text().splitlines()
            if s.startswith("{") and s.endswith("}")]
    assert sorted(ln["key"] for ln in kept) == sorted(json.loads(s)["key"] for s in lines)
    assert summary["n_cases"] == 2 and summary["complete"]


def test_resume_keeps_one_line_per_case(eval_run, tiny_dataset, tmp_path):
    out = tmp_path / "resumed"
    shutil.copytree(eval_run, out)
    lines = (out / "results.jsonl").read_text().splitlines()
    # two runs that appended the same cases (before the output lock)
    (out / "results.jsonl").write_text("\n".join(lines + lines[:1]) + "\n")
    cfg = rail_eval.EvalConfig(dataset={"source": str(tiny_dataset)}, affordances=["cup"], run={"provider": "offline"},
                              render=False)
    summary = rail_eval.run_eval(cfg, out, resume=True, progress=False)
    assert (out / "results.jsonl").read_text().splitlines() == lines
    assert summary["n_cases"] == summary["n_expected"] == 2 and summary["complete"]


def test_resume_rebuilds_a_dataset_an_older_run_left_partial(eval_run, tmp_path):
    out = tmp_path / "out"
    cfg = rail_eval.EvalConfig(dataset={"classes": ["cup", "solid_cylinder"], "per_class": 1, "seed": 3},
                               affordances=["cup"], run={"provider": "offline"}, render=False)
    generate(out / "dataset", classes=cfg.dataset.classes, per_class=1, seed=3, affordances=["cup"])
    labels = (out / "dataset" / "labels.jsonl").read_text().splitlines()
    # killed while writing labels one by one, then killed after evaluating the one object listed
    (out / "dataset" / "labels.jsonl").write_text(labels[0] + "\n")
    cup = next(s for s in (eval_run / "results.jsonl").read_text().splitlines() if "cup_000" in s)
    (out / "results.jsonl").write_text(cup + "\n")
    summary = rail_eval.run_eval(cfg, out, resume=True, progress=False)
    assert (out / "dataset" / "labels.jsonl").read_text().splitlines() == labels
    assert summary["n_cases"] == summary["n_expected"] == 2 and summary["complete"]


def test_resumed_dataset_is_rebuilt_for_another_seed_and_reused_for_the_same(tmp_path, capsys):
    def dataset(seed: int) -> list[str]:
        cfg = rail_eval.EvalConfig(dataset={"classes": ["cup", "solid_cylinder"], "per_class": 1, "seed": seed},
                                   affordances=["cup"], run={"provider": "offline"}, render=False)
        root, _ = rail_eval._dataset(cfg, tmp_path, ["cup"])
        return [p.read_bytes().hex() for p in sorted((root / "meshes").iterdir())]

    first = dataset(3)
    assert dataset(3) == first and "rebuilding" not in capsys.readouterr().err
    other = dataset(4)  # class counts match, so only the recorded spec can tell the seeds apart
    assert other != first and "seed" in capsys.readouterr().err
    (tmp_path / "dataset" / rail_eval.DATASET_SPEC).unlink()  # a dataset from before specs were written
    assert dataset(4) == other and "dataset_spec.json" in capsys.readouterr().err


def test_cli_second_run_on_one_out_names_the_holder(tmp_path, capsys):
    out = tmp_path / "out"
    with folder_lock(out, advice="wait"):
        assert eval_cli.main(["--out", str(out), "--classes", "cup", "--per-class", "1", "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"error: {out} is in use by another run (pid {os.getpid()} on ")
    assert not (out / "dataset").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--per-class", "0"], "--per-class 0: Input should be greater than or equal to 1"),
        (["--drops", "3"], "--drops 3: Input should be greater than or equal to 8"),
        (["--classes", "cup,mug"], "--classes: unknown 'mug'; valid: cup, bowl, vase"),
        (["--affordances", "cup,sofa"], "--affordances: unknown 'sofa'; valid: cup, bowl"),
    ],
)
def test_cli_bad_option_values(tmp_path, capsys, argv, message):
    assert eval_cli.main(["--out", str(tmp_path / "o"), "--no-progress", *argv]) == 2
    assert message in capsys.readouterr().err


def test_broken_mesh_becomes_an_error_line(tiny_dataset, tmp_path, capsys):
    ds = tmp_path / "ds"
    shutil.copytree(tiny_dataset, ds)
    records = read_labels(ds)
    (ds / records[0].mesh).write_text("this is not a mesh\n")
    out = tmp_path / "out"
    argv = ["--dataset", str(ds), "--affordances", "cup", "--provider", "offline", "--no-render", "--no-progress"]
    assert eval_cli.main([*argv, "--out", str(out)]) == 1  # the CLI rule: some input failed
    lines = [json.loads(s) for s in (out / "results.jsonl").read_text().splitlines()]
    broken = next(ln for ln in lines if ln["mesh"] == records[0].mesh)
    assert broken["error"] and "MeshError" in broken["error"] and broken["correct"] is False
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_errors"] == 1 and summary["n_cases"] == 2 and summary["complete"]
    assert f"error: {broken['key']}: MeshError" in capsys.readouterr().err


def test_cli_mesh_labelled_twice(tiny_dataset, tmp_path, capsys):
    ds = tmp_path / "ds"
    shutil.copytree(tiny_dataset, ds)
    first = (ds / "labels.jsonl").read_text().splitlines()[0]
    (ds / "labels.jsonl").write_text((ds / "labels.jsonl").read_text() + first + "\n")
    assert eval_cli.main(["--dataset", str(ds), "--out", str(tmp_path / "o"), "--no-progress"]) == 1
    assert f"lists {json.loads(first)['mesh']} more than once" in capsys.readouterr().err


def test_cli_bad_dataset_folder(tmp_path, capsys):
    assert eval_cli.main(["--dataset", str(tmp_path), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    assert "labels.jsonl" in capsys.readouterr().err


def test_one_object_cli_json_and_render(tiny_dataset, tmp_path, capsys):
    from rail_mj.__main__ import main as cli

    cup = next(r for r in read_labels(tiny_dataset) if r.class_name == "cup")
    png = tmp_path / "cup.png"
    assert cli([str(tiny_dataset / cup.mesh), "-a", "cup", "--provider", "offline", "--json",
                "--render", str(png)]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[0])
    assert result["functional"] and result["functional_pose"]["index"] >= 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 2000


def test_one_object_cli_bad_mesh(tmp_path, capsys):
    from rail_mj.__main__ import main as cli

    bad = tmp_path / "empty.obj"
    bad.write_text("")
    assert cli([str(bad), "-a", "cup", "--provider", "offline"]) == 1
    assert "MeshError" in capsys.readouterr().err
