"""The OpenAI-compatible provider against a loopback chat-completions server: no key, no model, no internet.

It shares the Anthropic provider's validation, repair rounds, cache and prompts (LLMProvider); what is its own
is the request (the stage schema as ``response_format``), the reading of a chat completion, the HTTP errors
and the configuration (OPENAI_BASE_URL, OPENAI_API_KEY, RAIL_MJ_MODEL).
"""

from __future__ import annotations

import json
import re
import socket
from pathlib import Path

import pytest
from chat_server import ChatServer, chat_error, completion, offline_completion, request_payload, schema_name
from messages_server import Reply

from rail_mj.__main__ import main as rail_main
from rail_mj.core.errors import ConfigError, ProviderError, StageError
from rail_mj.core.profile import AgentLayout
from rail_mj.eval.cli import _parser as eval_parser
from rail_mj.llm import (
    AgentModel,
    AgentModelRequest,
    AnalyzerRequest,
    LayoutRequest,
    OpenAIConfig,
    OpenAIProvider,
    TaskDescription,
    analyze_affordance,
    generate_agent_model,
    generate_layout,
    generate_profile,
    get_provider,
)
from rail_mj.llm.offline import offline_agent, offline_analysis
from rail_mj.llm.openai_provider import DEFAULT_BASE_URL, DEFAULT_MODEL, strict_schema
from rail_mj.llm.providers import PROVIDERS
from rail_mj.llm.schemas import Trajectories
from rail_mj.pipeline.chain import Pipeline
from rail_mj.pipeline.config import RunConfig

CUP = TaskDescription(affordance="cup", obb_dims=[0.12, 0.09, 0.09])
ANALYSIS = AnalyzerRequest(task=CUP)
GOOD_ANALYSIS = offline_analysis(CUP).model_dump_json()
BROKEN_MJCF = ('<mujoco><worldbody><body name="drop"><geom type="spheroid" size="0.01" mass="0.001"/></body>'
               "</worldbody></mujoco>")


@pytest.fixture(autouse=True)
def _clean_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    for name in ("OPENAI_API_KEY", "OPENAI_BASE_URL", "RAIL_MJ_MODEL", "RAIL_MJ_NO_CACHE"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path / "cache"))


@pytest.fixture
def provider_for(tmp_path):
    """A provider pointed at a server, with its own cache folder, no cache and no HTTP retries unless asked."""

    def make(server: ChatServer, **kw) -> OpenAIProvider:
        opts = {"base_url": server.base_url, "cache_root": tmp_path / "answers", "model": "test-model",
                "timeout": 10.0, "http_retries": 0, "cache": False, **kw}
        return OpenAIProvider(**opts)

    return make


def _first_then_offline(name: str, bad: Reply, times: int = 1):
    """Answer stage ``name`` ``times`` times with ``bad``, then (and every other stage) like the offline library."""
    sent = {"n": 0}

    def responder(body):
        if schema_name(body) == name and sent["n"] < times:
            sent["n"] += 1
            return bad
        return offline_completion(body)

    return responder


def _repair_of(provider_for, bad: Reply) -> list[dict]:
    """The second request's messages after one ``bad`` answer to the analyser (which then answers well)."""
    with ChatServer(_first_then_offline("AffordanceAnalysis", bad)) as server:
        assert analyze_affordance(ANALYSIS, provider_for(server)) == offline_analysis(CUP)
    assert len(server.requests) == 2
    return server.requests[1]["messages"]


# answers that validate


