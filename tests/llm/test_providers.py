"""Providers are configured once (frozen settings from get_provider or RunConfig); the affordance name is
resolved once, at the profile boundary, by the provider: the registry's canonical name when it knows it."""

from __future__ import annotations

import pytest
from messages_server import MessagesServer, offline_answer, request_payload, schema_title, text_reply
from pydantic import ValidationError

from rail_mj.core.errors import ConfigError, StageError, UnknownAffordanceError
from rail_mj.llm import (
    AnthropicConfig,
    OfflineProvider,
    ProviderConfig,
    generate_profile,
    get_provider,
    task_description,
)
from rail_mj.pipeline.chain import Pipeline
from rail_mj.pipeline.config import RunConfig

CUP_DIMS = [0.12, 0.09, 0.09]


@pytest.fixture
def loopback_env(tmp_path, monkeypatch):
    """The SDK reads its key and base URL from the environment, as a Pipeline's provider does."""

    def use(server: MessagesServer) -> None:
        monkeypatch.setenv("ANTHROPIC_API_KEY", "test-key")
        monkeypatch.setenv("ANTHROPIC_BASE_URL", server.base_url)

    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("RAIL_MJ_NO_CACHE", raising=False)
    monkeypatch.delenv("RAIL_MJ_MODEL", raising=False)
    return use


def test_settings_are_fixed_when_the_provider_is_made():
    provider = get_provider("anthropic", api_key="sk-test-secret", model="m", max_retries=4, cache=False,
                            temperature=0.0)
    assert provider.config == AnthropicConfig(max_retries=4, cache=False, model="m", temperature=0.0)
    assert provider.model == "m" and "sk-test-secret" not in repr(provider.config)  # the key stays with the client
    with pytest.raises(ValidationError, match="frozen"):
        provider.config.max_retries = 9  # type: ignore[misc]
    offline = get_provider("offline", max_retries=0, cache=False)
    assert isinstance(offline, OfflineProvider) and offline.config == ProviderConfig(max_retries=0, cache=False)


@pytest.mark.parametrize(("name", "options", "message"), [
    ("offline", {"model": "x"}, r"offline provider takes no LLM options; got \['model'\]; valid: max_retries, cache"),
    ("anthropic", {"api_key": "k", "retries": 3}, r"no option \['retries'\]; valid: api_key, max_retries, cache, mod"),
    ("offline", {"max_retries": -1}, r"max_retries must be a whole number >= 0; got -1"),
    ("anthropic", {"api_key": "k", "cache": "no"}, r"cache must be True or False; got 'no'"),
    ("anthropic", {"api_key": "k", "timeout": 0}, r"timeout must be a number > 0; got 0"),
])
def test_options_a_provider_does_not_take_are_refused_naming_the_valid_ones(name, options, message):
    with pytest.raises(ConfigError, match=message):
        get_provider(name, **options)


def test_a_provider_object_takes_no_further_options():
    with pytest.raises(ConfigError, match=r"configured when it was made; got options \['cache'\].*get_provider"):
        generate_profile("cup", CUP_DIMS, OfflineProvider(), cache=False)
    assert generate_profile("cup", CUP_DIMS, "offline", cache=False) == generate_profile("cup", CUP_DIMS)


@pytest.mark.parametrize(("given", "offline", "anthropic"), [
    ("Mugs", "cup", "cup"), ("  Trash_Bins ", "trash bin", "trash bin"), ("Sofa Bed ", None, "Sofa Bed"),
])
def test_the_provider_resolves_the_name_through_the_registry(given, offline, anthropic):
    llm = get_provider("anthropic", api_key="k")
    assert llm.affordance_name(given) == anthropic  # an LLM imagines names outside the registry, as written
    if offline is None:
        with pytest.raises(UnknownAffordanceError, match="known: basket, bathtub, bed, bench"):
            get_provider("offline").affordance_name(given)
    else:
        assert get_provider("offline").affordance_name(given) == offline
    with pytest.raises(ConfigError, match="non-empty"):
        llm.affordance_name("  ")


def test_a_profile_of_an_alias_is_the_canonical_profile():
    """A profile of "mug" said affordance "mug": every stage request carried the raw name."""
    assert task_description("mug", [0.09, 0.12, 0.09], OfflineProvider()).affordance == "cup"
    assert generate_profile("mug", CUP_DIMS) == generate_profile("cup", CUP_DIMS)


def test_pipeline_builds_one_profile_for_every_spelling_of_a_name():
    """Pipeline.profile keyed its cache on strip().lower(): "mug" and "cup" built two profiles."""
    pipe = Pipeline(RunConfig(provider="offline", backend="native"))
    cup = pipe.profile("cup", CUP_DIMS)
    assert pipe.profile("Mugs", CUP_DIMS) is cup and pipe.profile(" CUP", CUP_DIMS) is cup
    assert len(pipe._profiles) == 1 and cup.affordance == "cup"


def test_run_config_settings_reach_the_provider_once(loopback_env):
    """max_retries and cache come from RunConfig through the provider, not through every stage call."""
    with MessagesServer(lambda body: text_reply("not json")) as server:
        loopback_env(server)
        pipe = Pipeline(RunConfig(provider="anthropic", backend="native", model="test-model", max_retries=0,
                                  cache=False))
        assert (pipe.provider.config.max_retries, pipe.provider.config.cache) == (0, False)
        with pytest.raises(StageError, match="in 1 attempts"):
            pipe.profile("cup", CUP_DIMS)
    assert len(server.requests) == 1


def test_anthropic_stages_see_the_canonical_name_and_share_the_profile(loopback_env):
    with MessagesServer(offline_answer) as server:
        loopback_env(server)
        pipe = Pipeline(RunConfig(provider="anthropic", backend="native", model="test-model"))
        mug = pipe.profile("Mug", CUP_DIMS)
        assert pipe.profile("cup", CUP_DIMS) is mug
    assert len(server.requests) == 6 and mug.affordance == "cup" and mug.provider == "anthropic"
    for body in server.requests:
        payload = request_payload(body)
        assert payload["task"]["affordance"] == "cup", schema_title(body)
