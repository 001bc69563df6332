"""docs/new_affordance.md's worked example, end to end: a kind defined here registers, a row uses it, and the
offline provider answers every stage for it."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from typing import cast

import pytest

from rail_mj.affordances import REGISTRY, Affordance, Envelope, KindParams, registry
from rail_mj.affordances.kinds import KINDS, AgentShape, SeatParams, kind_of, register_kind
from rail_mj.affordances.kinds.base import box_agent, rest_bounds, rest_scoring, rest_window, rest_words
from rail_mj.affordances.kinds.lowering import Lowering
from rail_mj.affordances.row import KIND_PARAMS
from rail_mj.core.errors import ConfigError
from rail_mj.core.profile import CandidateInteraction, PoseCandidates, ResultSummary, ScoringCode
from rail_mj.llm import FunctionalPoseRequest, analyze_functional_poses, generate_profile, get_provider


@dataclass(frozen=True)
class StandParams(KindParams):
    """A stand row's own field: the half size of the plant placed on it."""

    item_half: float = 0.05  # m, a length: it scales with the agent

    def scaled(self, factor: float) -> StandParams:
        return replace(self, item_half=self.item_half * factor)


class Stand(Lowering):
    name = "stand"
    params_model = StandParams
    agent_description = "One box standing for a potted plant placed on the object."
    interaction_description = ("The box is lowered onto the object from above at its centre and at offsets; "
                               "released at contact.")
    expected_outcome = "The box rests level on top of the {name}, not touching the ground."
    offset = 0.3
    target = "the top"

    def agent(self, aff: Affordance, dims: Sequence[float]) -> AgentShape:
        half = cast(StandParams, aff.params).item_half
        return box_agent("plant", (half, half, half))

    def scoring(self, aff: Affordance, shape: AgentShape) -> ScoringCode:
        return rest_scoring(aff, shape, *rest_bounds(aff), 15, 15, f"level on top {rest_words(aff)}")

    def window(self, aff: Affordance) -> tuple[float, float]:
        return rest_window(aff, cast(StandParams, aff.params).item_half)


@pytest.fixture
def plant_stand(monkeypatch: pytest.MonkeyPatch) -> Iterator[Affordance]:
    """The doc's steps at the API level: register the kind (``@register_kind``), add its row to the registry;
    both undone afterwards so the other tests see the built-in kinds and rows only."""
    register_kind(Stand)
    try:
        row = Affordance("plant stand", "stand", "A plant stand holds a potted plant on a small level top 0.3-1 m "
                         "high.", (0.3, 1.1), (0.2, 0.6), envelope=Envelope(rest=(0.29, 1.01)),
                         params=StandParams(item_half=0.06))
        monkeypatch.setitem(REGISTRY, row.name, row)
        monkeypatch.setitem(registry.BY_NAME, row.name, row)
        yield row
    finally:
        KINDS.pop(Stand.name)
        KIND_PARAMS.pop(Stand.name)


def test_a_registered_kind_checks_its_rows_params_and_scales_them(plant_stand: Affordance) -> None:
    assert isinstance(kind_of(plant_stand), Stand) and KINDS["stand"] is kind_of(plant_stand)
    assert Affordance("stand", "stand", "a stand", (0.3, 1.1), (0.2, 0.6)).params == StandParams()
    assert plant_stand.scaled(0.5).params == StandParams(item_half=0.03)
    with pytest.raises(ConfigError, match="must be a StandParams; got a SeatParams"):
        Affordance("stand", "stand", "a stand", (0.3, 1.1), (0.2, 0.6), params=SeatParams())
    with pytest.raises(ConfigError, match="already registered"):
        register_kind(Stand)


def test_the_offline_provider_answers_every_stage_for_a_row_of_the_new_kind(plant_stand: Affordance) -> None:
    assert get_provider("offline").affordance_name("Plant Stands") == "plant stand"
    profile = generate_profile("plant stand", [0.7, 0.4, 0.4], provider="offline")
    assert profile.analysis.fits and profile.agent.name == "plant"
    assert [p.name for p in profile.plans.plans] == ["above", "above_front", "above_back", "above_left",
                                                     "above_right"]
    assert "plant rests" in profile.scoring.description  # the physics; the row's sizes are its prior

    def candidate(plan: str, mean_height: float, on_ground: float) -> CandidateInteraction:
        summary = ResultSummary(frac_inside_bbox=0.0, frac_on_ground=on_ground, frac_touching_object=1.0,
                                mean_height=mean_height, object_tilt_deg=0.0, agent_tilt_deg=0.0, agent_speed=0.0)
        return CandidateInteraction(plan=plan, description="", via_poses=[[0.0, 0.0, 1.0]], score=0.4,
                                    summary=summary)

    h = [0.2, 0.2, 0.35]  # standing: the plant's centre rests 0.76 m up, on the 0.7 m top
    standing = PoseCandidates(pose_index=0, probability=0.6, half_extents=h,
                              candidates=[candidate("above", 1.0 + 0.06 / 0.35, 0.0)])
    fallen = PoseCandidates(pose_index=1, probability=0.4, half_extents=h,
                            candidates=[candidate("above", -0.5, 1.0)])
    verdict = analyze_functional_poses(FunctionalPoseRequest(affordance="plant stand", expected_outcome="rests",
                                                             poses=[standing, fallen]), "offline")
    assert [v.accept for v in verdict.poses] == [True, False]
    assert verdict.best_pose == 0 and verdict.best_plan == "above"


@pytest.mark.parametrize("on_ground, touching, tilt, accepted, words", [
    (0.0, 1.0, 0.5, True, "rest on it or against it"),
    (1.0, 1.0, 0.5, True, "rest on it or against it"),  # books on the floor leaning on a bookend
    (0.9, 0.1, 0.5, False, "on the ground, away from the object"),  # droplets spilled beside a cup
    (0.0, 1.0, 60.0, False, "tipping"),
])
def test_the_generic_rules_refuse_tipping_and_agents_that_ended_on_the_ground_away_from_the_object(
        on_ground, touching, tilt, accepted, words) -> None:
    from rail_mj.affordances.kinds import judge_unregistered

    summary = ResultSummary(frac_inside_bbox=0.0, frac_on_ground=on_ground, frac_touching_object=touching,
                            mean_height=-0.5, object_tilt_deg=tilt, agent_tilt_deg=5.0, agent_speed=0.0)
    ok, why = judge_unregistered(CandidateInteraction(plan="front", description="lean", score=0.5, summary=summary,
                                                      via_poses=[[2.0, 0.0, 0.0], [1.1, 0.0, 0.0]]))
    assert ok is accepted and words in why