def test_full_profile_through_all_stages(provider_for):
    with ChatServer() as server:
        profile = generate_profile("cup", CUP.obb_dims, provider_for(server, api_key="sk-local"))
    offline_profile = generate_profile("cup", CUP.obb_dims, "offline")
    assert profile.provider == "openai" and profile.model == "test-model"
    same = {"provider", "model"}
    assert profile.model_dump(exclude=same) == offline_profile.model_dump(exclude=same)
    names = [schema_name(b) for b in server.requests]
    assert names == ["AffordanceAnalysis", "AgentModel", "AgentLayout", "MotionPlans", "Trajectories", "ScoringCode"]
    first = server.requests[0]
    assert first["model"] == "test-model" and first["temperature"] == pytest.approx(0.1)
    assert first["max_tokens"] == 8192
    assert [m["role"] for m in first["messages"]] == ["system", "user"]
    assert "Example 1 answer" in first["messages"][0]["content"]  # the shared prompts, few-shot included
    assert request_payload(first)["task"]["affordance"] == "cup"
    fmt = first["response_format"]
    assert fmt["type"] == "json_schema" and fmt["json_schema"]["strict"] is True
    assert fmt["json_schema"]["schema"]["title"] == "AffordanceAnalysis"
    auth = {k.lower(): v for k, v in server.headers[0].items()}
    assert auth["authorization"] == "Bearer sk-local" and auth["content-type"] == "application/json"


def test_the_strict_schema_requires_every_field_and_allows_no_other():
    schema = strict_schema(Trajectories.model_json_schema())
    via = schema["$defs"]["ViaPose"]
    assert via["required"] == ["rel", "offset_m", "quat", "anchor"] and via["additionalProperties"] is False
    assert all(d["additionalProperties"] is False for d in schema["$defs"].values())
    assert "anchor" not in Trajectories.model_json_schema()["$defs"]["ViaPose"]["required"]  # pydantic's, unchanged
    ref = {"$defs": {"A": {"type": "object", "properties": {"x": {"type": "integer", "default": None}}}},
           "type": "object", "properties": {"a": {"$ref": "#/$defs/A", "description": "inlined"}}}
    a = strict_schema(ref)["properties"]["a"]
    assert a == {"type": "object", "properties": {"x": {"type": "integer"}}, "description": "inlined",
                 "additionalProperties": False, "required": ["x"]}


def test_strict_false_sends_pydantic_schema(provider_for):
    with ChatServer() as server:
        analyze_affordance(ANALYSIS, provider_for(server, strict=False))
    sent = server.requests[0]["response_format"]["json_schema"]
    assert sent["strict"] is False and sent["schema"] == offline_analysis(CUP).model_json_schema()


# repair rounds


def test_invalid_mjcf_is_repaired_with_the_error_text(provider_for):
    bad = completion(AgentModel(name="drop", description="a droplet", mjcf=BROKEN_MJCF).model_dump_json())
    with ChatServer(_first_then_offline("AgentModel", bad)) as server:
        agent = generate_agent_model(AgentModelRequest(task=CUP, analysis=offline_analysis(CUP)),
                                     provider_for(server))
    assert agent == offline_agent(CUP)
    assert len(server.requests) == 2
    second = server.requests[1]["messages"]
    assert [m["role"] for m in second] == ["system", "user", "assistant", "user"]
    assert json.loads(second[2]["content"])["mjcf"] == BROKEN_MJCF  # the model sees what it wrote
    assert "Your previous answer was rejected" in second[3]["content"] and "spheroid" in second[3]["content"]


def test_schema_violation_is_repaired(provider_for):
    good = AgentLayout(nx=3, ny=3, nz=3, sx=0.02, sy=0.02, sz=0.02, collide_agents=True)
    replies = iter([completion(json.dumps({**good.model_dump(), "nx": 0})), completion(good.model_dump_json())])
    with ChatServer(lambda body: next(replies)) as server:
        layout = generate_layout(LayoutRequest(task=CUP, analysis=offline_analysis(CUP), agent=offline_agent(CUP)),
                                 provider_for(server))
    assert layout == good
    repair = server.requests[1]["messages"][-1]["content"]
    assert "does not match the schema" in repair and "nx" in repair


