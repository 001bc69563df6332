"""Generated scoring functions: paper-style scores match direct numpy, inputs and limits are checked."""

from __future__ import annotations

import numpy as np
import pytest

from rail_mj.core.errors import ConfigError, ScoringRuntimeError, UnsafeCodeError
from rail_mj.core.types import SCORING_ARGS, Outcomes
from rail_mj.scoring import (
    RejectedCodeError,
    close_workers,
    compile_scoring,
    scoring_rules,
    warm_up,
    worker_count,
)
from rail_mj.scoring.pool import _worker_env

SIGNATURE = f"def score({', '.join(SCORING_ARGS)}):"

CONTAINMENT = SIGNATURE + '''
    """Fraction of droplets inside the object's box and off the ground, minus the threshold."""
    h = object_half_extents[:, None, :]
    inside = np.all(np.abs(agent_pos) <= h, axis=-1)
    kept = np.logical_and(inside, contacts_ground == 0)
    return kept.mean(axis=1) - 0.5
'''

SITTING = SIGNATURE + '''
    seat_h = 0.1
    p = agent_pos[:, 0, :]
    q = agent_quat[:, 0, :]
    up_z = 1.0 - 2.0 * (q[:, 1] ** 2 + q[:, 2] ** 2)
    upright = up_z > np.cos(np.deg2rad(20.0))
    height_ok = np.abs(p[:, 2] - (object_half_extents[:, 2] + seat_h)) < 0.05
    over = np.all(np.abs(p[:, :2]) <= object_half_extents[:, :2], axis=1)
    ok = upright & height_ok & over & (object_tilt < 0.2)
    return np.where(ok, 1.0, -1.0)
'''

# written in the loop style LLMs often produce, with a nested helper and annotations
TABLE = SIGNATURE.replace("agent_pos,", "agent_pos: np.ndarray,").replace("):", ") -> np.ndarray:") + '''
    def level(q):
        return 1.0 - 2.0 * (q[1] ** 2 + q[2] ** 2) > 0.985

    scores: list = []
    for b in range(agent_pos.shape[0]):
        p = agent_pos[b, 0]
        on_top = p[2] > object_half_extents[b, 2] and contacts_object[b, 0] > 0
        off_ground = contacts_ground[b, 0] == 0
        still = np.linalg.norm(agent_vel[b, 0]) < 0.05
        if on_top and off_ground and still and level(agent_quat[b, 0]):
            scores.append(1.0)
        else:
            scores.append(-1.0)
    return np.array(scores)
'''


def _quat_tilted(rng: np.random.Generator, shape: tuple[int, ...], max_angle: float) -> np.ndarray:
    angle = rng.uniform(0.0, max_angle, shape)
    axis = rng.normal(size=shape + (3,))
    axis[..., 2] = 0.0
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    return np.concatenate([np.cos(angle / 2)[..., None], np.sin(angle / 2)[..., None] * axis], axis=-1)


def make_outcomes(batch: int, n_agents: int, seed: int = 0) -> Outcomes:
    rng = np.random.default_rng(seed)
    half = rng.uniform(0.05, 0.3, (batch, 3))
    spread = rng.uniform(0.8, 2.0, (batch, 1, 1))  # per rollout, so kept fractions range widely
    pos = rng.uniform(-1.0, 1.0, (batch, n_agents, 3)) * half[:, None, :] * spread
    return Outcomes(
        pose_index=np.arange(batch) // 4,
        plan_index=np.arange(batch) % 4,
        agent_pos=pos,
        agent_quat=_quat_tilted(rng, (batch, n_agents), 0.6),
        agent_vel=rng.normal(0.0, 0.05, (batch, n_agents, 3)),
        contacts_object=rng.integers(0, 3, (batch, n_agents)),
        contacts_agents=rng.integers(0, 3, (batch, n_agents)),
        contacts_ground=rng.integers(0, 2, (batch, n_agents)) * (rng.random((batch, n_agents)) < 0.3),
        released_early=np.zeros((batch, n_agents), bool),
        object_pos=rng.normal(0.0, 0.01, (batch, 3)),
        object_quat=np.tile([1.0, 0.0, 0.0, 0.0], (batch, 1)),
        object_tilt=rng.uniform(0.0, 0.4, batch),
        object_half_extents=half,
        settled=np.ones(batch, bool),
    )


