"""Stage 0: a use outside the registry becomes a row of a tested kind when the model says one fits, is defined once
per run, is imagined with the kind's physics (no stages 1-6 asked of the model), and is saved as an affordance file
that loads with no model. A row that fails a check goes back to the model with the check's words."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from chat_server import ChatServer, chat_error, completion, offline_completion, schema_name
from messages_server import Reply, request_payload

from rail_mj.affordances import known_affordances, load, unload_all
from rail_mj.affordances.prototypes import Prototype
from rail_mj.affordances.sizes import UseSizes
from rail_mj.core.errors import RailError, StageError
from rail_mj.core.types import SCORING_ARGS
from rail_mj.llm import definition_row, offline
from rail_mj.llm.schemas import AffordanceDefinition, DefinitionRequest, ScoringCode, TaskDescription
from rail_mj.mesh import object_from_mesh
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot.demo import make_object

FRUIT_BOWL = """[[affordance]]
name = "fruit bowl"
kind = "container"
ibd = "A fruit bowl holds a few apples or oranges in an open, wide cavity (rim 20-40 cm across, 6-15 cm deep)."

[affordance.envelope]
height = [0.06, 0.2]
width = [0.18, 0.45]
aspect = [0.0, 0.6]

[affordance.params.droplets]
max_radius = 0.05
"""
BASIS = ["rim 20-40 cm across, 6-15 cm deep: fruit bowls in catalogues", "fruit 6-10 cm across: apples, oranges"]
BOWL = Prototype(role="positive", shape="open_cylinder", length=0.3, width=0.0, height=0.12, wall=0.008,
                 why="a 30 cm fruit bowl 12 cm deep")
LID = Prototype(role="negative", shape="closed_cylinder", length=0.3, width=0.0, height=0.12, why="closed")
SLAB = Prototype(role="positive", shape="slab", length=0.3, width=0.3, height=0.12, why="a block: wrong on purpose")


def _definition(row: str | None, kind: str | None = "container", name: str = "fruit bowl",
                prototypes: tuple[Prototype, ...] = (BOWL, LID)) -> str:
    return AffordanceDefinition(affordance=name, kind=kind, row_toml=row, size_basis=BASIS if row else [],
                                prototypes=list(prototypes) if row else [],
                                reason="a fruit bowl is tested as a bowl is: things dropped in stay").model_dump_json()


class Model:
    """Stage 0 from ``definitions`` in turn; every other stage as the offline library answers it."""

    def __init__(self, *definitions: str) -> None:
        self.definitions = list(definitions)
        self.asked: list[str] = []
        self.repairs: list[str] = []

    def __call__(self, body: dict[str, Any]) -> Reply:
        name = schema_name(body)
        self.asked.append(name)
        if name != "AffordanceDefinition":
            if name not in ("FunctionalPoseVerdict",):
                return chat_error(400, f"the model was not to be asked {name}")
            return offline_completion(body)
        last = body["messages"][-1]["content"]
        if "Your previous answer was rejected" in last:
            self.repairs.append(last)
        return completion(self.definitions.pop(0), model=body["model"])


@pytest.fixture(autouse=True)
def _fresh(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    unload_all()
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("RAIL_MJ_MODEL", "test-model")
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    yield
    unload_all()


def _scaled(kind: str, factor: float):
    """A demo object made ``factor`` times larger (a 30 cm basin from the 15 cm bowl)."""
    mesh = make_object(kind, 0).mesh.copy()
    mesh.apply_scale(factor)
    return object_from_mesh(mesh, name=f"{kind}_x{factor:g}")


def _run(model: Model, objects: list, name: str = "fruit bowl", **settings: Any):
    with ChatServer(model) as server:
        config = RunConfig(provider="openai", backend="native", pose="as_placed", max_retries=1,
                           provider_options={"base_url": server.base_url}, **settings)
        return classify(objects, [name], config=config, progress=False, workers=1)


def test_a_use_a_kind_models_is_a_row_defined_once_and_imagined_with_the_kinds_physics() -> None:
    model = Model(_definition(FRUIT_BOWL))
    bowl, plate = _run(model, [_scaled("bowl", 2.0), _scaled("plate", 1.5)])  # 30 x 12 cm basin, 28 cm plate
    assert model.asked.count("AffordanceDefinition") == 1  # once per run, not per object
    assert "AffordanceAnalysis" not in model.asked and "ScoringCode" not in model.asked  # stages 1-6: the kind's
    assert bowl.error is None and bowl.functional, bowl.analyzer_reasons
    assert plate.error is None and not plate.functional
    assert bowl.definition is not None and "a row of the container kind" in bowl.definition
    assert bowl.profile_check is not None and bowl.profile_check.startswith("proven: positive prototype "
                                                                            "open_cylinder 0.30 x 0.12 m")
    assert "negative prototype closed_cylinder 0.30 x 0.12 m: not functional" in bowl.profile_check
    assert bowl.definition_toml is not None and bowl.definition_toml.endswith(FRUIT_BOWL)
    # the plate had no candidate to put to stage 7: nothing was asked for it
    assert bowl.llm_calls == {"affordance_definition": 1, "functional_pose": 1} and plate.llm_calls == {}
    assert "fruit bowl" in known_affordances()  # registered in this process (and in every worker) for the run


def test_a_row_that_fails_a_check_goes_back_with_the_checks_words() -> None:
    unknown_param = FRUIT_BOWL.replace("max_radius = 0.05", "max_radius = 0.05\nsize = 2")
    model = Model(_definition(unknown_param), _definition(FRUIT_BOWL))
    (bowl,) = _run(model, [_scaled("bowl", 2.0)])
    assert bowl.functional and bowl.llm_repairs == {"affordance_definition": 1}
    assert "unknown key 'size'" in model.repairs[0] and "valid: scale, min_radius, max_radius" in model.repairs[0]


def test_without_a_kind_the_use_keeps_its_own_profile() -> None:
    model = Model(_definition(None, kind=None, name="ladder"))
    with pytest.raises(RailError, match="affordance_analyzer"):  # this model answers no stage 1
        _run(model, [make_object("stool", 0)], name="ladder")
    assert "AffordanceAnalysis" in model.asked  # stage 1 asked of the model: the free-form path, before any object


SIZES = UseSizes(largest=(0.2, 0.45), smallest=(0.06, 0.2), basis=["fruit bowls 20-45 cm across, 6-20 cm deep"])
#: a score that calls every rollout a success: the closed negative passes it, so the proof must send it back
EVERYTHING = ScoringCode(description="every rollout succeeds",
                         source=f"def score({', '.join(SCORING_ARGS)}):\n    return np.ones(agent_pos.shape[0])\n")


class FreeFormModel:
    """Stage 0: no kind; stage 1: the use's sizes and prototypes (a 30 cm bowl, the same closed); stages 2-5 the
    offline bowl's answers for the positive prototype; stage 6 ``scorings`` in turn (the offline bowl's when they
    run out); stage 7 the rules'."""

    def __init__(self, *scorings: ScoringCode) -> None:
        self.scorings = list(scorings)
        self.asked: list[str] = []
        self.repairs: list[str] = []
        self.reference = TaskDescription(affordance="bowl", obb_dims=[0.3, 0.3, 0.12])

    def __call__(self, body: dict[str, Any]) -> Reply:
        name = schema_name(body)
        self.asked.append(name)
        last = body["messages"][-1]["content"]
        if "Your previous answer was rejected" in last:
            self.repairs.append(last)
        task = self.reference
        answers: dict[str, Any] = {
            "AffordanceDefinition": lambda: AffordanceDefinition(
                affordance="fruit bowl", kind=None, row_toml=None, size_basis=[], prototypes=[],
                reason="say no kind fits, to test the free-form path"),
            "AffordanceAnalysis": lambda: offline.offline_analysis(task).model_copy(update={
                "affordance": "fruit bowl", "sizes": SIZES, "prototypes": [BOWL, LID],
                "reason": "one profile for every fruit bowl"}),
            "AgentModel": lambda: offline.offline_agent(task),
            "AgentLayout": lambda: offline.offline_layout(task),
            "MotionPlans": lambda: offline.offline_plans(task),
            "Trajectories": lambda: offline.offline_trajectories(task, offline.offline_layout(task)),
            "ScoringCode": lambda: self.scorings.pop(0) if self.scorings else offline.offline_scoring(task),
        }
        if name == "FunctionalPoseVerdict":
            return offline_completion(body)
        request = request_payload(body)
        if name != "AffordanceDefinition":
            assert request["task"] == {"affordance": "fruit bowl", "obb_dims": None, "scale": 1.0}, request
        return completion(answers[name]().model_dump_json(), model=body["model"])


