"""The robot experiment: its task list, its figures, resuming a run, and (slow) one whole task."""

from __future__ import annotations

import json

import pytest

from rail_mj.affordances import PAPER_AFFORDANCES
from rail_mj.robot.experiment import TASKS, Task, format_table, run_experiment, run_task, summarize
from rail_mj.robot.request import parse_request


def test_tasks_cover_the_registry_beyond_the_papers_eight():
    names = [t.name for t in TASKS]
    assert len(names) == len(set(names)) >= 18
    affordances = {parse_request(t.request).affordance for t in TASKS}
    assert len(affordances) >= 15
    assert len(affordances - set(PAPER_AFFORDANCES)) >= 13  # issue 15: 13 of them beyond the paper's


def _row(name: str, success: bool, agree: bool | None, peak: float) -> dict:
    return {"task": name, "request": "put the doll on the chair", "affordance": "chair", "executed": True,
            "success": success, "agree": agree, "peak_force": peak, "force_limit": 15.0, "force_events": 1,
            "true": {"functional": True}, "scan": None if agree is None else {"functional": agree, "seconds": 4.0,
                                                                              "chamfer_m": 0.002},
            "seconds": {"parse": 0.001, "execute": 3.0}}


def test_summary_figures():
    rows = [_row("a", True, True, 12.0), _row("b", False, False, 18.0)]
    s = summarize(rows, scan=True, scan_note=None)
    assert s["success_rate"] == 0.5 and s["verdict_agreement"] == 0.5 and s["n_compared"] == 2
    assert s["peak_over_limit"] == pytest.approx(1.2) and s["n_force_events"] == 2
    assert s["scan_seconds_mean"] == 4.0 and s["chamfer_mm_mean"] == pytest.approx(2.0)
    table = format_table(rows)
    assert "18.0/15.0" in table and table.count("\n") == 3


def test_a_resumed_run_keeps_finished_rows(tmp_path, monkeypatch):
    done = _row("kept", True, None, 10.0)
    (tmp_path / "summary.jsonl").write_text(json.dumps(done) + "\n{torn")
    ran = []

    def fake(task, **kw):
        ran.append(task.name)
        return _row(task.name, True, None, 1.0)

    monkeypatch.setattr("rail_mj.robot.experiment.run_task", fake)
    tasks = (Task("kept", "demo:cup", 0, "put the water in the cup"),
             Task("new", "demo:cup", 1, "put water in the cup"))
    s = run_experiment(tasks=tasks, scan=False, json_path=tmp_path / "summary.json", progress=None)
    assert ran == ["new"] and s["n_tasks"] == 2
    assert [json.loads(x)["task"] for x in (tmp_path / "summary.jsonl").read_text().splitlines()[-1:]] == ["new"]
    assert json.loads((tmp_path / "summary.json").read_text())["success_rate"] == 1.0


@pytest.mark.slow
def test_one_whole_task_doll_on_stool():
    row = run_task(Task("doll_stool", "demo:stool", 1, "put the doll on the stool"), scan=False)
    assert row["agent"] == "doll" and row["affordance"] == "stool" and row["true"]["functional"]
    assert row["executed"] and row["success"] and row["peak_force"] <= 1.2 * row["force_limit"]


def test_the_scan_is_available_where_the_loader_can_load_open3d(monkeypatch):
    # open3d-cpu needs libusb, which the loader preloads from a wheel; a bare `import open3d` refused the scan
    # on a machine without the system library although the scan itself ran
    from rail_mj.robot import experiment
    from rail_mj.robot.scan import ScanError

    calls = []
    monkeypatch.setattr("rail_mj.robot.scan.load_open3d", lambda: calls.append(1))
    assert experiment.scan_available() is None and calls

    def missing():
        raise ScanError("the scan needs open3d, an optional extra")

    monkeypatch.setattr("rail_mj.robot.scan.load_open3d", missing)
    assert "open3d" in experiment.scan_available()


