"""Stage 6's check runs the candidate in the sandbox on a synthetic batch of the real shapes, so that the
repair loop sees run-time errors (issue 11 §2): the batch's contract, the messages, the loopback repair."""

from __future__ import annotations

import re
from dataclasses import fields

import numpy as np
import pytest
import trimesh
from messages_server import MessagesServer, offline_answer, schema_title, text_reply

from rail_mj.core.errors import StageError, UnsafeCodeError
from rail_mj.core.profile import ScoringCode
from rail_mj.core.types import SCORING_ARGS, AgentSetup, RailObject
from rail_mj.imagination import ImaginationConfig, imagine
from rail_mj.llm import (
    AnthropicProvider,
    ScoringRequest,
    TaskDescription,
    generate_scoring,
)
from rail_mj.llm.checks import InvalidAnswerError, candidate_half_extents, check_scoring
from rail_mj.llm.offline import (
    known_affordances,
    offline_agent,
    offline_analysis,
    offline_layout,
    offline_plans,
    offline_scoring,
)
from rail_mj.scoring import (
    WorkerStartError,
    close_workers,
    compile_scoring,
    pool,
    probe_outcomes,
)
from rail_mj.stable_poses import pose_from_up

SIGNATURE = f"def score({', '.join(SCORING_ARGS)}):\n"
CUP = TaskDescription(affordance="cup", obb_dims=[0.12, 0.09, 0.09])
DROPLET = ('<mujoco><worldbody><body name="drop"><geom type="sphere" size="0.006" mass="0.001"/></body>'
           '</worldbody></mujoco>')

# (id, body of score, what the repair message must say)
FAILING = [
    ("name-error", "return undefined_name", r"at line 2: NameError: name 'undefined_name' is not defined"),
    ("scalar", "return 1.0", r"returned a scalar \(float\), expected an array of shape \(\d+,\)"),
    ("while-true", "while True:\n    pass", r"timed out after 2 s"),
    ("wrong-axis", "return agent_pos[:, :, 0].sum(axis=0)", r"got shape \(\d+,\)"),
    ("nan", "return np.log(contacts_ground.sum(axis=1) - 1.0)", r"non-finite"),
    ("bad-index", "return agent_pos[:, 0, 5]", r"at line 2: IndexError"),
]


def _body(lines: str) -> str:
    return SIGNATURE + "".join(f"    {line}\n" for line in lines.splitlines())


def _request(task: TaskDescription) -> ScoringRequest:
    return ScoringRequest(task=task, analysis=offline_analysis(task), agent=offline_agent(task),
                          layout=offline_layout(task), plans=offline_plans(task))


def test_probe_batch_has_the_imaginations_names_dtypes_shapes_and_order():
    mesh = trimesh.creation.box(extents=[0.2, 0.1, 0.06])
    box = RailObject(name="box", mesh=mesh, hulls=(np.asarray(mesh.vertices),), mesh_hash="test-box",
                     obb_dims=np.sort(mesh.extents)[::-1], com=mesh.center_mass, mass=1.0, density=500.0)
    poses = [pose_from_up(box, np.array([0.0, 0.0, 1.0]), 0.5), pose_from_up(box, np.array([1.0, 0.0, 0.0]), 0.5)]
    agents = AgentSetup(fragment=DROPLET, offsets=np.array([[0.0, 0.0, 0.0], [0.02, 0.0, 0.0]]))
    plans = [np.array([[0.0, 0.0, 0.1, 1, 0, 0, 0]]), np.array([[0.2, 0.0, 0.05, 1, 0, 0, 0]]),
             np.array([[0.0, 0.2, 0.05, 1, 0, 0, 0]])]
    real = imagine(box, poses, agents, plans, backend="native", config=ImaginationConfig(settle_time=0.05))
    probe = probe_outcomes(2, 3, [p.half_extents for p in poses])
    for f in fields(real):
        want, got = getattr(real, f.name), getattr(probe, f.name)
        if want is None or got is None:  # an optional field (a nominal batch has no world index)
            assert want is None and got is None, f.name
            continue
        assert (got.dtype, got.shape) == (want.dtype, want.shape), f.name
    np.testing.assert_array_equal(probe.pose_index, real.pose_index)
    np.testing.assert_array_equal(probe.plan_index, real.plan_index)
    np.testing.assert_array_equal(probe.object_half_extents, real.object_half_extents)


def test_probe_batch_covers_inside_on_top_beside_and_tipped():
    h = candidate_half_extents(CUP.obb_dims)
    o = probe_outcomes(27, 5, h, seed=0)
    assert o.batch == 5 * len(h)
    hb = o.object_half_extents[:, None, :]
    inside = np.all(np.abs(o.agent_pos) <= hb, axis=-1).all(axis=1)
    on_top = (o.agent_pos[..., 2] > hb[..., 2]).all(axis=1) & (o.contacts_object > 0).all(axis=1)
    on_ground = (o.contacts_ground > 0).all(axis=1)
    tipped = o.object_tilt > 1.0
    assert inside.any() and on_top.any() and on_ground.any() and tipped.any() and not o.settled.all()
    np.testing.assert_allclose(np.linalg.norm(o.agent_quat, axis=-1), 1.0)
    np.testing.assert_array_equal(probe_outcomes(27, 5, h, seed=0).agent_pos, o.agent_pos)


@pytest.mark.parametrize("affordance", known_affordances())
def test_every_offline_scoring_passes_the_runtime_check(affordance):
    for dims in ([0.12, 0.09, 0.09], [0.6, 0.5, 0.45], [1.8, 0.9, 0.6]):  # a cup's, a stool's, a bed's size
        task = TaskDescription(affordance=affordance, obb_dims=dims)
        request = _request(task)
        check_scoring(offline_scoring(task), request)
        assert generate_scoring(request) == offline_scoring(task)