def test_without_a_kind_one_profile_serves_every_object_and_is_proven_first() -> None:
    """Stages 1-6 once per run for every object (no object dims in the task); its scoring code, which calls the
    closed negative a fruit bowl, goes back with what the simulation saw plan by plan; the repaired profile is
    proven and judges each object, weighed by the sizes stage 1 gave."""
    model = FreeFormModel(EVERYTHING)
    basin, plate, big = _run(model, [_scaled("bowl", 2.0), _scaled("plate", 1.5), _scaled("bowl", 2.6)])
    profile_stages = ["AffordanceAnalysis", "AgentModel", "AgentLayout", "MotionPlans", "Trajectories"]
    assert [model.asked.count(s) for s in profile_stages] == [1] * 5  # once per run, not per object
    assert model.asked.count("ScoringCode") == 2  # one repair round
    (feedback,) = model.repairs
    assert "failed its proof" in feedback and "negative prototype closed_cylinder 0.30 x 0.12 m: functional" in feedback
    assert "Per plan: above: score 1.00" in feedback and "inside the box" in feedback and "on the ground" in feedback
    assert basin.error is None and basin.functional, basin.analyzer_reasons
    assert big.error is None and big.functional, big.analyzer_reasons  # a 39 cm basin: the same profile
    assert plate.error is None and not plate.functional and "smallest dim" in (plate.prior or "")
    assert basin.profile_check is not None and basin.profile_check.startswith("proven: positive prototype")
    assert basin.definition is not None and "written once for every object of the use" in basin.definition
    assert basin.llm_calls["affordance_analyzer"] == 1 and basin.llm_repairs == {"scoring": 1}
    assert "affordance_analyzer" not in plate.llm_calls  # counted once, on the use's first case


