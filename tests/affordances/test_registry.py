"""The affordance registry and its kinds: one answer to "what is a cup?" for every reader."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
from pydantic import ValidationError

from rail_mj.affordances import (
    ANY,
    LIQUID_RADIUS,
    PAPER_AFFORDANCES,
    REGISTRY,
    Affordance,
    Envelope,
    get,
    known_affordances,
    label_key,
    normalize,
)
from rail_mj.affordances.kinds import KINDS, kind_of
from rail_mj.affordances.kinds.container import ContainerParams
from rail_mj.core.errors import UnknownAffordanceError
from rail_mj.dataset import ground_truth as dataset
from rail_mj.dataset.labels import LabelRecord
from rail_mj.llm.checks import check_agent
from rail_mj.llm.offline import offline_agent
from rail_mj.llm.schemas import TaskDescription
from rail_mj.robot.demo import DEMO_AFFORDANCES
from rail_mj.scoring import compile_scoring


def _dims(name: str, where: float) -> list[float]:
    """Sorted dims at the low (0) or high (1) end of a row's typical ranges; an open side a factor 2 off."""
    row = REGISTRY[name]
    env = row.envelope

    def at(rng: tuple[float, float]) -> float:
        lo, hi = rng
        lo, hi = (lo or hi / 2), (hi if np.isfinite(hi) else 2 * lo)
        return lo * (hi / lo) ** where

    if env.ranges():
        width = at(env.width if env.width != ANY else env.length)
        length = at(env.length) if env.length != ANY else width
        return sorted((at(env.height), width, max(width, length)), reverse=True)
    big, small = at(row.largest), at(row.smallest)
    return sorted((big, min(big, small), min(big, small)), reverse=True)


def test_every_kind_name_has_one_kind_file_and_every_row_a_kind():
    assert set(KINDS) == {"container", "seat", "lie", "surface", "dish", "storage"}
    assert all(type(KINDS[k]).__module__ == f"rail_mj.affordances.kinds.{k}" for k in KINDS)
    assert all(KINDS[k].name == k for k in KINDS)
    assert {a.kind for a in REGISTRY.values()} == set(KINDS)


def test_names_are_canonical_and_aliases_unambiguous():
    aliases = [alias for a in REGISTRY.values() for alias in a.aliases]
    assert len(aliases) == len(set(aliases)) and not set(aliases) & set(REGISTRY)
    for a in REGISTRY.values():
        assert normalize(a.name) == a.name == " ".join(a.name.split()).lower()
        assert get(a.key) is a and all(get(alias) is a for alias in a.aliases)


@pytest.mark.parametrize(("given", "canonical", "key"), [
    ("Trash_Bins", "trash bin", "trash_bin"), ("garbage can", "trash bin", "trash_bin"), ("mug", "cup", "cup"),
    ("pen-holder", "pen holder", "pen_holder"), ("shelves", "shelf", "shelf"), ("Bath Tub", "bathtub", "bathtub"),
])
def test_one_normalisation_gives_the_name_and_the_label_key(given, canonical, key):
    assert normalize(given) == canonical
    assert label_key(given) == key == dataset.normalize_affordance(given)


def test_unregistered_names_raise_with_the_known_ones_but_still_make_a_label_key():
    with pytest.raises(UnknownAffordanceError) as err:
        get("trampoline")
    assert all(name in str(err.value) for name in known_affordances())
    assert label_key("  Flux-Capacitor ") == "flux_capacitor"  # labels may name uses the registry does not know


def test_the_paper_flag_is_the_one_list_of_the_paper_affordances():
    assert PAPER_AFFORDANCES == ("cup", "bowl", "vase", "basket", "bathtub", "plate", "table", "chair")
    assert set(PAPER_AFFORDANCES) == {a.name for a in REGISTRY.values() if a.paper}
    assert all(get(n).key == n for n in PAPER_AFFORDANCES)  # the same string in labels and requests
    assert dataset.PAPER_AFFORDANCES is PAPER_AFFORDANCES


def test_the_dataset_answers_registered_affordances_by_their_keys():
    assert all(get(k).key == k for k in dataset.AFFORDANCES)
    for spec in dataset.CLASS_SPECS.values():
        assert all(get(a).key == a for a in spec.affords), spec.name
    assert dataset.ground_truth("cup", "Mugs") and dataset.ground_truth("trash_bin", "garbage can")


def test_a_label_record_naming_one_affordance_twice_is_rejected():
    record = {"mesh": "m.obj", "class": "cup", "affordances": {"Trash bin": True, "trash_bin": False}}
    with pytest.raises(ValidationError, match="'Trash bin' and 'trash_bin' both name the affordance 'trash_bin'"):
        LabelRecord.model_validate(record)


