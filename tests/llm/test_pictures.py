"""Stage 7's pictures (rail_mj.llm.pictures, rail_mj.pipeline.pose_pictures): each pose of the request with its
plan's end state goes to a model that sees pictures, in its API's shape, keyed in the cache by what is drawn; a
model whose API refuses them is asked again as text; the offline library and ``pictures=False`` send none."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from chat_server import ChatServer, chat_error, offline_completion
from messages_server import MessagesServer, error_reply, offline_answer

from rail_mj.dataset import shapes
from rail_mj.llm import AnthropicProvider, OpenAIProvider, get_provider
from rail_mj.mesh import object_from_mesh
from rail_mj.pipeline.chain import Pipeline
from rail_mj.pipeline.config import RunConfig
from rail_mj.stable_poses import StablePoseConfig

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(autouse=True)
def _env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    for name in ("OPENAI_API_KEY", "OPENAI_BASE_URL", "ANTHROPIC_BASE_URL", "RAIL_MJ_NO_CACHE"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path / "cache"))


@pytest.fixture(scope="module")
def cup():
    return object_from_mesh(shapes.GENERATORS["cup"](np.random.default_rng(1)).mesh, name="cup")


def _stage7(requests: list[dict]) -> list[dict]:
    return [r for r in requests if "FunctionalPose" in str(r.get("response_format") or r.get("output_config"))]


def _as_text_only(refusal, answer):
    """A server that answers ``refusal`` to a request with pictures and ``answer``s it as text."""

    def responder(body):
        content = next(m["content"] for m in body["messages"] if m["role"] == "user")
        return answer(body) if isinstance(content, str) else refusal

    return responder


def _run(provider, cup) -> None:
    pipe = Pipeline(RunConfig(provider="offline", backend="native", stable_poses=StablePoseConfig(n_drops=16)))
    pipe.provider = provider
    result = pipe.run(cup, pipe.stable_poses(cup), "cup")
    assert result.error is None and result.functional


def test_openai_gets_one_picture_of_each_pose_after_its_caption(cup, tmp_path):
    with ChatServer(offline_completion) as server:
        provider = OpenAIProvider(base_url=server.base_url, model="test-model", cache_root=tmp_path / "a")
        _run(provider, cup)
    (body,) = _stage7(server.requests)
    content = next(m["content"] for m in body["messages"] if m["role"] == "user")
    request = content[0]["text"]
    n_poses = request.count('"pose_index"')
    images = [b for b in content if b["type"] == "image_url"]
    assert n_poses >= 1 and len(images) == n_poses
    assert all(b["image_url"]["url"].startswith("data:image/png;base64,iVBOR") for b in images)  # a PNG
    captions = [b["text"] for b in content[1:] if b["type"] == "text"]
    assert len(captions) == n_poses and all(c.startswith("Picture of pose ") and "10 cm" in c for c in captions)


def test_anthropic_gets_them_as_image_blocks_and_a_rerun_is_served_from_the_cache(cup, tmp_path):
    with MessagesServer(offline_answer) as server:
        provider = AnthropicProvider(api_key="test-key", base_url=server.base_url, model="test-model",
                                     cache_root=tmp_path / "b")
        _run(provider, cup)
        asked = len(server.requests)
        _run(AnthropicProvider(api_key="test-key", base_url=server.base_url, model="test-model",
                               cache_root=tmp_path / "b"), cup)
    (body,) = _stage7(server.requests)
    content = body["messages"][0]["content"]
    images = [b for b in content if b["type"] == "image"]
    assert images and all(b["source"]["media_type"] == "image/png" for b in images)
    assert len(server.requests) == asked  # the same poses drawn the same: every answer from the cache


def test_a_model_whose_api_refuses_pictures_is_asked_again_as_text(cup, tmp_path):
    with ChatServer(_as_text_only(chat_error(400, "this model does not take image_url content"),
                                  offline_completion)) as server:
        provider = OpenAIProvider(base_url=server.base_url, model="test-model", cache_root=tmp_path / "c",
                                  http_retries=0)
        _run(provider, cup)
    assert provider.pictures_refused is not None and "HTTP 400" in provider.pictures_refused
    assert not provider.sees_pictures
    refused, again = _stage7(server.requests)
    assert not isinstance(refused["messages"][1]["content"], str) and isinstance(again["messages"][1]["content"], str)


def test_a_server_that_fails_on_pictures_is_asked_again_as_text(cup, tmp_path):
    with ChatServer(_as_text_only(chat_error(500, "the vision encoder crashed"), offline_completion)) as server:
        provider = OpenAIProvider(base_url=server.base_url, model="test-model", cache_root=tmp_path / "h",
                                  http_retries=1)
        _run(provider, cup)
    assert provider.pictures_refused is not None and "HTTP 500" in provider.pictures_refused
    assert [isinstance(b["messages"][1]["content"], str) for b in _stage7(server.requests)] == [False, False, True]


def test_no_pictures_from_the_offline_library_or_when_turned_off(cup, tmp_path):
    assert not get_provider("offline").sees_pictures
    with ChatServer(offline_completion) as server:
        _run(OpenAIProvider(base_url=server.base_url, model="test-model", cache_root=tmp_path / "d",
                            pictures=False), cup)
    (body,) = _stage7(server.requests)
    assert isinstance(body["messages"][1]["content"], str)


def test_the_anthropic_api_refusing_them_is_asked_again_as_text_too(cup, tmp_path):
    with MessagesServer(_as_text_only(error_reply(400, "invalid_request_error"), offline_answer)) as server:
        provider = AnthropicProvider(api_key="test-key", base_url=server.base_url, model="test-model",
                                     cache_root=tmp_path / "e")
        _run(provider, cup)
    assert provider.pictures_refused is not None and "the Anthropic API answered HTTP 400" in provider.pictures_refused


def test_an_object_of_arbitrary_orientation_says_nothing_of_the_pose_it_came_in(cup, tmp_path):
    """Its file's up is no maker's: stage 7's model gets no came_in and no pose's as_it_came (the offline rules
    weigh the pose it came in by the same flag, rail_mj.stable_poses.came_in)."""
    import dataclasses
    import json

    with ChatServer(offline_completion) as server:
        _run(OpenAIProvider(base_url=server.base_url, model="test-model", cache_root=tmp_path / "f",
                            pictures=False), dataclasses.replace(cup, oriented=False))
        _run(OpenAIProvider(base_url=server.base_url, model="test-model", cache_root=tmp_path / "g",
                            pictures=False), cup)
    anyhow, as_built = (json.loads(b["messages"][1]["content"].split("\n", 1)[1]) for b in _stage7(server.requests))
    assert anyhow["came_in"] is None and all(p["shape"]["as_it_came"] is None for p in anyhow["poses"])
    assert as_built["came_in"] is not None and any(p["shape"]["as_it_came"] for p in as_built["poses"])
