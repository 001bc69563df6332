"""Hostile and malformed LLM answers through the real SDK client and a loopback server: each is a failed
attempt that goes back to the model with a message naming what came back, never a crash; and the SDK
is loaded only when the Anthropic provider is used."""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys

import pytest
from messages_server import MessagesServer, Reply, offline_answer, schema_title, text_reply
from paths import REPO

from rail_mj.core.errors import StageError
from rail_mj.llm import (
    AgentModel,
    AgentModelRequest,
    AnalyzerRequest,
    AnthropicProvider,
    TaskDescription,
    analyze_affordance,
    generate_agent_model,
)
from rail_mj.llm.offline import offline_agent, offline_analysis

CUP = TaskDescription(affordance="cup", obb_dims=[0.12, 0.09, 0.09])


@pytest.fixture
def provider_for(tmp_path):
    def make(server: MessagesServer, **kw) -> AnthropicProvider:
        opts = {"api_key": "test-key", "base_url": server.base_url, "cache_root": tmp_path / "cache",
                "model": "test-model", "timeout": 10.0, "http_retries": 0, "cache": False, **kw}
        return AnthropicProvider(**opts)

    return make


def _first_then_offline(title: str, bad: Reply):
    """Answer stage ``title`` once with ``bad``, then (and every other stage) like the offline library."""
    sent = {"n": 0}

    def responder(body):
        if schema_title(body) == title and sent["n"] == 0:
            sent["n"] += 1
            return bad
        return offline_answer(body)

    return responder


def _message(**fields) -> Reply:
    base = text_reply("{}").body
    return Reply(200, {**base, **fields})


NOT_A_MESSAGE = [
    pytest.param(Reply(200, {"hello": "world"}), r"is not a Message \(type None\): '\{\"hello\": \"world\"\}'",
                 id="object"),
    pytest.param(Reply(200, [1, 2]), r"is not a Message \(a JSON array\): '\[1, 2\]'", id="array"),
    pytest.param(Reply(200, None), r"is not a Message \(a JSON null\)", id="null"),
    pytest.param(Reply(200, {}, raw="<html>proxy login</html>"), "is not JSON: '<html>proxy login</html>'",
                 id="html"),
    pytest.param(Reply(200, {"type": "error", "error": {"type": "overloaded_error"}}),
                 r"is not a Message \(type 'error'\).*overloaded_error", id="error-body"),
    pytest.param(_message(content=None), "has no list of typed content blocks", id="content-null"),
    pytest.param(_message(content=[1, "x"]), "has no list of typed content blocks", id="content-junk"),
    pytest.param(_message(content=[{"type": "text"}]), "a text block without text", id="text-missing"),
]


@pytest.mark.parametrize(("bad", "named"), NOT_A_MESSAGE)
def test_http_200_that_is_not_a_message_is_a_failed_attempt(provider_for, bad, named):
    """An HTTP 200 whose body was no Message crashed with TypeError / AttributeError inside the SDK."""
    with MessagesServer(_first_then_offline("AffordanceAnalysis", bad)) as server:
        analysis = analyze_affordance(AnalyzerRequest(task=CUP), provider_for(server))
    assert analysis == offline_analysis(CUP)
    assert len(server.requests) == 2
    repair = server.requests[1]["messages"][-1]
    assert repair["role"] == "user" and re.search(named, repair["content"])


def test_http_200_that_is_never_a_message_ends_in_a_stage_error(provider_for):
    with MessagesServer(lambda body: Reply(200, {"hello": "world"})) as server:
        with pytest.raises(StageError, match=r"3 attempts.*is not a Message \(type None\)"):
            analyze_affordance(AnalyzerRequest(task=CUP), provider_for(server, max_retries=2))
    assert len(server.requests) == 3


def _repair_of(provider_for, title: str, bad: Reply, request) -> tuple[list[dict], object]:
    """The second request's messages after one ``bad`` answer, and the stage's final answer."""
    ask = {"AffordanceAnalysis": analyze_affordance, "AgentModel": generate_agent_model}[title]
    with MessagesServer(_first_then_offline(title, bad)) as server:
        answer = ask(request, provider_for(server))
    assert len(server.requests) == 2
    return server.requests[1]["messages"], answer


ANALYSIS = AnalyzerRequest(task=CUP)
GOOD_ANALYSIS = offline_analysis(CUP).model_dump_json()