def test_retries_exhausted_is_a_stage_error(provider_for):
    bad = completion(AgentModel(name="drop", description="a droplet", mjcf=BROKEN_MJCF).model_dump_json())
    with ChatServer(_first_then_offline("AgentModel", bad, times=99)) as server:
        with pytest.raises(StageError, match=r"agent_model.*3 attempts \(model test-model\).*last problem.*spheroid"):
            generate_agent_model(AgentModelRequest(task=CUP, analysis=offline_analysis(CUP)),
                                 provider_for(server, max_retries=2))
    assert len(server.requests) == 3


# untrusted replies: each a failed attempt that goes back for repair


def _reply(**fields) -> Reply:
    return Reply(200, {**completion("{}").body, **fields})


NOT_A_COMPLETION = [
    pytest.param(Reply(200, {}, raw="<html>proxy login</html>"), "is not JSON: '<html>proxy login</html>'", id="html"),
    pytest.param(Reply(200, [1, 2]), r"is not a chat completion \(a JSON array\): '\[1, 2\]'", id="array"),
    pytest.param(Reply(200, {"error": {"message": "overloaded"}}), r"not a chat completion \(no choices\).*overloaded",
                 id="error-body"),
    pytest.param(_reply(choices=[]), r"\(no choices\)", id="choices-empty"),
    pytest.param(_reply(choices=["x"]), "a choice without a message", id="choice-junk"),
    pytest.param(completion(None), r"the answer held no text \(finish_reason 'stop'\)", id="content-null"),
    pytest.param(completion(""), r"the answer held no text \(finish_reason 'stop'\)", id="content-empty"),
    pytest.param(completion([{"type": "text"}]), "message content is not text", id="content-list"),  # type: ignore[arg-type]
    pytest.param(completion(None, refusal="I can't help with that."),
                 "the model refused to answer: \"I can't help with that.\"", id="refusal"),
    pytest.param(completion("Sure! A cup holds liquid."), "does not match the schema.*Invalid JSON", id="prose"),
    pytest.param(completion("[1, 2, 3]"), "Input should be an object", id="json-array"),
    pytest.param(completion(json.dumps({**json.loads(GOOD_ANALYSIS), "confidence": 0.9})),
                 "Extra inputs are not permitted", id="extra-field"),
]


@pytest.mark.parametrize(("bad", "named"), NOT_A_COMPLETION)
def test_an_unusable_reply_is_a_failed_attempt(provider_for, bad, named):
    messages = _repair_of(provider_for, bad)
    assert messages[-1]["role"] == "user" and re.search(named, messages[-1]["content"], re.S)


def test_the_model_sees_its_own_wrong_text_but_not_a_broken_reply(provider_for):
    prose = _repair_of(provider_for, completion("Sure! A cup holds liquid."))
    assert [m["role"] for m in prose] == ["system", "user", "assistant", "user"]
    assert prose[2]["content"] == "Sure! A cup holds liquid."
    refused = _repair_of(provider_for, completion(None, refusal="no"))
    assert [m["role"] for m in refused] == ["system", "user", "user"]  # nothing to show back


def test_an_answer_cut_off_at_max_tokens_says_so(provider_for):
    messages = _repair_of(provider_for, completion(GOOD_ANALYSIS[:60], finish_reason="length"))
    repair = messages[-1]["content"]
    assert "cut off at max_tokens=8192 (finish_reason 'length')" in repair and "shorter" in repair
    assert "EOF while parsing" in repair


def test_a_reply_that_is_never_usable_ends_in_a_stage_error(provider_for):
    with ChatServer(lambda body: completion(None, refusal="no")) as server:
        with pytest.raises(StageError, match=r"3 attempts.*the model refused to answer: 'no'"):
            analyze_affordance(ANALYSIS, provider_for(server, max_retries=2))
    assert len(server.requests) == 3


# HTTP and network failures: a ProviderError naming the status and what to do


def test_http_401_names_the_key_and_is_not_retried(provider_for):
    with ChatServer(lambda body: chat_error(401, "Incorrect API key provided")) as server:
        with pytest.raises(ProviderError, match=r"answered HTTP 401 \('Incorrect API key provided'\).*OPENAI_API_KEY"):
            analyze_affordance(ANALYSIS, provider_for(server, api_key="sk-wrong", http_retries=2))
    assert len(server.requests) == 1