@pytest.mark.parametrize("case_id,lines,message", FAILING, ids=[c[0] for c in FAILING])
def test_runtime_failure_is_an_invalid_answer_that_says_what_went_wrong(case_id, lines, message):
    request = _request(CUP)
    source = _body(lines)
    compile_scoring(source)  # the static check alone accepts every one of them
    with pytest.raises(InvalidAnswerError, match=message) as err:
        check_scoring(ScoringCode(description="bad", source=source), request)
    text = str(err.value)
    n_agents, batch = request.layout.n_agents, len(request.plans.plans) * len(candidate_half_extents(CUP.obb_dims))
    assert f"B={batch} rollouts x N={n_agents} agents" in text
    assert f"agent_pos float64 ({batch}, {n_agents}, 3)" in text
    assert f"contacts_ground int64 ({batch}, {n_agents})" in text


def test_static_rejection_is_still_an_unsafe_code_error():
    with pytest.raises(UnsafeCodeError, match="import statement"):
        check_scoring(ScoringCode(description="bad", source=_body("import os\nreturn object_tilt")), _request(CUP))


def test_a_worker_that_cannot_start_is_not_blamed_on_the_code(monkeypatch):
    def no_worker(cls):
        raise WorkerStartError("could not start a scoring worker: test")

    close_workers()
    monkeypatch.setattr(pool._Worker, "start", classmethod(no_worker))
    with pytest.raises(WorkerStartError):
        check_scoring(offline_scoring(CUP), _request(CUP))


def test_offline_library_answer_failing_at_run_time_is_a_stage_error(monkeypatch):
    from rail_mj.llm import providers

    bad = ScoringCode(description="bad", source=_body("return undefined_name"))
    monkeypatch.setattr(providers.offline, "offline_scoring", lambda task: bad)
    with pytest.raises(StageError, match="offline library.*NameError"):
        generate_scoring(_request(CUP))


@pytest.fixture
def provider_for(tmp_path, monkeypatch):
    monkeypatch.delenv("RAIL_MJ_NO_CACHE", raising=False)

    def make(server: MessagesServer) -> AnthropicProvider:
        return AnthropicProvider(api_key="test-key", base_url=server.base_url, cache_root=tmp_path / "cache",
                                 model="test-model", timeout=10.0)

    return make


def _bad_scoring_then_offline(source: str):
    """Answer ScoringCode with ``source`` once, every later request like the offline library."""
    sent = {"bad": False}

    def responder(body):
        if schema_title(body) == "ScoringCode" and not sent["bad"]:
            sent["bad"] = True
            return text_reply(ScoringCode(description="fails at run time", source=source).model_dump_json())
        return offline_answer(body)

    return responder


@pytest.mark.parametrize("case_id,lines,message", [FAILING[0], FAILING[1]], ids=[FAILING[0][0], FAILING[1][0]])
def test_loopback_run_time_error_is_fed_back_and_the_repair_accepted(provider_for, case_id, lines, message):
    request = _request(CUP)
    bad = _body(lines)
    with MessagesServer(_bad_scoring_then_offline(bad)) as server:
        scoring = generate_scoring(request, provider_for(server))
    assert scoring == offline_scoring(CUP)
    assert [schema_title(b) for b in server.requests] == ["ScoringCode", "ScoringCode"]
    repair = server.requests[1]["messages"]
    assert [m["role"] for m in repair] == ["user", "assistant", "user"]
    assert ScoringCode.model_validate_json(repair[1]["content"]).source == bad
    feedback = repair[2]["content"]
    assert "synthetic batch" in feedback
    assert re.search(message, feedback), feedback


# ---- a profile for every object of a use (a task of no obb_dims) ------------------------------------------------
def _use_analysis(**update):
    from rail_mj.llm.prompts import _EXAMPLE_USE_ANALYSIS

    return _EXAMPLE_USE_ANALYSIS.model_copy(update=update)


USE = TaskDescription(affordance="cup", obb_dims=None)


def test_the_prompts_per_use_example_passes_its_checks() -> None:
    from rail_mj.llm.checks import check_analysis

    check_analysis(_use_analysis(), USE)


@pytest.mark.parametrize("update, words", [
    ({"sizes": None}, "give sizes"),
    ({"fits": False}, "fits must be true"),
    ({"prototypes": []}, "at least one positive and one near-miss negative"),
    ({"sizes": _use_analysis().sizes.model_copy(update={"largest": (0.3, 0.5)})}, "is not inside sizes"),
])
def test_a_per_use_analysis_without_what_the_profile_is_proven_and_weighed_by_is_refused(update, words) -> None:
    from rail_mj.llm.checks import check_analysis

    with pytest.raises(InvalidAnswerError, match=words):
        check_analysis(_use_analysis(**update), USE)


def test_an_object_analysis_gives_no_sizes() -> None:
    from rail_mj.llm.checks import check_analysis

    with pytest.raises(InvalidAnswerError, match="sizes must be null"):
        check_analysis(_use_analysis(), CUP)


def test_a_per_use_answer_is_checked_on_every_extreme_typical_box() -> None:
    from rail_mj.llm.checks import task_half_extents

    halves = task_half_extents(USE, _use_analysis())
    assert len(halves) > len(candidate_half_extents(CUP.obb_dims or []))
    assert min(float(h.min()) for h in halves) == pytest.approx(0.025)  # the smallest's lo, halved
    assert max(float(h.max()) for h in halves) == pytest.approx(0.08)  # the largest's hi, halved
    with pytest.raises(InvalidAnswerError, match="no sizes"):
        task_half_extents(USE, None)