@pytest.mark.parametrize(
    ("bad", "named"),
    [
        pytest.param(text_reply("Sure! A cup holds liquid."), "Invalid JSON", id="prose"),
        pytest.param(text_reply("[1, 2, 3]"), "Input should be an object", id="json-array"),
        pytest.param(text_reply(json.dumps({**json.loads(GOOD_ANALYSIS), "confidence": 0.9})),
                     "Extra inputs are not permitted", id="extra-field"),
    ],
)
def test_answer_text_that_breaks_the_schema_goes_back_with_the_text(provider_for, bad, named):
    messages, analysis = _repair_of(provider_for, "AffordanceAnalysis", bad, ANALYSIS)
    assert analysis == offline_analysis(CUP)
    assert [m["role"] for m in messages] == ["user", "assistant", "user"]
    assert messages[1]["content"] == bad.body["content"][0]["text"]  # the model sees what it wrote
    assert "does not match the schema" in messages[2]["content"] and named in messages[2]["content"]


def test_answer_cut_off_at_max_tokens_says_so(provider_for):
    """A truncated answer was reported as a bare JSON error; the model was not told it ran out of tokens."""
    bad = _message(content=[{"type": "text", "text": GOOD_ANALYSIS[:60]}], stop_reason="max_tokens")
    messages, analysis = _repair_of(provider_for, "AffordanceAnalysis", bad, ANALYSIS)
    assert analysis == offline_analysis(CUP)
    assert "cut off at max_tokens=8192" in messages[-1]["content"] and "shorter" in messages[-1]["content"]
    assert "EOF while parsing" in messages[-1]["content"]


def test_empty_content_is_a_failed_attempt(provider_for):
    messages, analysis = _repair_of(provider_for, "AffordanceAnalysis", _message(content=[]), ANALYSIS)
    assert analysis == offline_analysis(CUP)
    assert [m["role"] for m in messages] == ["user", "user"]  # nothing to show back
    assert "the answer held no text (stop_reason 'end_turn', content blocks [])" in messages[-1]["content"]


AGENT_REQUEST = AgentModelRequest(task=CUP, analysis=offline_analysis(CUP))


def _agent_reply(mjcf: str) -> Reply:
    return text_reply(AgentModel(name="drop", description="a droplet", mjcf=mjcf).model_dump_json())


def test_mjcf_include_is_refused_and_repaired(provider_for):
    bad = _agent_reply('<mujoco><include file="/etc/passwd"/><worldbody><body><geom size="0.01"/></body>'
                       "</worldbody></mujoco>")
    messages, agent = _repair_of(provider_for, "AgentModel", bad, AGENT_REQUEST)
    assert agent == offline_agent(CUP)
    assert "<include> is not allowed inside <mujoco> (it pulls in another file)" in messages[-1]["content"]
    assert "root:" not in messages[-1]["content"]  # nothing of the file reaches the model


def test_a_million_kilogram_agent_is_refused_and_repaired(provider_for):
    bad = _agent_reply('<mujoco><worldbody><body name="drop"><geom type="sphere" size="0.005" mass="1e6"/>'
                       "</body></worldbody></mujoco>")
    messages, agent = _repair_of(provider_for, "AgentModel", bad, AGENT_REQUEST)
    assert agent == offline_agent(CUP)
    assert "agent mass 1e+06 kg is not plausible; valid: 1e-05 to 200.0 kg" in messages[-1]["content"]


def _imports_after(statement: str) -> set[str]:
    code = f"import sys; {statement}; print(' '.join(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300)
    return set(out.stdout.split())


def test_the_anthropic_sdk_is_imported_only_by_its_provider():
    """``import rail_mj.llm`` (and so the pipeline) loaded the SDK eagerly."""
    modules = _imports_after("import rail_mj.pipeline.chain; from rail_mj.llm import AnthropicProvider, get_provider; "
                             "get_provider('offline')")
    assert "anthropic" not in modules and "rail_mj.pipeline.chain" in modules
    used = _imports_after("from rail_mj.llm import get_provider; get_provider('anthropic', api_key='k')")
    assert "anthropic" in used


def test_llm_modules_import_each_other_without_a_cycle():
    """providers imported anthropic_provider (in get_provider), which imported providers back."""
    folder = REPO / "rail_mj" / "llm"
    names = {p.stem for p in folder.glob("*.py")} - {"__init__"}
    graph: dict[str, set[str]] = {}
    for name in names:
        edges = graph.setdefault(name, set())
        for node in ast.walk(ast.parse((folder / f"{name}.py").read_text())):  # function-level imports too
            if isinstance(node, ast.ImportFrom) and node.module:
                targets = [f"{node.module}.{a.name}" for a in node.names] + [node.module]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                continue
            edges |= {t.removeprefix("rail_mj.llm.") for t in targets if t.removeprefix("rail_mj.llm.") in names}

    def reaches(start: str, goal: str, seen: set[str]) -> bool:
        return any(n == goal or (n not in seen and reaches(n, goal, seen | {n})) for n in graph[start])

    assert [n for n in sorted(names) if reaches(n, n, set())] == []