def test_the_robot_demo_names_registered_affordances_and_takes_its_agent_from_the_kind():
    for key, (obj_kind, agent, _) in DEMO_AFFORDANCES.items():
        assert get(key).key == key == obj_kind
        assert agent == ("ball" if get(key).kind == "container" else "block")


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_the_scoring_source_is_the_physics_alone_whatever_the_envelope(name):
    """The envelope is a prior (Affordance.pose_prior), never a mask in the scoring: a pose of an unusual size is
    scored by its physics."""
    row = get(name)
    free = replace(row, envelope=Envelope(rest=row.envelope.rest))
    kind = kind_of(row)
    shape = kind.agent(row, [0.5, 0.4, 0.3])
    assert kind.scoring(row, shape).source == kind.scoring(free, shape).source


def test_a_new_affordance_is_a_row_its_kind_imagines_without_a_new_file():
    stockpot = Affordance("stockpot", "container", "A stockpot holds soup in a deep open cavity.",
                          envelope=Envelope(height=(0.2, 0.45), aspect=(0.6, np.inf)))
    kind = kind_of(stockpot)
    shape = kind.agent(stockpot, [0.35, 0.3, 0.3])
    source = kind.scoring(stockpot, shape).source
    compile_scoring(source)
    assert "e[:, 2] >=" not in source  # its sizes are its prior
    assert stockpot.dims_fit([0.35, 0.3, 0.3]) and not stockpot.dims_fit([0.9, 0.9, 0.8])
    assert [p.name for p in kind.plans(shape)] == ["above", "above_front", "above_back", "above_left", "above_right"]


@pytest.mark.parametrize("where", [0.0, 1.0])
def test_registered_agents_compile(where):
    for name in REGISTRY:
        task = TaskDescription(affordance=name, obb_dims=_dims(name, where))
        check_agent(offline_agent(task), task)


def test_the_registry_imports_without_the_llm_stages_and_the_kinds_import_first():
    light = "import sys, rail_mj.affordances; assert 'rail_mj.llm' not in sys.modules"
    first = "import rail_mj.affordances.kinds as k, rail_mj.llm.offline as o; assert o.kinds is k"
    for code in (light, first):
        subprocess.run([sys.executable, "-c", code], check=True)


def test_a_liquid_is_one_drop_size_in_any_vessel():
    """Water is water: an espresso cup's, a vase's neck's and a bathtub's droplets are the same drop."""
    liquid = [a for a in REGISTRY.values()
              if isinstance(a.params, ContainerParams) and a.params.droplets.max_radius <= LIQUID_RADIUS]
    assert {"cup", "bowl", "vase", "bathtub"} <= {a.name for a in liquid}
    for aff in liquid:
        for middle in (0.05, 0.08, 0.2, 0.8):
            assert KINDS["container"].agent(aff, (middle, middle, middle)).radius == pytest.approx(LIQUID_RADIUS)


@pytest.mark.parametrize("kind, name", [("dish", "plate"), ("surface", "table")])
def test_the_agent_placed_on_a_figures_dish_or_table_is_sized_to_it(kind, name):
    """A doll's side plate or smallest table (a person's scaled by 0.3 / 1.7) gets food or a book sized to it,
    never one wider than the object itself."""
    doll = 0.3 / 1.7
    width = {"plate": 0.15, "table": 0.5}[name] * doll
    shape = KINDS[kind].agent(REGISTRY[name], (width, width, 0.02 * doll))
    assert 2 * shape.radius < width



@pytest.mark.parametrize("name, box, size", [
    ("plate", (0.30, 0.05, 0.02), "width"),  # a strip 5 cm wide is no plate: it is not 15 cm across both ways
    ("saucer", (0.14, 0.04, 0.02), "width"),
    ("tray", (0.50, 0.08, 0.03), "width"),
    ("bowl", (0.70, 0.25, 0.10), "length"),  # a handle makes a bowl 50 cm long at most
    ("basket", (0.90, 0.40, 0.25), "length"),  # a footprint longer than the span of the arms
])
def test_every_size_a_dish_or_vessel_is_defined_by_is_in_its_prior(name, box, size):
    row = get(name)

    def plausibility(dims: tuple[float, ...]) -> float:
        return {f.name: f.plausibility for f in row.pose_prior([v / 2 for v in dims]).factors}[size]

    assert plausibility(box) < 0.5
    fitting = (box[0], 0.25, box[2]) if size == "width" else (0.3, box[1], box[2])
    assert plausibility(fitting) == 1.0
