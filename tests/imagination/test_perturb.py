"""Perturbed worlds in one batch, probabilities that stay finite when a rollout blows up, and calibration."""

from dataclasses import fields, replace

import numpy as np
import pytest
from PIL import Image
from scenes import DROPLET, FAST, _cup, _grid, _inside, _pour_plans

from rail_mj.core.errors import ConfigError
from rail_mj.core.profile import MotionPlan
from rail_mj.core.results import AffordanceResult, PoseInfo, PoseProbability
from rail_mj.core.types import AgentSetup
from rail_mj.eval.calibration import brier, calibration, draw_reliability, reliability
from rail_mj.imagination import ImaginationConfig, PerturbationSet, draw_perturbations, get_backend, imagine, prepare
from rail_mj.imagination.batch import outcomes_from_states
from rail_mj.imagination.perturb import world_models
from rail_mj.imagination.worlds import ImaginedWorlds, candidate_plans, fill_perturbed, world_outcomes
from rail_mj.mjcf import OWNER_OBJECT
from rail_mj.pipeline.verdicts import candidate_slots, judge, most_probable
from rail_mj.render.explain import explain, format_explanation
from rail_mj.stable_poses import pose_from_up

K = 3
ZERO = dict(perturb_scale=0.0, perturb_friction=0.0, perturb_agent_mass=0.0, perturb_agent_size=0.0,
            perturb_offset=0.0)


@pytest.fixture(scope="session")
def cup():
    return _cup()


@pytest.fixture(scope="session")
def poses(cup):
    return [pose_from_up(cup, np.array([0.0, 0.0, s]), 0.5) for s in (1.0, -1.0)]


@pytest.fixture(scope="session")
def drops():
    return AgentSetup(fragment=DROPLET, offsets=_grid(2, 0.015), collide_agents=False)


@pytest.fixture(scope="session")
def perturbed(cup, poses, drops):
    ps = draw_perturbations(ImaginationConfig(perturbations=K, seed=3))
    return ps, imagine(cup, poses, drops, _pour_plans(poses), backend="native", config=FAST, perturbations=ps)


def test_perturbation_settings_out_of_range_are_config_errors_naming_the_range():
    for bad in (-1, 33, 2.5, True):
        with pytest.raises(ConfigError, match=r"perturbations must be a whole number in \[0, 32\]"):
            ImaginationConfig(perturbations=bad)
    with pytest.raises(ConfigError, match=r"seed must be a whole number in \[0, 4294967295\]"):
        ImaginationConfig(seed=-1)
    with pytest.raises(ConfigError, match=r"perturb_scale must be a number in \[0, 0.5\]"):
        ImaginationConfig(perturb_scale=0.6)
    assert ImaginationConfig(perturbations=32).perturbations == 32


def test_draws_cover_each_range_and_repeat_with_the_seed():
    cfg = ImaginationConfig(perturbations=8, seed=5)
    ps = draw_perturbations(cfg)
    assert ps == draw_perturbations(cfg) and ps != draw_perturbations(ImaginationConfig(perturbations=8, seed=6))
    assert ps.n_worlds == 9 and ps.worlds[0].nominal
    scales = np.sort(ps.scales[1:])
    # stratified: one draw in each eighth of [0.9, 1.1]
    assert np.all(np.floor((scales - 0.9) / 0.025) == np.arange(8))
    assert all(w.nominal for w in draw_perturbations(ImaginationConfig(perturbations=4, **ZERO)).worlds)


