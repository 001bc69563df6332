"""Requests in words (rail_mj.robot.parse_request) and the request's agent scale (registry, offline stages)."""

from __future__ import annotations

import pytest

from rail_mj.affordances import FIGURE_HEIGHTS, PERSON_HEIGHT, for_request, get, request_scale
from rail_mj.affordances.names import ANIMAL_LENGTHS
from rail_mj.core.errors import ConfigError, UnknownAffordanceError
from rail_mj.llm import TaskDescription, get_provider, parse_request_text, task_profile
from rail_mj.llm.checks import InvalidAnswerError
from rail_mj.llm.offline import offline_request
from rail_mj.llm.prompts import STAGES, system_prompt
from rail_mj.llm.providers import OfflineProvider
from rail_mj.llm.schemas import Request, RequestText
from rail_mj.mjcf.body import body_size
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot import parse_request
from rail_mj.robot.demo import make_object


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
    ("put the paper in the trash bin", "paper", "trash bin", "in"),  # compound names, matched whole
    ("put the pen in the pen holder", "pen", "pen holder", "in"),
    ("put the bread on the cutting board", "bread", "cutting board", "on"),
    ("pour the water into the cup", "water", "cup", "in"),
    ("sit the person on the stool", "person", "stool", "on"),
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


@pytest.mark.parametrize("text, agent, affordance, owner", [
    ("put the soap in the soap dish", "soap", "soap dish", None),
    ("put the cup on the coffee table", "cup", "coffee table", None),
    ("put the doll on the doll's chair", "doll", "chair", "doll"),
    ("put the cup on the teddy bear's table", "cup", "table", "teddy bear"),
    ("put the apple on the dolls' red beds", "apple", "bed", "doll"),
    ("put the pen in the doll's pencil cup", "pen", "pen holder", "doll"),
    ("put the puppy on the dog bed", "puppy", "bed", "dog"),
    ("put the ball on the red toy chair", "ball", "chair", None),
    ("put the book on the bedside table", "book", "nightstand", None),
])
def test_compound_names_keep_their_words(text, agent, affordance, owner):
    """A compound name is matched whole (soap dish, coffee table, bedside table), then by its head noun with
    the figure or animal whose it is in front; colour, material, size words and "toy" are dropped."""
    req = parse_request(text)
    assert (req.agent, req.affordance, req.owner) == (agent, affordance, owner)


@pytest.mark.parametrize("text, closest", [
    ("put the apple in the fruit bowl", "bowl"),
    ("put the cup on the dining table", "table"),
    ("put the food in the dog bowl", "bowl"),  # a dog's body sizes its bed, not its bowl
    ("put the ball in the toy spaceship", None),
])
def test_compound_names_that_cannot_be_resolved_are_refused_with_the_closest(text, closest):
    with pytest.raises(UnknownAffordanceError) as info:
        parse_request(text)
    message = str(info.value)
    assert "known: " in message and "coffee table" in message
    if closest is not None:
        assert f"closest: {closest}," in message or f"closest: {closest};" in message


def test_the_owner_sets_the_scale_and_a_dog_only_as_an_owner():
    assert request_scale("apple", "doll") == pytest.approx(FIGURE_HEIGHTS["doll"] / PERSON_HEIGHT)
    assert request_scale(None, "dog") == pytest.approx(ANIMAL_LENGTHS["dog"] / PERSON_HEIGHT)
    assert request_scale("dog") == 1.0  # a dog put on a bed may be put on a person's bed
    bed = for_request("bed", "puppy", "dog")
    assert bed.largest == pytest.approx(tuple(x * ANIMAL_LENGTHS["dog"] / PERSON_HEIGHT for x in get("bed").largest))
    with pytest.raises(ConfigError, match="valid owners: .*dog.*doll"):
        request_scale("apple", "dragon")


def test_coffee_table_and_soap_dish_are_rows_of_their_own_not_their_head_nouns():
    coffee, table = get("coffee table"), get("table")
    low = [0.5, 0.3, 0.22]  # half extents of a 1.0 x 0.6 m top 0.44 m high
    assert coffee.pose_fits(low)[0] and not table.pose_fits(low)[0]
    soap, plate = get("soap dish"), get("plate")
    assert soap.dims_fit([0.12, 0.09, 0.025]) and not plate.dims_fit([0.12, 0.09, 0.025])


def test_the_llm_request_parser_must_give_a_known_owner():
    class Dragon(OfflineProvider):
        def answer(self, stage, request, check):
            answer = offline_request(request).model_copy(update={"owner": "dragon"})
            with pytest.raises(InvalidAnswerError, match="owner must be null"):
                check(answer)
            answer = offline_request(request)
            check(answer)
            return answer

    assert STAGES["request_parser"].version == "2"
    req = parse_request_text(RequestText(text="put the apple in the doll's bowl"), Dragon())
    assert req.owner == "doll" and req.affordance == "bowl"


def test_the_owner_reaches_the_classification_scale():
    """'the doll's chair' asks for a doll's chair even when a block is what is put on it: RunConfig(owner=...)."""
    req = parse_request("put the block on the doll's chair")
    chair = make_object("chair", 1)  # the demo's table-top chair, made at a doll's scale

    def verdict(**scale):
        return classify([chair], [req.affordance], config=RunConfig(provider="offline", pose="as_placed", **scale),
                        progress=False, workers=1)[0]

    assert req.owner == "doll" and not verdict(agent=req.agent).dims_fit
    assert verdict(agent=req.agent, owner=req.owner).dims_fit
