"""Requests in words (rail_mj.robot.parse_request) and the request's agent scale (registry, offline stages)."""

from __future__ import annotations

import pytest

from rail_mj.affordances import FIGURE_HEIGHTS, PERSON_HEIGHT, for_request, get, request_scale
from rail_mj.core.errors import ConfigError, UnknownAffordanceError
from rail_mj.llm import TaskDescription, get_provider, parse_request_text, task_profile
from rail_mj.llm.prompts import STAGES, system_prompt
from rail_mj.llm.schemas import Request, RequestText
from rail_mj.mjcf.body import body_size
from rail_mj.robot import parse_request


@pytest.mark.parametrize("text, agent, affordance, preposition", [
    ("put the apple in the bowl", "apple", "bowl", "in"),
    ("Put the apples into the bowls.", "apple", "bowl", "in"),
    ("place a doll onto the toy chair", "doll", "chair", "on"),
    ("please put the teddies on top of the stool", "teddy", "stool", "on"),
    ("pour water inside the mug", "water", "cup", "in"),
    ("put the pen in the pencil cup", "pen", "pen holder", "in"),
    ("could you put the book on the bookshelves please", "book", "shelf", "on"),
    ("drop the paper ball in the trash can", "paper ball", "trash bin", "in"),
    ("the box on the benches", "box", "bench", "on"),
])
def test_parser_reads_good_sentences(text, agent, affordance, preposition):
    req = parse_request(text)
    assert isinstance(req, Request)
    assert (req.agent, req.affordance, req.preposition, req.text) == (agent, affordance, preposition, text)


def test_unknown_affordance_lists_the_known_names():
    with pytest.raises(UnknownAffordanceError) as info:
        parse_request("put the apple in the spaceship")
    message = str(info.value)
    assert "spaceship" in message and "bowl" in message and "pen holder" in message


@pytest.mark.parametrize("text", ["", "   ", "hello world", "put the apple", "in the bowl"])
def test_parser_refuses_sentences_without_agent_or_object(text):
    with pytest.raises(ConfigError, match="put the AGENT"):
        parse_request(text)


def test_request_parser_is_a_stage_with_offline_answer_and_examples():
    req = parse_request_text(RequestText(text="put the doll on the chair"), get_provider("offline"))
    assert req.affordance == "chair" and req.agent == "doll"
    prompt = system_prompt(STAGES["request_parser"])
    assert '"affordance":"bowl"' in prompt and '"agent":"doll"' in prompt


def test_request_scale_follows_figures_not_items():
    assert request_scale("doll") == pytest.approx(FIGURE_HEIGHTS["doll"] / PERSON_HEIGHT)
    assert request_scale("the teddies") == request_scale("teddy")
    assert request_scale("person") == 1.0
    assert request_scale("apple") == request_scale("water") == request_scale(None) == 1.0


def test_scaled_row_scales_dims_and_envelope_together():
    chair, doll = get("chair"), for_request("chair", "doll")
    k = request_scale("doll")
    assert doll.largest == pytest.approx((chair.largest[0] * k, chair.largest[1] * k))
    assert doll.smallest == pytest.approx((chair.smallest[0] * k, chair.smallest[1] * k))
    assert doll.envelope.rest == pytest.approx((chair.envelope.rest[0] * k, chair.envelope.rest[1] * k))
    assert doll.envelope.aspect == chair.envelope.aspect and doll.scale == pytest.approx(k)
    assert get("cup").scaled(1.0) is get("cup")
    with pytest.raises(ConfigError, match="positive"):
        chair.scaled(0.0)


def test_doll_sized_chair_passes_the_dimension_check_only_for_a_doll():
    dims = [0.14, 0.11, 0.105]  # the demo's toy chair: a 9 cm seat
    offline = get_provider("offline")
    person = task_profile(TaskDescription(affordance="chair", obb_dims=dims), offline)
    doll = task_profile(TaskDescription(affordance="chair", obb_dims=dims, scale=request_scale("doll")), offline)
    assert not person.analysis.fits
    assert doll.analysis.fits and doll.scale == pytest.approx(request_scale("doll"))
    # the body is a doll's (its pelvis as broad as a doll's hips; the seat kind's agent is the articulated body now),
    # and the scoring's seat-height window a doll chair's
    hips = body_size(request_scale("doll")).hip_breadth / 2
    assert f" {hips:.6g} " in doll.agent.mjcf
    assert "0.0635" in doll.scoring.source