def test_perturbed_worlds_differ_from_each_other_in_the_batch(cup, poses, drops, perturbed):
    ps, out = perturbed
    scene = get_backend("native", FAST).scene(cup, drops)
    models = world_models(scene, ps)
    assert len(models) == K + 1 and models[0] is scene.model
    agent = scene.geom_owner >= 0
    for w, m in zip(ps.worlds[1:], models[1:], strict=True):
        np.testing.assert_allclose(m.mesh_vert, scene.model.mesh_vert * w.scale, rtol=1e-6)
        np.testing.assert_allclose(m.geom_friction[:, 0], scene.model.geom_friction[:, 0] * w.friction)
        np.testing.assert_allclose(m.geom_size[agent], scene.model.geom_size[agent] * w.agent_size)
        bodies = np.unique(m.geom_bodyid[agent])
        np.testing.assert_allclose(m.body_mass[bodies], scene.model.body_mass[bodies] * w.agent_mass)
        body = m.geom_bodyid[scene.geom_owner == OWNER_OBJECT][0]  # the object: same density, scaled
        assert m.body_mass[body] == pytest.approx(scene.model.body_mass[body] * w.scale**3)
    assert out.batch == (K + 1) * 2 * 2 and list(out.world) == [w for w in range(K + 1) for _ in range(4)]
    finals = out.agent_pos.reshape(K + 1, 4, -1)
    for a in range(K + 1):
        for b in range(a + 1, K + 1):
            assert np.abs(finals[a] - finals[b]).max() > 1e-4
    np.testing.assert_allclose(out.object_half_extents[4 * np.arange(K + 1)][:, 0] / poses[0].half_extents[0],
                               ps.scales)
    # every world still pours into the upright cup and not into the inverted one
    inside = _inside(out).mean(axis=1).reshape(K + 1, 2, 2)
    assert np.all(inside[:, 0] >= 0.9) and np.all(inside[:, 1] == 0)


def test_perturbed_worlds_equal_the_nominal_one_at_zero_amplitude(cup, poses, drops):
    ps = draw_perturbations(ImaginationConfig(perturbations=2, **ZERO))
    out = imagine(cup, poses, drops, _pour_plans(poses), backend="native", config=FAST, perturbations=ps)
    nominal = imagine(cup, poses, drops, _pour_plans(poses), backend="native", config=FAST)
    for w in range(3):
        np.testing.assert_allclose(out.agent_pos[4 * w : 4 * w + 4], nominal.agent_pos, atol=1e-9)
        np.testing.assert_array_equal(out.contacts_object[4 * w : 4 * w + 4], nominal.contacts_object)


def test_a_state_that_blew_up_becomes_a_finite_marked_failure(cup, poses, drops):
    scene = get_backend("native", FAST).scene(cup, drops)
    batch = prepare(cup, poses, drops, _pour_plans(poses), FAST)
    qpos = batch.initial_qpos(scene)
    qvel = np.zeros((batch.placement.batch, scene.model.nv))
    qpos[1, :3] = np.nan
    qvel[2, 0] = np.inf
    contacts = np.zeros((batch.placement.batch, scene.n_agents, 3), dtype=np.int64)
    flags = np.zeros((batch.placement.batch, scene.n_agents), dtype=bool)
    warned = np.array([False, False, False, True])
    out = outcomes_from_states(scene, batch.placement, qpos, qvel, contacts, flags, np.ones(4, bool), warned)
    assert out.unstable is not None and out.unstable.tolist() == [False, True, True, True]
    for name in ("agent_pos", "agent_vel", "object_pos", "object_quat", "object_tilt"):
        assert np.all(np.isfinite(getattr(out, name))), name
    assert out.settled.tolist() == [True, False, False, False]


def _plans(n: int) -> list[MotionPlan]:
    return [MotionPlan(name=f"plan{j}", description="pour") for j in range(n)]


def _take(out, rows):
    return replace(out, **{f.name: None if getattr(out, f.name) is None else getattr(out, f.name)[rows]
                           for f in fields(out)})


def _probabilities(ps, out, scores, poses, unstable=None):
    """The verdicts of a batch of every world, split as the pipeline runs it: nominal, then perturbed."""
    if unstable is not None:
        out = replace(out, unstable=unstable)
    # an affordance outside the registry: the generic rules (object upright, agents not on the ground away from it),
    # no size prior
    evidence = ImaginedWorlds("frobnicate", 1.0, _plans(2), poses, [0, 1], [_pour_plans(poses)] * 2, ps)
    evidence.add_nominal(_take(out, slice(0, 4)), scores[:4])
    evidence.add_perturbed(_take(out, slice(4, None)), scores[4:], [(k, j) for k in (0, 1) for j in (0, 1)], [0, 1])
    return judge(evidence, np.ones(3))