def test_a_profile_that_never_passes_its_proof_is_refused_naming_what_failed() -> None:
    model = FreeFormModel(EVERYTHING, EVERYTHING)
    with pytest.raises(StageError, match="failed its proof.*negative prototype closed_cylinder"):
        _run(model, [_scaled("bowl", 2.0)])


def test_every_check_names_what_is_wrong() -> None:
    request = DefinitionRequest(affordance="fruit bowl")
    cases = [
        (FRUIT_BOWL.replace('name = "fruit bowl"', 'name = "bowl for fruit"'), "must be the requested use"),
        (FRUIT_BOWL + '\n[[affordance]]\nname = "x"\nkind = "dish"\nibd = "x"\n', "exactly one"),
        (FRUIT_BOWL.replace('name = "fruit bowl"', 'name = "fruit bowl"\naliases = ["cup"]'), "already registered"),
        (FRUIT_BOWL.replace("height = [0.06, 0.2]", "height = [0.2, 0.06]"), "height"),
        ("not toml [", "not valid TOML"),
    ]
    for row, words in cases:
        answer = AffordanceDefinition.model_validate_json(_definition(row))
        with pytest.raises(Exception, match=words):
            definition_row(request, answer)
    other_kind = AffordanceDefinition(affordance="fruit bowl", kind="dish", row_toml=FRUIT_BOWL, size_basis=BASIS,
                                      prototypes=[BOWL, LID], reason="r")
    with pytest.raises(Exception, match="must equal the answer's kind 'dish'"):
        definition_row(request, other_kind)
    no_basis = AffordanceDefinition(affordance="fruit bowl", kind="container", row_toml=FRUIT_BOWL, size_basis=[],
                                    prototypes=[BOWL, LID], reason="r")
    one_role = no_basis.model_copy(update={"size_basis": BASIS, "prototypes": [BOWL]})
    with pytest.raises(Exception, match="at least one positive and one near-miss negative"):
        definition_row(request, one_role)
    huge = no_basis.model_copy(update={"size_basis": BASIS, "prototypes": [
        BOWL.model_copy(update={"length": 1.5, "height": 0.8}), LID]})
    with pytest.raises(Exception, match="not inside the row's typical sizes"):
        definition_row(request, huge)
    with pytest.raises(Exception, match="size_basis"):
        definition_row(request, no_basis)
    assert definition_row(request, AffordanceDefinition.model_validate_json(_definition(FRUIT_BOWL))) is not None