def test_persistent_http_500_is_retried_then_a_provider_error(provider_for):
    with ChatServer(lambda body: chat_error(500, "boom")) as server:
        with pytest.raises(ProviderError, match=r"HTTP 500 after 2 retries \('boom'\); try again later"):
            analyze_affordance(ANALYSIS, provider_for(server, http_retries=2))
    assert len(server.requests) == 3


@pytest.mark.parametrize("status", [429, 500, 503])
def test_a_passing_429_or_5xx_is_retried(provider_for, status):
    failures = iter([chat_error(status)])
    with ChatServer(lambda body: next(failures, None) or offline_completion(body)) as server:
        assert analyze_affordance(ANALYSIS, provider_for(server, http_retries=1)) == offline_analysis(CUP)
    assert len(server.requests) == 2


def test_http_404_names_the_base_url(provider_for):
    with ChatServer() as server:
        no_v1 = server.base_url.removesuffix("/v1")
        with pytest.raises(ProviderError, match=r"HTTP 404.*check OPENAI_BASE_URL.*'test-model' \(RAIL_MJ_MODEL\)"):
            analyze_affordance(ANALYSIS, provider_for(server, base_url=no_v1))


def test_http_400_suggests_the_model_and_structured_output(provider_for):
    with ChatServer(lambda body: chat_error(400, "response_format json_schema is not supported")) as server:
        with pytest.raises(ProviderError, match=r"HTTP 400.*not supported.*RAIL_MJ_MODEL.*json_schema.*strict=False"):
            analyze_affordance(ANALYSIS, provider_for(server))


def test_timeout_is_a_provider_error(provider_for):
    def slow(body):
        reply = offline_completion(body)
        return Reply(reply.status, reply.body, delay_s=1.5)

    with ChatServer(slow) as server:
        with pytest.raises(ProviderError, match=r"did not answer within 0.3 s; raise it \(--llm-timeout SECONDS"):
            analyze_affordance(ANALYSIS, provider_for(server, timeout=0.3))


def test_no_server_is_a_provider_error(provider_for):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # closed again: nothing listens there
    provider = OpenAIProvider(base_url=f"http://127.0.0.1:{port}/v1", model="m", cache=False, http_retries=0)
    with pytest.raises(ProviderError, match=rf"cannot reach the OpenAI-compatible API at http://127.0.0.1:{port}/v1.*"
                                            "check that the server is running and OPENAI_BASE_URL"):
        analyze_affordance(ANALYSIS, provider)


# the response cache, shared with the Anthropic provider


def test_second_run_is_served_from_cache(provider_for, monkeypatch, tmp_path):
    with ChatServer() as server:
        provider = provider_for(server, cache=True)
        first = generate_profile("bowl", [0.2, 0.2, 0.08], provider)
        n = len(server.requests)
        second = generate_profile("bowl", [0.2, 0.2, 0.08], provider)
        assert len(server.requests) == n == 6 and second == first  # the cache hit made no request
        records = [json.loads(p.read_text()) for p in (tmp_path / "answers").rglob("*.json")]
        assert len(records) == 6 and {(r["provider"], r["model"]) for r in records} == {("openai", "test-model")}
        generate_profile("bowl", [0.2, 0.2, 0.08], provider_for(server, cache=True, model="other-model"))
        assert len(server.requests) == 2 * n  # the model is part of the key
        generate_profile("bowl", [0.2, 0.2, 0.08], provider_for(server, cache=False))
        assert len(server.requests) == 3 * n
        monkeypatch.setenv("RAIL_MJ_NO_CACHE", "1")
        generate_profile("bowl", [0.2, 0.2, 0.08], provider)
        assert len(server.requests) == 4 * n


# configuration: OPENAI_BASE_URL, OPENAI_API_KEY, RAIL_MJ_MODEL