def test_probability_is_finite_and_a_blown_up_rollout_is_a_named_failure(poses, perturbed):
    ps, out = perturbed
    scores = np.where(np.arange(out.batch) % 4 < 2, 0.5, -1.0)  # the upright cup's pours succeed, not the other's
    clean = _probabilities(ps, out, scores, poses)
    assert [v.physics for v in clean] == [1.0, 0.0] and clean[0].probability == 1.0 and not clean[0].blew_up
    assert [v.imagined for v in clean] == [K + 1, K + 1]
    unstable = np.zeros(out.batch, dtype=bool)
    unstable[4:6] = True  # world 1, upright pose, both plans
    scores[8] = np.nan  # world 2, upright pose, plan 0: a scoring NaN is no success either
    blown = _probabilities(ps, out, scores, poses, unstable)
    assert blown[0].best_plan == "plan1" and blown[0].successes == K and blown[0].physics == K / (K + 1)
    assert len(blown[0].blew_up) == 2 and "blew up in world 1 (scale" in blown[0].blew_up[0]
    for v in clean + blown:
        for x in (v.prior, v.physics, v.probability):
            assert np.isfinite(x) and 0.0 <= x <= 1.0
    everything = _probabilities(ps, out, np.full(out.batch, np.nan), poses, np.ones(out.batch, dtype=bool))
    assert all(v.probability == 0.0 and len(v.blew_up) == 2 * (K + 1) for v in everything)


def test_explanation_prints_each_factor_and_the_rollouts_that_blew_up(cup, poses):
    v = PoseProbability(index=0, prior=0.5, prior_factors="height 0.2 (typical 0.06-0.16, width 25%): 0.50",
                        physics=0.75, probability=0.375, best_plan="above", successes=3, worlds=4,
                        blew_up=["plan 'above' blew up in world 2 (scale 1.050, ...)"])
    r = AffordanceResult(object="cup", affordance="cup", requested="cup",
                         stable_poses=[PoseInfo.from_pose(0, poses[0])], plans=["above"], scores=[[0.5]],
                         pose_verdicts=[v], probability=0.375, dims_fit=True)
    text = format_explanation(explain(r))
    assert ("probability: prior 0.50 (height 0.2 (typical 0.06-0.16, width 25%): 0.50) x physics 0.75 "
            "(plan 'above' in 3 of 4 worlds) = 0.38") in text
    assert "blew up (a failure): plan 'above' blew up in world 2" in text
    assert "verdict: not functional, probability 0.38" in text
    alone = v.model_copy(update={"physics": 0.0, "probability": 0.0, "best_plan": None, "successes": 0, "imagined": 1})
    assert "no plan succeeded in the nominal world, so the perturbed ones were not imagined" in format_explanation(
        explain(r.model_copy(update={"pose_verdicts": [alone]})))


def test_brier_score_and_reliability_on_synthetic_labels(tmp_path):
    assert brier([1.0, 0.0, 0.8, 0.2], [True, False, True, False]) == pytest.approx(0.02)
    assert brier([0.5] * 4, [True, False, True, False]) == pytest.approx(0.25)
    assert brier([], []) is None
    rng = np.random.default_rng(0)
    p = rng.random(20000)
    y = rng.random(20000) < p  # calibrated by construction
    bins = reliability(p, y)
    assert len(bins) == 10 and sum(b["n"] for b in bins) == 20000
    for b in bins:
        assert b["lo"] <= b["mean_probability"] < b["hi"]
        assert abs(b["positive_fraction"] - b["mean_probability"]) < 0.03
    overconfident = reliability(np.ones(100), np.arange(100) < 60)
    assert overconfident[-1]["n"] == 100 and overconfident[-1]["positive_fraction"] == pytest.approx(0.6)
    lines = [{"error": None, "label": bool(t), "result": {"probability": float(q)}} for q, t in zip(p[:200], y[:200])]
    lines.append({"error": "MeshError: broken", "label": True, "result": {}})
    block = calibration(lines)
    assert block["n"] == 200 and block["brier"] == pytest.approx(brier(p[:200], y[:200]))
    png = draw_reliability(block, tmp_path / "reliability.png")
    with Image.open(png) as img:
        assert img.size == (600, 600)
        # the red calibration curve is drawn
        rgb = np.asarray(img.convert("RGB"), dtype=int)
    assert np.any((rgb[..., 0] > 150) & (rgb[..., 1] < 80) & (rgb[..., 2] < 80))


def test_a_perturbation_set_holds_a_world():
    with pytest.raises(ConfigError, match="at least one world"):
        PerturbationSet(())
    perturbed = draw_perturbations(ImaginationConfig(perturbations=2)).perturbed
    assert PerturbationSet().perturbed is None and perturbed is not None and perturbed.n_worlds == 2


