"""The real Anthropic SDK client against a loopback Messages API server: no key, no internet."""

from __future__ import annotations

import json

import pytest
from messages_server import (
    MessagesServer,
    Reply,
    error_reply,
    offline_answer,
    schema_title,
    text_reply,
)

from rail_mj.core.errors import FragmentError, ProviderError, StageError
from rail_mj.core.profile import AgentLayout
from rail_mj.core.results import BasinInfo
from rail_mj.llm import (
    AgentModel,
    AgentModelRequest,
    AnalyzerRequest,
    AnthropicProvider,
    LayoutRequest,
    TaskDescription,
    analyze_affordance,
    generate_agent_model,
    generate_layout,
    generate_profile,
)
from rail_mj.llm.checks import check_agent
from rail_mj.llm.offline import offline_agent, offline_analysis

CUP = TaskDescription(affordance="cup", obb_dims=[0.12, 0.09, 0.09])
BROKEN_MJCF = ('<mujoco><worldbody><body name="drop"><geom type="spheroid" size="0.01" mass="0.001"/></body>'
               '</worldbody></mujoco>')


@pytest.fixture
def provider_for(tmp_path, monkeypatch):
    """Build a provider pointed at a server, with its own cache folder and a short SDK backoff."""
    monkeypatch.delenv("RAIL_MJ_NO_CACHE", raising=False)

    def make(server: MessagesServer, **kw) -> AnthropicProvider:
        opts = {"api_key": "test-key", "base_url": server.base_url, "cache_root": tmp_path / "cache",
                "model": "test-model", "timeout": 10.0, **kw}
        return AnthropicProvider(**opts)

    return make


def _bad_agent_then_offline(bad: str, times: int):
    """Answer AgentModel with broken MJCF ``times`` times, everything else like the offline library."""
    count = {"n": 0}

    def responder(body):
        if schema_title(body) == "AgentModel" and count["n"] < times:
            count["n"] += 1
            return text_reply(AgentModel(name="drop", description="a droplet", mjcf=bad).model_dump_json())
        return offline_answer(body)

    return responder


def test_full_profile_through_all_stages(provider_for):
    with MessagesServer() as server:
        profile = generate_profile("cup", CUP.obb_dims, provider_for(server))
    offline_profile = generate_profile("cup", CUP.obb_dims, "offline")
    assert profile.provider == "anthropic" and profile.model == "test-model"
    assert (profile.model_dump(exclude={"provider", "model"})
            == offline_profile.model_dump(exclude={"provider", "model"}))
    titles = [schema_title(b) for b in server.requests]
    assert titles == ["AffordanceAnalysis", "AgentModel", "AgentLayout", "MotionPlans", "Trajectories", "ScoringCode"]
    first = server.requests[0]
    assert first["model"] == "test-model" and first["temperature"] == pytest.approx(0.1)
    assert first["output_config"]["format"]["type"] == "json_schema"
    assert "Example 1 answer" in first["system"]  # few-shot from the offline library
    auth = {k.lower(): v for k, v in server.headers[0].items()}
    assert "test-key" in (auth.get("x-api-key", "") + auth.get("authorization", ""))


def test_invalid_mjcf_is_repaired_with_the_error_text(provider_for):
    with pytest.raises(FragmentError) as err:
        check_agent(AgentModel(name="drop", description="a droplet", mjcf=BROKEN_MJCF), CUP)
    with MessagesServer(_bad_agent_then_offline(BROKEN_MJCF, 1)) as server:
        agent = generate_agent_model(AgentModelRequest(task=CUP, analysis=offline_analysis(CUP)), provider_for(server))
    assert agent == offline_agent(CUP)
    assert len(server.requests) == 2
    second = server.requests[1]["messages"]
    assert [m["role"] for m in second] == ["user", "assistant", "user"]
    assert json.loads(second[1]["content"])["mjcf"] == BROKEN_MJCF
    assert str(err.value) in second[2]["content"]


def test_retries_exhausted_names_stage_and_problem(provider_for):
    with MessagesServer(_bad_agent_then_offline(BROKEN_MJCF, 99)) as server:
        provider = provider_for(server, max_retries=2)
        with pytest.raises(StageError, match=r"agent_model.*3 attempts.*last problem") as err:
            generate_agent_model(AgentModelRequest(task=CUP, analysis=offline_analysis(CUP)), provider)
    assert len(server.requests) == 3
    assert "spheroid" in str(err.value)


