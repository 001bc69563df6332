"""The LLM path measured offline: a recorded conversation replayed end to end through both LLM providers.

``fixtures/llm_replay/dog_bed.json`` is an LLM conversation for a novel affordance, "dog bed" (no registry row,
no affordance file loaded), written by hand in the shape a model answers: stages 1-7 in order, one of them
answered first with MJCF the fragment allow-list refuses (a free joint) and another with scoring code the sandbox
refuses (an import), each followed by the repaired answer. The loopback servers serve it, turn by turn, to the
real Anthropic SDK client (``provider="anthropic"``) and to the OpenAI-compatible provider (``provider="openai"``)
in ``rail_mj.classify`` on a small generated bed; both must give the same result, see the refusal fed back in
the repair round, and leave in the answer cache exactly the accepted answers, from which the same result replays
with no server at all. No live model is involved (see the README's "What has been run against a live model").
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from chat_server import ChatServer, chat_error, completion, schema_name
from messages_server import MessagesServer, Reply, error_reply, schema_title, text_reply
from paths import FIXTURES

from rail_mj.affordances import known_affordances, unload_all
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.llm.prompts import STAGES
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot.demo import object_from_parts

FIXTURE = FIXTURES / "llm_replay" / "dog_bed.json"
CONVERSATION: dict[str, Any] = json.loads(FIXTURE.read_text())
#: The answer type's name (the schema the provider sends) -> its stage's name.
STAGE_OF = {spec.output_type.__name__: name for name, spec in STAGES.items()}
#: Everything of a result but the seconds it took, the provider that made it (also named in the words of its
#: stage-0 definition) and the requests it sent (none from the cache).
COMPARED = {"timings", "provider", "definition", "llm_calls", "llm_repairs"}


def _box(lo: list[float], hi: list[float]) -> np.ndarray:
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    return np.asarray(lo, float) + corners * (np.asarray(hi, float) - np.asarray(lo, float))


def _dog_bed() -> RailObject:
    """A cushion 70 x 50 cm and 6 cm thick, with a bolster 6 cm wide and 14 cm tall along its back and sides."""
    return object_from_parts("dog_bed", [
        _box([-0.35, -0.25, 0.0], [0.35, 0.25, 0.06]), _box([-0.35, 0.19, 0.06], [0.35, 0.25, 0.14]),
        _box([-0.35, -0.19, 0.06], [-0.29, 0.19, 0.14]), _box([0.29, -0.19, 0.06], [0.35, 0.19, 0.14])])


class Replay:
    """A responder that answers each request with the conversation's next turn, which must be for the stage the
    request asks (else an HTTP 400 naming both, which ends the run with a ProviderError)."""

    def __init__(self, stage_of_body: Callable[[dict[str, Any]], str], reply: Callable[[str], Reply],
                 error: Callable[[int, str], Reply]) -> None:
        self.turns = list(CONVERSATION["turns"])
        self.stage_of_body, self.reply, self.error = stage_of_body, reply, error
        self.served: list[dict[str, Any]] = []

    def __call__(self, body: dict[str, Any]) -> Reply:
        stage = STAGE_OF[self.stage_of_body(body)]
        if not self.turns or self.turns[0]["stage"] != stage:
            expected = self.turns[0]["stage"] if self.turns else "no more requests"
            return self.error(400, f"replay: the conversation's next turn is {expected}, asked {stage}")
        turn = self.turns.pop(0)
        self.served.append(turn)
        return self.reply(json.dumps(turn["answer"]))


def _anthropic_replay() -> Replay:
    return Replay(schema_title, text_reply, lambda status, message: error_reply(status, message))


def _openai_replay() -> Replay:
    return Replay(schema_name, lambda text: completion(text, model=CONVERSATION["model"]), chat_error)


@pytest.fixture(autouse=True)
def _novel(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    """No affordance file loaded (the dog bed is novel), a fresh cache, the model's name, no real endpoint."""
    unload_all()
    assert CONVERSATION["affordance"] not in known_affordances()
    for name in ("RAIL_MJ_NO_CACHE", "OPENAI_API_KEY", "ANTHROPIC_BASE_URL", "OPENAI_BASE_URL"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("RAIL_MJ_MODEL", CONVERSATION["model"])
    monkeypatch.setenv("ANTHROPIC_API_KEY", "test-key")
    yield
    unload_all()


def _classify(provider: str) -> AffordanceResult:
    return classify([_dog_bed()], [CONVERSATION["affordance"]], config=RunConfig(provider=provider, backend="native",
                    pose="as_placed"), progress=False, workers=1)[0]


def _text(message: dict[str, Any]) -> str:
    content = message["content"]
    return content if isinstance(content, str) else " ".join(block.get("text", "") for block in content)


def _served_run(provider: str, monkeypatch: pytest.MonkeyPatch) -> tuple[AffordanceResult, Replay, list[dict]]:
    """``provider``'s run with its loopback server serving the conversation: the result, the replay, the requests."""
    replay = _anthropic_replay() if provider == "anthropic" else _openai_replay()
    server = MessagesServer(replay) if provider == "anthropic" else ChatServer(replay)
    with server:
        monkeypatch.setenv("ANTHROPIC_BASE_URL" if provider == "anthropic" else "OPENAI_BASE_URL", server.base_url)
        result = _classify(provider)
    return result, replay, server.requests


def _cache_records(root: Path) -> list[dict[str, Any]]:
    return [json.loads(p.read_text()) for p in sorted((root / "llm").rglob("*.json"))]


@pytest.mark.parametrize("provider", ["anthropic", "openai"])
def test_the_recorded_conversation_runs_end_to_end_with_its_repair_rounds(provider, monkeypatch, tmp_path):
    result, replay, requests = _served_run(provider, monkeypatch)
    assert result.error is None, result.error
    assert not replay.turns and len(requests) == len(CONVERSATION["turns"])  # every turn served, nothing else
    assert result.affordance == result.requested == "dog bed" and result.provider == provider
    assert result.dims_fit and result.functional and result.best_plan is not None
    assert result.best_plan.name == "lie_centre" and result.plans[0] == "lie_centre"
    assert "dog_body" in result.agent_fragment and "import" not in result.scoring_source
    # the requests sent, per stage: each stage once, and a repair round for each refused answer
    repairs = Counter(t["stage"] for t in CONVERSATION["turns"] if "rejected" in t)
    assert result.llm_repairs == dict(repairs) and sum(repairs.values()) == 2
    assert result.llm_calls == {t["stage"]: 1 for t in CONVERSATION["turns"]}
    # each refused answer went back to the model, and the request after it carries the refusal
    for i, turn in enumerate(CONVERSATION["turns"]):
        if "rejected" not in turn:
            continue
        repair = requests[i + 1]
        last = _text(repair["messages"][-1])
        assert "Your previous answer was rejected" in last and turn["rejected"] in last, (turn["stage"], last)
        assert json.loads(_text(repair["messages"][-2])) == turn["answer"]  # the refused answer, as it was given
    # the cache holds the accepted answers, under today's prompt versions, for this provider and model
    accepted = {t["stage"]: t["answer"] for t in CONVERSATION["turns"] if "rejected" not in t}
    records = _cache_records(tmp_path / "cache")
    assert sorted(r["stage"] for r in records) == sorted(accepted)
    for record in records:
        stage = STAGES[record["stage"]]
        assert (record["provider"], record["model"], record["prompt_version"]) == (
            provider, CONVERSATION["model"], stage.version)
        assert json.loads(record["answer"]) == json.loads(
            stage.output_type.model_validate(accepted[record["stage"]]).model_dump_json())


def test_both_providers_and_the_cache_replay_without_a_server_give_one_result(monkeypatch, tmp_path):
    results = {}
    for provider in ("anthropic", "openai"):
        results[provider], _, _ = _served_run(provider, monkeypatch)
        # the server is gone (its port closed): every answer must now come from the cache
        replayed = _classify(provider)
        assert replayed.error is None, replayed.error
        assert replayed.model_dump(exclude=COMPARED) == results[provider].model_dump(exclude=COMPARED)
    assert results["anthropic"].model_dump(exclude=COMPARED) == results["openai"].model_dump(exclude=COMPARED)
    assert results["openai"].functional