@pytest.mark.slow
def test_mjx_runs_the_perturbed_worlds_as_native_does(cup, poses, drops):
    ps = draw_perturbations(ImaginationConfig(perturbations=2, seed=1))
    native = imagine(cup, poses, drops, _pour_plans(poses), backend="native", config=FAST, perturbations=ps)
    fast = imagine(cup, poses, drops, _pour_plans(poses), backend="mjx", config=FAST, perturbations=ps)
    np.testing.assert_array_equal(_inside(fast), _inside(native))
    np.testing.assert_allclose(fast.agent_pos, native.agent_pos, atol=5e-3)


def test_perturbed_worlds_imagine_again_only_poses_whose_verdict_they_can_change():
    """A pose without a candidate has nothing to confirm; one whose prior is below 0.5 stays below it."""
    scores = np.array([0.5, -1.0, -1.0, -1.0, 0.2, 0.1])  # 3 poses x 2 plans; pose 1 has no candidate
    assert candidate_slots(scores, 3, 2) == [0, 2]
    assert candidate_slots(scores, 3, 2, priors=[0.9, 0.9, 0.49]) == [0]
    assert candidate_slots(scores, 3, 2, priors=[0.5, 0.0, 1.0]) == [0, 2]


def test_perturbed_worlds_imagine_only_the_candidates_and_keep_each_failed_plan_as_it_failed(cup, poses, drops,
                                                                                              perturbed):
    """Only the plans that scored above 0 go to the perturbed worlds; spread back, their rollouts are the ones a
    call imagining every plan gives, and every other plan is the nominal world's failure, not blown up."""
    ps, full = perturbed
    nominal_scores = np.array([1.0, -1.0, -0.5, 0.4])  # pose 0: plan 0 a candidate; pose 1: plan 1
    pairs = candidate_plans(nominal_scores, [0, 1], 2)
    assert pairs == [(0, 0), (1, 1)]
    # a plan the kind's pose rules read whatever it scored (a vessel's every pour, for a leak) goes along
    assert candidate_plans(nominal_scores, [0, 1], 2, evidence={1}) == [(0, 0), (0, 1), (1, 1)]
    again = imagine(cup, [poses[k] for k, _ in pairs], drops, [[_pour_plans(poses)[j]] for _, j in pairs],
                    backend="native", config=FAST, perturbations=ps.perturbed)
    assert again.batch == K * len(pairs)
    nominal = world_outcomes(full, np.zeros(full.batch), K + 1)[0][0]
    out, scores = fill_perturbed((nominal, nominal_scores), (again, np.full(again.batch, 0.7)), pairs, [0, 1], 2, K)
    assert out.batch == K * 4 and list(out.world) == [w for w in range(K) for _ in range(4)]
    assert out.plan_index.tolist() == [0, 1] * 2 * K and out.pose_index.tolist() == [0, 0, 1, 1] * K
    candidate = np.array([True, False, False, True] * K)
    np.testing.assert_allclose(out.agent_pos[candidate], full.agent_pos[4:][candidate])
    np.testing.assert_allclose(out.agent_pos[~candidate], np.tile(nominal.agent_pos, (K, 1, 1))[~candidate])
    np.testing.assert_array_equal(scores, np.tile([0.7, -1.0, -0.5, 0.7], K))
    assert out.unstable is not None and not out.unstable.any()


def test_kinds_name_the_plans_their_pose_rules_read_whatever_they_scored():
    """A leak from any pour refuses a vessel's pose, a bench needs both places side by side, a plate needs its
    centre: those plans are imagined in every world. A chair's places to either side are not: where the body did not
    sit in the nominal world it counts as not sitting in each perturbed one, as every failed plan does."""
    from rail_mj.affordances.judge import rules_row
    from rail_mj.affordances.kinds import kind_of

    def evidence(name: str) -> set[str]:
        row = rules_row(name, 1.0)
        assert row is not None
        kind = kind_of(row)
        return kind.evidence_plans(row, [p.name for p in kind.plans(kind.agent(row, [1.0, 0.5, 0.4]))])

    assert evidence("cup") == {"above", "above_front", "above_back", "above_left", "above_right"}
    assert evidence("table") == set()
    assert evidence("chair") == set()
    assert len(evidence("bench")) == 12  # two places side by side x two headings x three depths
    assert evidence("plate") == {"above"}
    assert evidence("bed") == set()