def test_a_saved_definition_loads_with_no_model(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    from rail_mj.pipeline import cli

    mesh = tmp_path / "basin.stl"
    _scaled("bowl", 2.0).mesh.export(mesh)
    model = Model(_definition(FRUIT_BOWL))
    with ChatServer(model) as server:
        monkeypatch.setenv("OPENAI_BASE_URL", server.base_url)
        rc = cli.main([str(mesh), "-a", "fruit bowl", "--provider", "openai", "--backend", "native",
                       "--save-affordance", str(tmp_path / "saved"), "--json"])
    assert rc == 0, capsys.readouterr().err
    saved = tmp_path / "saved" / "fruit_bowl.toml"
    text = saved.read_text()
    assert "defined by openai:test-model" in text and BASIS[0] in text
    unload_all()
    (row,) = load(saved)
    assert row.name == "fruit bowl" and row.kind == "container"
    json.loads(capsys.readouterr().out.splitlines()[0])


def test_a_row_that_fails_its_proof_goes_back_with_what_the_simulation_saw() -> None:
    """A slab named as the positive prototype cannot hold fruit: the answer comes back with the scores and the
    rules' words, and the repaired answer (a bowl-shaped positive) is proven and used."""
    model = Model(_definition(FRUIT_BOWL, prototypes=(SLAB, LID)), _definition(FRUIT_BOWL))
    (bowl,) = _run(model, [_scaled("bowl", 2.0)])
    assert bowl.functional and bowl.llm_repairs == {"affordance_definition": 1}
    (feedback,) = model.repairs
    assert "failed its proof" in feedback and "positive prototype slab 0.30 x 0.30 x 0.12 m: not functional" in feedback
    assert "Scores per plan: above" in feedback and "What the rules saw" in feedback


def test_a_row_that_never_passes_its_proof_is_refused_naming_what_failed() -> None:
    model = Model(_definition(FRUIT_BOWL, prototypes=(SLAB, LID)), _definition(FRUIT_BOWL, prototypes=(SLAB, LID)))
    with pytest.raises(Exception, match="failed its proof.*positive prototype slab"):
        _run(model, [_scaled("bowl", 2.0)])


def test_the_prompts_examples_pass_their_own_proof() -> None:
    """Stage 0's worked examples (a stool, a bowl) are shown to every model: their prototypes must be proven by the
    registered rows as a model's would be."""
    from rail_mj.affordances import REGISTRY
    from rail_mj.affordances.files import FileRow
    from rail_mj.llm.prompts import _EXAMPLE_DEFINITIONS
    from rail_mj.pipeline.chain import _prototype_runner
    from rail_mj.pipeline.definitions import prover

    for name, kind, prototypes, basis, reason in _EXAMPLE_DEFINITIONS:
        proofs: dict[str, str] = {}
        answer = AffordanceDefinition(affordance=name, kind=kind, row_toml="x", size_basis=basis,
                                      prototypes=prototypes, reason=reason)
        renamed = REGISTRY[name].__class__(**{**REGISTRY[name].__dict__, "name": f"example {name}", "aliases": ()})
        prover(_prototype_runner(RunConfig(backend="native")), proofs)(answer, FileRow(renamed, False))
        assert proofs["x"].startswith("proven:"), (name, proofs)



def test_a_saved_profile_loads_with_no_model(tmp_path: Path) -> None:
    """A proven free-form profile is written as a profile folder before any object; the offline provider imagines
    the use from it, with the sizes its stage 1 gave, and no model."""
    saved = tmp_path / "saved"
    (first,) = _run(FreeFormModel(), [_scaled("bowl", 2.0)], save_affordance=saved)
    folder = saved / "fruit_bowl"
    assert (folder / "agent.urdf").is_file() and "proven: positive prototype" in (folder / "definition.txt").read_text()
    config = RunConfig(provider="offline", backend="native", pose="as_placed", profile_dir=folder)
    basin, plate = classify([_scaled("bowl", 2.0), _scaled("plate", 1.5)], ["fruit bowl"], config=config,
                            progress=False, workers=1)
    assert basin.error is None and basin.functional == first.functional is True, basin.analyzer_reasons
    assert plate.error is None and not plate.functional and "smallest dim" in (plate.prior or "")
    assert basin.llm_calls == {} and basin.definition is None


def test_an_eval_defines_a_use_once_and_counts_its_requests_per_stage(tmp_path: Path) -> None:
    """``python -m rail_mj.eval`` on a labelled set naming a use outside the registry (its label key "fruit_bowl" put
    to the model in words): stage 0 and the profile once for the run, summary.json's requests per stage."""
    from rail_mj.eval import run as rail_eval

    data = tmp_path / "data"
    (data / "meshes").mkdir(parents=True)
    for name, obj, label in (("basin", _scaled("bowl", 2.0), True), ("plate", _scaled("plate", 1.5), False)):
        obj.mesh.export(data / "meshes" / f"{name}.stl")
        with (data / "labels.jsonl").open("a") as fh:
            up = {"functional_up": [0, 0, 1]} if label else {}
            fh.write(json.dumps({"mesh": f"meshes/{name}.stl", "class": name, "affordances": {"fruit_bowl": label},
                                 "nominal_up": [0, 0, 1], **up}) + "\n")
    model = FreeFormModel()
    with ChatServer(model) as server:
        cfg = rail_eval.EvalConfig(dataset={"source": str(data)}, render=False, run={
            "provider": "openai", "backend": "native", "pose": "as_placed", "max_retries": 1,
            "provider_options": {"base_url": server.base_url}})
        summary = rail_eval.run_eval(cfg, tmp_path / "out", progress=False, workers=1)
    assert model.asked.count("AffordanceDefinition") == model.asked.count("AffordanceAnalysis") == 1
    assert summary["classification"]["overall"] == 1.0, summary["classification"]
    assert summary["llm_calls"]["affordance_definition"] == summary["llm_calls"]["scoring"] == 1
    lines = [json.loads(line) for line in (tmp_path / "out" / "results.jsonl").read_text().splitlines()]
    assert sorted(ln["key"] for ln in lines) == ["meshes/basin.stl::fruit_bowl", "meshes/plate.stl::fruit_bowl"]


def test_a_models_stage_7_sees_the_shape_of_each_pose_and_of_the_object_as_it_came() -> None:
    """What the numbers cannot say: which faces the cavity opens through, whether a pose is the one the object came
    in, the object's shape as it came. The rules (the offline provider) read the physics alone and get none."""
    seen: list[dict[str, Any]] = []
    model = Model(_definition(FRUIT_BOWL))

    def responder(body: dict[str, Any]) -> Reply:
        if schema_name(body) == "FunctionalPoseVerdict":
            seen.append(request_payload(body))
        return model(body)

    with ChatServer(responder) as server:
        config = RunConfig(provider="openai", backend="native", pose="as_placed", max_retries=1,
                           provider_options={"base_url": server.base_url})
        (bowl,) = classify([_scaled("bowl", 2.0)], ["fruit bowl"], config=config, progress=False, workers=1)
    assert bowl.functional
    (request,) = seen
    assert request["came_in"]["open_faces"] == ["top"] and request["came_in"]["as_it_came"]
    assert request["poses"][0]["shape"] == request["came_in"]  # as placed: the pose it came in