def test_the_hosted_api_needs_a_key_and_has_a_default_model(monkeypatch):
    with pytest.raises(ConfigError, match=r"needs an API key for the hosted OpenAI API \(https://api.openai.com/v1\)"
                                          r": set OPENAI_API_KEY.*a local server.*needs none: set OPENAI_BASE_URL"):
        OpenAIProvider()
    monkeypatch.setenv("OPENAI_API_KEY", "sk-test-secret")
    provider = OpenAIProvider()
    assert (provider.config.base_url, provider.model) == (DEFAULT_BASE_URL, DEFAULT_MODEL)
    assert "sk-test-secret" not in repr(provider.config)  # the key stays with the provider
    assert provider.url == "https://api.openai.com/v1/chat/completions"


def test_a_local_server_needs_no_key_but_a_model(monkeypatch):
    monkeypatch.setenv("OPENAI_BASE_URL", "http://localhost:11434/v1/")
    with pytest.raises(ConfigError, match=r"needs a model name for the server at http://localhost:11434/v1: "
                                          r"set RAIL_MJ_MODEL \(or pass model=\)"):
        OpenAIProvider()
    monkeypatch.setenv("RAIL_MJ_MODEL", "llama3.1")
    provider = get_provider("openai")
    assert isinstance(provider, OpenAIProvider)
    assert provider.config == OpenAIConfig(model="llama3.1", base_url="http://localhost:11434/v1")
    assert get_provider("openai", model="qwen2.5").model == "qwen2.5"  # model= wins over RAIL_MJ_MODEL


def test_no_key_sends_no_authorization(provider_for):
    with ChatServer() as server:
        analyze_affordance(ANALYSIS, provider_for(server))
    assert "authorization" not in {k.lower() for k in server.headers[0]}


@pytest.mark.parametrize(("options", "message"), [
    ({"retries": 3}, r"openai provider takes no option \['retries'\]; valid: api_key, max_retries, cache, model"),
    ({"base_url": "localhost:8000/v1", "model": "m"}, r"base_url must be an http:// or https:// URL"),
    ({"base_url": "http://h/v1", "model": "m", "strict": "yes"}, r"strict must be True or False; got 'yes'"),
    ({"base_url": "http://h/v1", "model": "m", "timeout": 0}, r"timeout must be a number > 0; got 0"),
    ({"base_url": "http://h/v1", "model": "m", "max_retries": -1}, r"max_retries must be a whole number >= 0"),
])
def test_bad_options_are_config_errors(options, message):
    with pytest.raises(ConfigError, match=message):
        get_provider("openai", **options)


def test_openai_is_a_provider_everywhere_providers_are_listed(monkeypatch, tmp_path):
    assert "openai" in PROVIDERS
    assert eval_parser().parse_args(["--out", str(tmp_path), "--provider", "openai"]).provider == "openai"
    assert get_provider("openai", base_url="http://h/v1", model="m").affordance_name("Sofa Bed ") == "Sofa Bed"


def test_pipeline_and_cli_take_provider_openai(monkeypatch, tmp_path, capsys):
    with ChatServer() as server:
        monkeypatch.setenv("OPENAI_BASE_URL", server.base_url)
        monkeypatch.setenv("RAIL_MJ_MODEL", "test-model")
        pipe = Pipeline(RunConfig(provider="openai", backend="native", max_retries=1, cache=False))
        assert pipe.provider_name == "openai" and pipe.provider.config.max_retries == 1
        cup = pipe.profile("Mug", CUP.obb_dims)
        assert cup.affordance == "cup" and cup.provider == "openai" and len(server.requests) == 6
        mesh = tmp_path / "noise.stl"
        mesh.write_bytes(b"\0" * 64)
        # the command line builds the provider, then refuses the empty name before any mesh or request
        assert rail_main([str(mesh), "-a", "cup", "-a", " ", "--provider", "openai", "--json"]) == 2
    assert "non-empty" in json.loads(capsys.readouterr().out)["error"]
    assert len(server.requests) == 6