def test_poses_one_world_apart_tie_and_stage_7s_pick_breaks_the_tie():
    """Five worlds tell 4/5 from 5/5 by one world only: an upright chair that failed one perturbed world is as
    probable as the chair on its side, and stage 7's pick (the one whose back bears the torso) is the functional
    pose. Two worlds apart, the more probable pose wins whatever stage 7 picked."""
    from types import SimpleNamespace

    def pose(i: int, successes: int) -> PoseProbability:
        return PoseProbability(index=i, prior=1.0, physics=successes / 5, probability=successes / 5,
                               best_plan="facing_front" if successes else None, successes=successes, worlds=5,
                               imagined=5)

    stable = [SimpleNamespace(probability=p) for p in (0.4, 0.3, 0.2, 0.1)]
    one_apart = [pose(0, 5), pose(1, 4), pose(2, 0), pose(3, 2)]
    assert most_probable(one_apart, stable, stage7_best=1).index == 1  # type: ignore[arg-type]
    assert most_probable(one_apart, stable, stage7_best=None).index == 0  # type: ignore[arg-type]
    tied = AffordanceResult(object="chair", affordance="chair", requested="chair", functional=True,
                            stable_poses=[PoseInfo(index=i, pos=[0.0] * 3, quat=[1.0, 0, 0, 0], probability=0.25,
                                                   half_extents=[0.3] * 3, up_in_mesh_frame=[0.0, 0.0, 1.0])
                                          for i in range(4)],
                            pose_verdicts=one_apart, probability=1.0, functional_pose=None)
    tied.functional_pose = tied.stable_poses[1]
    assert "probability 1.00 (pose 1: 0.80, within one world of the most probable pose" in format_explanation(
        explain(tied))
    two_apart = [pose(0, 5), pose(1, 3), pose(2, 0), pose(3, 2)]
    assert most_probable(two_apart, stable, stage7_best=1).index == 0  # type: ignore[arg-type]
    below = [pose(0, 3), pose(1, 2)]  # 0.4 is one world from 0.6 but not functional
    assert most_probable(below, stable, stage7_best=1).index == 0  # type: ignore[arg-type]


def test_a_factor_every_pose_carries_moves_no_pose_out_of_a_tie():
    """An object of unknown up carries one factor on every pose (0.64 for an armchair): upright, seated in 3 of 5
    worlds, is one world from its back's 4 of 5, and stays stage 7's pick, though 0.6 x 0.64 is under 0.5."""
    from types import SimpleNamespace

    f = 0.64

    def pose(i: int, successes: int) -> PoseProbability:
        return PoseProbability(index=i, prior=f, physics=successes / 5, probability=f * successes / 5,
                               best_plan="facing_front" if successes else None, successes=successes, worlds=5,
                               imagined=5)

    stable = [SimpleNamespace(probability=p) for p in (0.5, 0.5)]
    verdicts = [pose(0, 4), pose(1, 3)]
    assert most_probable(verdicts, stable, stage7_best=1, common=f).index == 1  # type: ignore[arg-type]
    assert most_probable(verdicts, stable, stage7_best=1).index == 0  # type: ignore[arg-type]
    two_apart = [pose(0, 5), pose(1, 3)]
    assert most_probable(two_apart, stable, stage7_best=1, common=f).index == 0  # type: ignore[arg-type]


def test_a_world_with_a_resized_body_judges_it_by_the_row_scaled_for_that_body():
    """The seat rules read the body's own size (its toe reach, its hips over the seat): a world whose body is 10%
    larger is judged for that body, as a doll's chair is for a doll. A cup's rules read no agent size."""
    from rail_mj.affordances.judge import rules_row, world_row
    from rail_mj.affordances.kinds import kind_of

    chair = rules_row("chair")
    assert chair is not None
    big = world_row("chair", 1.0, 1.1)
    assert big is not None and big.scale == pytest.approx(1.1)
    nominal, larger = (kind_of(chair).agent(row, [0.9, 0.5, 0.4]).body for row in (chair, big))
    assert nominal is not None and larger is not None
    assert larger.ankle == pytest.approx(1.1 * nominal.ankle) and larger.foot == pytest.approx(1.1 * nominal.foot)
    assert big.envelope.rest == pytest.approx(tuple(1.1 * v for v in chair.envelope.rest))
    assert world_row("chair", 1.0, 1.0) == chair
    assert world_row("cup", 1.0, 1.1) == rules_row("cup")