def table_outcomes(batch: int, seed: int = 3) -> Outcomes:
    """One box agent; every other one on top and still, every third one level, so all branches occur."""
    o = make_outcomes(batch, 1, seed)
    pos, vel, quat = o.agent_pos.copy(), o.agent_vel.copy(), o.agent_quat.copy()
    pos[::2, 0, 2] = o.object_half_extents[::2, 2] + 0.05
    vel[::2] *= 0.1
    quat[::3] = [1.0, 0.0, 0.0, 0.0]
    return Outcomes(**{**o.__dict__, "agent_pos": pos, "agent_vel": vel, "agent_quat": quat})


def sitting_outcomes(batch: int, seed: int = 1) -> Outcomes:
    """One agent; about half seated at the right height (seat half-height 0.1) so both classes occur."""
    o = make_outcomes(batch, 1, seed)
    rng = np.random.default_rng(seed + 1)
    z = o.object_half_extents[:, 2] + 0.1 + rng.normal(0.0, 0.04, batch)
    pos = o.agent_pos.copy()
    pos[:, 0, 2] = z
    return Outcomes(**{**o.__dict__, "agent_pos": pos})


@pytest.fixture(scope="module", autouse=True)
def warm_worker():
    warm_up(1)
    yield


def test_containment_matches_numpy():
    o = make_outcomes(200, 27)
    got = compile_scoring(CONTAINMENT)(outcomes=o)
    inside = np.all(np.abs(o.agent_pos) <= o.object_half_extents[:, None, :], axis=-1)
    want = (inside & (o.contacts_ground == 0)).mean(axis=1) - 0.5
    assert got.dtype == np.float64 and got.shape == (200,)
    np.testing.assert_array_equal(got, want)
    assert 0 < (got > 0).sum() < 200


def test_sitting_matches_numpy():
    o = sitting_outcomes(300)
    got = compile_scoring(SITTING)(o)
    p, q, h = o.agent_pos[:, 0], o.agent_quat[:, 0], o.object_half_extents
    upright = 1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2) > np.cos(np.radians(20))
    ok = (upright & (np.abs(p[:, 2] - h[:, 2] - 0.1) < 0.05) & np.all(np.abs(p[:, :2]) <= h[:, :2], axis=1)
          & (o.object_tilt < 0.2))
    np.testing.assert_array_equal(got, np.where(ok, 1.0, -1.0))
    assert 0 < ok.sum() < 300


def test_table_loop_style_with_helper_and_annotations_matches_numpy():
    o = table_outcomes(64)
    got = compile_scoring(TABLE)(**o.scoring_kwargs())
    p, q = o.agent_pos[:, 0], o.agent_quat[:, 0]
    ok = ((p[:, 2] > o.object_half_extents[:, 2]) & (o.contacts_object[:, 0] > 0) & (o.contacts_ground[:, 0] == 0)
          & (np.linalg.norm(o.agent_vel[:, 0], axis=1) < 0.05) & (1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2) > 0.985))
    np.testing.assert_array_equal(got, np.where(ok, 1.0, -1.0))
    assert ok.any() and not ok.all()


def test_bool_and_int_outputs_become_float64():
    o = make_outcomes(10, 2)
    as_bool = compile_scoring(SIGNATURE + "\n    return object_tilt < 0.2\n")(o)
    as_int = compile_scoring(SIGNATURE + "\n    return contacts_object.sum(axis=1)\n")(o)
    assert as_bool.dtype == as_int.dtype == np.float64
    np.testing.assert_array_equal(as_bool, (o.object_tilt < 0.2).astype(float))
    np.testing.assert_array_equal(as_int, o.contacts_object.sum(axis=1).astype(float))