def test_schema_violation_is_repaired(provider_for):
    agent = offline_agent(CUP)
    good = AgentLayout(nx=3, ny=3, nz=3, sx=0.02, sy=0.02, sz=0.02, collide_agents=True)
    replies = iter([text_reply(json.dumps({**good.model_dump(), "nx": 0})), text_reply(good.model_dump_json())])
    with MessagesServer(lambda body: next(replies)) as server:
        layout = generate_layout(LayoutRequest(task=CUP, analysis=offline_analysis(CUP), agent=agent),
                                 provider_for(server))
    assert layout == good
    repair = server.requests[1]["messages"][-1]["content"]
    assert "does not match the schema" in repair and "nx" in repair


def test_second_run_is_served_from_cache(provider_for, monkeypatch):
    with MessagesServer() as server:
        provider = provider_for(server)
        first = generate_profile("bowl", [0.2, 0.2, 0.08], provider)
        n = len(server.requests)
        second = generate_profile("bowl", [0.2, 0.2, 0.08], provider)
        assert len(server.requests) == n == 6 and second == first
        generate_profile("bowl", [0.2, 0.2, 0.08], provider_for(server, cache=False))
        assert len(server.requests) == 2 * n
        monkeypatch.setenv("RAIL_MJ_NO_CACHE", "1")
        generate_profile("bowl", [0.2, 0.2, 0.08], provider)
        assert len(server.requests) == 3 * n


@pytest.mark.parametrize(("status", "kind"), [(429, "rate_limit_error"), (500, "api_error")])
def test_sdk_retries_429_and_500(provider_for, status, kind):
    failures = iter([error_reply(status, kind)])

    def responder(body):
        return next(failures, None) or offline_answer(body)

    with MessagesServer(responder) as server:
        analysis = analyze_affordance(AnalyzerRequest(task=CUP), provider_for(server, http_retries=2))
    assert analysis == offline_analysis(CUP)
    assert len(server.requests) == 2


def test_persistent_500_is_a_provider_error(provider_for):
    with MessagesServer(lambda body: error_reply(500, "api_error")) as server:
        with pytest.raises(ProviderError, match="HTTP 500"):
            analyze_affordance(AnalyzerRequest(task=CUP), provider_for(server, http_retries=1))
    assert len(server.requests) == 2


def test_timeout_is_a_provider_error(provider_for):
    def slow(body):
        reply = offline_answer(body)
        return Reply(reply.status, reply.body, delay_s=1.5)

    with MessagesServer(slow) as server:
        with pytest.raises(ProviderError, match="did not answer within 0.3 s"):
            analyze_affordance(AnalyzerRequest(task=CUP), provider_for(server, timeout=0.3, http_retries=0))


def test_missing_key_is_a_config_error(monkeypatch):
    from rail_mj.core.errors import ConfigError

    monkeypatch.delenv("ANTHROPIC_API_KEY", raising=False)
    with pytest.raises(ConfigError, match="ANTHROPIC_API_KEY"):
        AnthropicProvider()


def test_functional_pose_analyzer_through_the_client(provider_for):
    from rail_mj.core.profile import CandidateInteraction, PoseCandidates, ResultSummary
    from rail_mj.llm import FunctionalPoseRequest, analyze_functional_poses

    summary = ResultSummary(frac_inside_bbox=0.9, frac_on_ground=0.0, frac_touching_object=0.8, mean_height=-0.4,
                            object_tilt_deg=1.0, agent_tilt_deg=5.0, agent_speed=0.0)
    request = FunctionalPoseRequest(affordance="cup", expected_outcome="filled", poses=[PoseCandidates(
        pose_index=3, probability=0.7, half_extents=[0.04, 0.04, 0.05],
        basin=BasinInfo(rim=0.095, opening=[0.0, 0.0], length=0.07),
        candidates=[CandidateInteraction(plan="above", description="drop from above",
                                         via_poses=[[0.0, 0.0, 0.1], [0.0, 0.0, 0.06]], score=0.4, summary=summary)],
    )])
    with MessagesServer() as server:
        verdict = analyze_functional_poses(request, provider_for(server))
    assert (verdict.best_pose, verdict.best_plan) == (3, "above")
    assert schema_title(server.requests[0]) == "FunctionalPoseVerdict"