def test_a_plan_on_a_scan_turned_half_a_turn_is_carried_out_on_the_real_object_the_same_way_round():
    # as_placed_pose may turn a scanned model's footprint box half a turn: the doll shelf's scan did, and its plan
    # "left" (+y on the scan: the shelf's open front) was pushed into the real shelf's back wall
    import numpy as np

    from rail_mj.core.types import StablePose
    from rail_mj.robot.control import RobotConfig
    from rail_mj.robot.experiment import plan_in_true_frame

    robot = RobotConfig()
    half = np.array([0.1, 0.06, 0.05])
    # the scanned mesh: world coordinates, its base brought down from the table top to z = 0
    scan_base_world = np.array([0.0, 0.0, robot.table_height])
    turned = StablePose(pos=np.array([robot.object_xy[0], robot.object_xy[1], 0.0]), quat=np.array([0.0, 0, 0, 1]),
                        probability=1.0, half_extents=half)
    true_origin = np.array([*robot.object_xy, robot.table_height + half[2]])
    via = np.array([[0.0, 0.1, 0.02, 1, 0, 0, 0], [0.0, 0.0, 0.02, 1, 0, 0, 0]])
    out = plan_in_true_frame(via, turned, scan_base_world - true_origin)
    assert np.allclose(out[:, :3], [[0.0, -0.1, 0.02], [0.0, 0.0, 0.02]])  # the same side of the real object
    assert np.allclose(np.abs(out[:, 3:]), [0, 0, 0, 1])  # the item turned with the frame

    straight = StablePose(pos=np.array([-robot.object_xy[0], -robot.object_xy[1], 0.0]), quat=np.array([1.0, 0, 0, 0]),
                          probability=1.0, half_extents=half)
    assert np.allclose(plan_in_true_frame(via, straight, scan_base_world - true_origin), via)


def test_a_task_that_cannot_run_stops_the_run_with_its_error_and_keeps_the_finished_rows(tmp_path, monkeypatch):
    from rail_mj.core.errors import ConfigError

    def fake(task, **kw):
        if task.name == "bad":
            raise ConfigError("object 'wardrobe' is out of the arm's reach")
        return _row(task.name, True, None, 1.0)

    monkeypatch.setattr("rail_mj.robot.experiment.run_task", fake)
    tasks = (Task("good", "demo:cup", 0, "put the water in the cup"),
             Task("bad", "demo:cup", 1, "put water in the cup"))
    with pytest.raises(ConfigError, match="wardrobe"):
        run_experiment(tasks=tasks, scan=False, json_path=tmp_path / "summary.json", progress=None)
    assert [json.loads(x)["task"] for x in (tmp_path / "summary.jsonl").read_text().splitlines()] == ["good"]


def test_the_experiment_meets_the_issue_24_task_counts():
    assert len(TASKS) >= 36
    assert sum(t.real for t in TASKS) >= 8
    assert sum(t.decline for t in TASKS) >= 8
    assert sum(len(t.beside) >= 2 for t in TASKS) >= 4


def test_summary_counts_declines_choices_and_the_judge():
    rows = [_row("a", True, True, 12.0), _row("b", False, True, 10.0)]
    rows[0].update(expect="execute", plan_success=True, agree_judge=True, n_objects=3, right_choice=True,
                   real=True)
    rows[1].update(expect="decline", declined=True, executed=False, peak_force=0.0, plan_success=None,
                   agree_judge=None, n_objects=1, right_choice=True)
    s = summarize(rows, scan=True, scan_note=None)
    assert s["success_rate"] == 1.0 and s["n_positive"] == 1 and s["decline_rate"] == 1.0
    assert s["n_declines"] == 1 and s["n_tables"] == 1 and s["right_choice_rate"] == 1.0 and s["n_real"] == 1
    assert s["judge_plan_agreement"] == 1.0