def test_in_place_edits_stay_in_the_worker():
    o = make_outcomes(8, 3)
    before = o.agent_pos.copy()
    f = compile_scoring(SIGNATURE + "\n    agent_pos -= 100.0\n    return agent_pos[:, 0, 0]\n")
    np.testing.assert_array_equal(f(o), before[:, 0, 0] - 100.0)
    np.testing.assert_array_equal(o.agent_pos, before)


def test_empty_batch_returns_empty():
    o = make_outcomes(0, 3)
    assert compile_scoring(CONTAINMENT)(o).shape == (0,)


def test_runtime_error_names_line_and_worker_survives():
    f = compile_scoring(SIGNATURE + "\n    x = 1\n    y = x / 0\n    return object_tilt\n")
    with pytest.raises(ScoringRuntimeError, match=r"line 3.*ZeroDivisionError"):
        f(make_outcomes(4, 1))
    assert worker_count() >= 1
    assert compile_scoring(CONTAINMENT)(make_outcomes(4, 27)).shape == (4,)


def test_rejection_names_line_and_construct():
    src = CONTAINMENT.replace("    h = ", "    import os\n    h = ")
    with pytest.raises(RejectedCodeError, match=r"line 3: import statement") as info:
        compile_scoring(src)
    assert info.value.line == 3
    assert isinstance(info.value, UnsafeCodeError)


@pytest.mark.parametrize("header", [
    "def score(agent_pos):",
    "def score(" + ", ".join(reversed(SCORING_ARGS)) + "):",
    "def score(" + ", ".join(SCORING_ARGS) + ", extra=1):",
    "def score(*args):",
    "def scorer(" + ", ".join(SCORING_ARGS) + "):",
])
def test_wrong_signature_rejected(header):
    with pytest.raises(UnsafeCodeError, match="score"):
        compile_scoring(header + "\n    return object_tilt\n")


def test_argument_errors_are_config_errors():
    f = compile_scoring(CONTAINMENT)
    o = make_outcomes(4, 2)
    kw = o.scoring_kwargs()
    with pytest.raises(ConfigError, match="missing"):
        f(**{k: v for k, v in kw.items() if k != "agent_vel"})
    with pytest.raises(ConfigError, match="unknown"):
        f(**kw, released_early=o.released_early)
    with pytest.raises(ConfigError, match="batch size 4"):
        f(**{**kw, "object_tilt": np.zeros(5)})
    with pytest.raises(ConfigError, match="dtype"):
        f(**{**kw, "object_tilt": np.array(["a"] * 4)})
    with pytest.raises(ConfigError, match="not both"):
        f(o, agent_pos=o.agent_pos)
    with pytest.raises(ConfigError, match="timeout_s"):
        compile_scoring(CONTAINMENT, timeout_s=0)
    with pytest.raises(ConfigError, match="memory_mb"):
        compile_scoring(CONTAINMENT, memory_mb=1)


def test_rules_text_lists_the_allow_list():
    rules = scoring_rules()
    for name in ("np.{", "linalg", "clip", "astype", SIGNATURE[:-1]):
        assert name in rules


def test_worker_env_drops_secrets(monkeypatch):
    monkeypatch.setenv("ANTHROPIC_API_KEY", "sk-secret")
    env = _worker_env()
    assert "ANTHROPIC_API_KEY" not in env
    assert env["OPENBLAS_NUM_THREADS"] == "1"


def test_close_workers_then_fresh_worker_scores():
    close_workers()
    assert worker_count() == 0
    o = make_outcomes(16, 27)
    got = compile_scoring(CONTAINMENT)(o)
    inside = np.all(np.abs(o.agent_pos) <= o.object_half_extents[:, None, :], axis=-1)
    np.testing.assert_array_equal(got, (inside & (o.contacts_ground == 0)).mean(axis=1) - 0.5)
