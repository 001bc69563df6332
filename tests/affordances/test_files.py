"""Affordance files (issue 23): a TOML file's rows are registered, validated, clash-checked, seen by the offline
provider, the classify CLI and worker processes; installed packages add rows through entry points."""

from __future__ import annotations

import importlib.metadata
import json
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

import pytest
import trimesh
from paths import EXAMPLES

from rail_mj.__main__ import main as rail_main
from rail_mj.affordances import REGISTRY, get, known_affordances, load, load_files, normalize, unload_all
from rail_mj.affordances.files import ENTRY_POINT_GROUP, read
from rail_mj.affordances.names import parse_words
from rail_mj.core.errors import AffordanceFileError, ConfigError, UnknownAffordanceError
from rail_mj.eval import cli as eval_cli
from rail_mj.llm import generate_profile
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import RunConfig
from rail_mj.robot import __main__ as robot_cli
from rail_mj.stable_poses import StablePoseConfig

DOG_BED = EXAMPLES / "dog_bed.toml"
FAST = RunConfig(backend="native", stable_poses=StablePoseConfig(n_drops=8))

ROW = """[[affordance]]
name = "{name}"
kind = "lie"
ibd = "A {name} lets a dog lie down."
largest = [0.5, 1.3]
smallest = [0.02, 0.4]
{extra}
"""


@pytest.fixture(autouse=True)
def _fresh_registry(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Every test starts and ends with the built-in rows alone, and caches in a temporary folder."""
    monkeypatch.setenv("RAIL_MJ_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))
    unload_all()
    yield
    unload_all()


def _file(tmp_path: Path, text: str, name: str = "rows.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _cushion(path: Path) -> Path:
    """A convex 0.9 x 0.65 x 0.1 m cushion (no CoACD): a dog bed."""
    trimesh.creation.box(extents=(0.9, 0.65, 0.1)).export(path)
    return path


@pytest.mark.parametrize("example", ["birdbath", "dog_bed", "coaster"])
def test_the_examples_parse(example: str) -> None:
    (entry,) = read(EXAMPLES / f"{example}.toml")
    assert entry.row.name == example.replace("_", " ") and not entry.override and not entry.row.paper


def test_a_loaded_file_is_seen_by_every_lookup_and_the_offline_provider(tmp_path: Path) -> None:
    assert "dog bed" not in known_affordances()
    (row,) = load(DOG_BED)
    assert load(DOG_BED) == (row,)  # a file loaded before is not registered twice
    assert "dog bed" in known_affordances() and REGISTRY["dog bed"] is row
    assert get("Pet_Beds") is row and normalize("dog cushions") == "dog bed"
    assert parse_words("put the puppy on the dog bed").affordance == "dog bed"
    profile = generate_profile("dog bed", [0.9, 0.65, 0.1], provider="offline")
    assert profile.analysis.fits and profile.analysis.ibd == row.ibd and profile.agent.name == "body"
    assert "rest" in profile.scoring.source and len(profile.plans.plans) == 8
    (result,) = classify([_cushion(tmp_path / "cushion.stl")], ["pet bed"],
                         config=FAST.model_copy(update=dict(provider="offline")), progress=False, workers=1)
    assert result.error is None and result.affordance == "dog bed" and result.dims_fit and result.functional
    unload_all()
    with pytest.raises(UnknownAffordanceError):
        get("dog bed")


def test_the_files_reach_worker_processes(tmp_path: Path) -> None:
    cushions = [_cushion(tmp_path / f"c{i}.stl") for i in range(2)]
    results = classify(cushions, ["dog bed"],
                       config=FAST.model_copy(update=dict(provider="offline", affordances_files=[DOG_BED.resolve()])),
                       progress=False, workers=2)
    assert [r.error for r in results] == [None, None]
    assert all(r.affordance == "dog bed" and r.functional for r in results)


def test_the_classify_cli_takes_affordances_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mesh = _cushion(tmp_path / "cushion.stl")
    assert rail_main([str(mesh), "-a", "dog bed", "--provider", "offline", "--backend", "native"]) == 2
    assert "no offline imagination profile for affordance 'dog bed'" in capsys.readouterr().err
    unload_all()
    assert rail_main([str(mesh), "-a", "dog bed", "--provider", "offline", "--backend", "native", "--json",
                      "--affordances-file", str(DOG_BED), "--affordances-file", str(EXAMPLES / "coaster.toml")]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["affordance"] == "dog bed" and result["functional"]
    unload_all()
    bad = _file(tmp_path, ROW.format(name="mat", extra='kind2 = "lie"'))
    assert rail_main([str(mesh), "-a", "mat", "--affordances-file", str(bad)]) == 2
    assert f"error: {bad}: [[affordance]] #1 ('mat'): unknown key 'kind2'" in capsys.readouterr().err


@pytest.mark.parametrize(("text", "message"), [
    (ROW.format(name="mat", extra="").replace('"lie"', '"bathe"'),
     "[[affordance]] #1 ('mat'): kind: unknown kind 'bathe'; valid: container, dish, lie, seat, storage, surface"),
    (ROW.format(name="mat", extra="").replace('ibd = "A mat lets a dog lie down."\n', ""),
     "[[affordance]] #1 ('mat'): missing ibd (required: name, kind, ibd)"),
    (ROW.format(name="mat", extra="").replace("[0.5, 1.3]", "[1.3, 0.5]"),
     "('mat'): largest: must be [lo, hi] in metres with 0 < lo <= hi, both finite; got [1.3, 0.5]"),
    (ROW.format(name="mat", extra="").replace("[0.02, 0.4]", "[0, 0.4]"), "smallest: must be [lo, hi]"),
    (ROW.format(name="mat", extra="").replace("[0.02, 0.4]", "0.4"), "smallest: must be [lo, hi]"),
    (ROW.format(name="mat", extra='colour = "red"'),
     "unknown key 'colour'; valid: name, kind, ibd, largest, smallest, aliases, envelope, params, override"),
    (ROW.format(name="mat", extra="[affordance.envelope]\nheight = [0.4, 0.1]"),
     "envelope.height: must be [lo, hi] with 0 <= lo <= hi (hi may be inf); got [0.4, 0.1]"),
    (ROW.format(name="mat", extra="[affordance.envelope]\ndepth = [0.1, 0.4]"),
     "envelope: unknown key 'depth'; valid: height, width, length, aspect, rest"),
    (ROW.format(name="mat", extra="[affordance.envelope]\nwidths = {height = 20.0}"),
     "envelope.widths: a prior width must be a number in [0.01, 10] (a fraction of the bound); got 20.0"),
    (ROW.format(name="mat", extra="[affordance.envelope]\nwidths = {depth = 0.2}"),
     "envelope.widths: a prior width is for one of height, width, length, height/width, largest dim"),
    (ROW.format(name="mat", extra="[affordance.params]\npersons = 2"),
     "params: unknown key 'persons' for KindParams; valid: none (this kind has no parameters)"),
    (ROW.format(name="bowl2", extra="[affordance.params]\nholds_water = 1").replace('"lie"', '"container"'),
     "('bowl2'): params.holds_water: must be true or false; got 1"),
    (ROW.format(name="bowl2", extra="[affordance.params]\nwater = true").replace('"lie"', '"container"'),
     "params: unknown key 'water' for ContainerParams; valid: droplets, holds_water, basin_length"),
    (ROW.format(name="bowl2", extra="[affordance.params.droplets]\nmax_radius = -1").replace('"lie"', '"container"'),
     "params.droplets.max_radius: must be a number >= 0 (inf allowed); got -1"),
    (ROW.format(name="Dog_Mat", extra=""), "name: 'Dog_Mat' is not canonical: write 'dog mat'"),
    (ROW.format(name="mat", extra='aliases = ["rug", "rug"]'), "aliases: repeat a name"),
    (ROW.format(name="mat", extra="override = 1"), "override: must be true or false; got 1"),
    ('[[affordance]]\nname = "mat"\nkind = lie\n', "not valid TOML: Invalid value (at line 3, column 8)"),
    ('[affordance]\nname = "mat"\n', "write each row as [[affordance]]"),
    ('name = "mat"\n', "unknown top-level key 'name'; an affordance file holds only [[affordance]] tables"),
    ("", "defines no affordance"),
])
def test_a_malformed_file_is_an_error_naming_file_row_field_and_what_is_valid(
    tmp_path: Path, text: str, message: str
) -> None:
    path = _file(tmp_path, text)
    with pytest.raises(AffordanceFileError) as err:
        load(path)
    assert str(err.value).startswith(f"{path}: ") and message in str(err.value)
    assert isinstance(err.value, ConfigError) and "mat" not in known_affordances()


def test_a_missing_file_is_an_error_naming_it(tmp_path: Path) -> None:
    with pytest.raises(AffordanceFileError, match="nowhere.toml: cannot read the affordance file"):
        load(tmp_path / "nowhere.toml")


def test_a_clash_names_both_rows_unless_the_row_overrides(tmp_path: Path) -> None:
    cup = _file(tmp_path, ROW.format(name="cup", extra=""), "cup.toml")
    with pytest.raises(AffordanceFileError, match=f"{cup}: affordance 'cup': its name 'cup' is already the name "
                                                  r"of the affordance 'cup' \(built-in\); .* override = true"):
        load(cup)
    mug = _file(tmp_path, ROW.format(name="teacup", extra='aliases = ["mug"]'), "mug.toml")
    with pytest.raises(AffordanceFileError, match="its alias 'mug' is already an alias of the affordance 'cup'"):
        load(mug)
    first, second = (_file(tmp_path, ROW.format(name="mat", extra=""), f"{n}.toml") for n in ("one", "two"))
    load(first)
    with pytest.raises(AffordanceFileError, match=f"already the name of the affordance 'mat' \\({first}\\)"):
        load(second)
    # a whole file is registered or none of it
    half = _file(tmp_path, ROW.format(name="rug", extra="") + ROW.format(name="bed", extra=""), "half.toml")
    with pytest.raises(AffordanceFileError, match="'bed'"):
        load(half)
    assert "rug" not in known_affordances()
    assert get("cup").kind == "container" and get("mug").name == "cup"


def test_override_replaces_the_row_and_takes_an_alias(tmp_path: Path) -> None:
    built_in = get("cup")
    cup = _file(tmp_path, ROW.format(name="cup", extra="override = true"), "cup.toml")
    (row,) = load(cup)
    assert get("cup") is row and row.kind == "lie" and list(REGISTRY).index("cup") == 0  # in place
    with pytest.raises(UnknownAffordanceError):
        get("mug")  # the replaced row's aliases went with it
    teacup = _file(tmp_path, ROW.format(name="teacup", extra='aliases = ["bin"]\noverride = true'), "teacup.toml")
    load(teacup)
    assert get("bin").name == "teacup" and "bin" not in get("trash bin").aliases and get("garbage can").name == \
        "trash bin"
    alias_as_name = _file(tmp_path, ROW.format(name="beaker", extra='aliases = ["bowl"]\noverride = true'), "b.toml")
    with pytest.raises(AffordanceFileError, match="an alias never replaces a row"):
        load(alias_as_name)
    unload_all()
    assert get("cup") is built_in and get("mug") is built_in and get("bin").name == "trash bin"


def test_a_later_file_may_override_an_earlier_one(tmp_path: Path) -> None:
    first = _file(tmp_path, ROW.format(name="mat", extra=""), "one.toml")
    second = _file(tmp_path, ROW.format(name="mat", extra="override = true").replace("a dog", "a cat"), "two.toml")
    load_files([first, second])
    assert "a cat" in get("mat").ibd


class _EntryPoint(SimpleNamespace):
    def load(self):
        return self.target()


def _entry_points(*eps: _EntryPoint):
    def entry_points(group: str):
        assert group == ENTRY_POINT_GROUP
        return list(eps)
    return entry_points


def test_entry_points_register_lazily_on_the_first_lookup(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    calls = []
    mat = _file(tmp_path, ROW.format(name="mat", extra=""))

    def rows():
        calls.append(1)
        return [mat]

    ep = _EntryPoint(name="mats", value="mat_pkg:rows", dist=SimpleNamespace(name="mat-pkg"), target=lambda: rows)
    monkeypatch.setattr(importlib.metadata, "entry_points", _entry_points(ep))
    assert calls == []
    assert get("mats").name == "mat" and "mat" in known_affordances()
    assert calls == [1]  # once
    clash = _file(tmp_path, ROW.format(name="mat", extra=""), "clash.toml")
    with pytest.raises(AffordanceFileError, match=r"\(entry point 'mats' \(mat_pkg:rows\) of the distribution "
                                                  r"'mat-pkg'\)"):
        load(clash)


def test_a_broken_entry_point_is_an_error_naming_its_distribution(monkeypatch: pytest.MonkeyPatch) -> None:
    def broken():
        raise ImportError("No module named 'mat_pkg'")

    ep = _EntryPoint(name="mats", value="mat_pkg:rows", dist=SimpleNamespace(name="mat-pkg"), target=broken)
    monkeypatch.setattr(importlib.metadata, "entry_points", _entry_points(ep))
    with pytest.raises(AffordanceFileError, match="entry point 'mats' .* of the distribution 'mat-pkg': failed: "
                                                  "ImportError: No module named 'mat_pkg'"):
        get("cup")
    wrong = _EntryPoint(name="mats", value="mat_pkg:rows", dist=SimpleNamespace(name="mat-pkg"), target=lambda: 42)
    monkeypatch.setattr(importlib.metadata, "entry_points", _entry_points(wrong))
    with pytest.raises(AffordanceFileError, match="'mat-pkg'.*: gave a int; an entry point gives affordance file"):
        known_affordances()


def test_the_docs_file_example_takes_over_a_built_in_alias(tmp_path: Path) -> None:
    doc = (EXAMPLES.parent / "docs" / "new_affordance.md").read_text()
    toml = doc.split("```toml\n", 1)[1].split("```", 1)[0]
    (row,) = load(_file(tmp_path, toml))
    assert get("pail") is row and get("bucket").aliases == () and row.params == get("cup").params


def test_the_eval_and_robot_clis_load_the_files_first(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    bad = _file(tmp_path, ROW.format(name="mat", extra="").replace('"lie"', '"bathe"'))
    assert eval_cli.main(["--out", str(tmp_path / "out"), "--provider", "offline", "--affordances-file",
                          str(bad)]) == 2
    assert f"error: {bad}: [[affordance]] #1 ('mat'): kind: unknown kind 'bathe'" in capsys.readouterr().err
    monkeypatch.setattr(robot_cli, "run_demo", lambda *a, **k: pytest.fail("nothing may run"))
    assert robot_cli.main(["--demo", "--affordances-file", str(bad)]) == 2
    assert "unknown kind 'bathe'" in capsys.readouterr().err
    seen = []
    monkeypatch.setattr(robot_cli, "fetch_panda", lambda: seen.append(get("dog bed").name) or tmp_path)
    assert robot_cli.main(["--fetch", "--affordances-file", str(DOG_BED)]) == 0 and seen == ["dog bed"]


def test_every_registered_row_written_as_a_file_reads_back_the_same() -> None:
    """row_toml is what stage 0's examples show a model and what --save-affordance writes: parse() must give back
    the row it was written from, widths and nested params included."""
    import dataclasses

    from rail_mj.affordances.envelope import Envelope
    from rail_mj.affordances.files import row_toml
    from rail_mj.affordances.kinds import ContainerParams, Droplets

    rows = [*REGISTRY.values(), dataclasses.replace(
        REGISTRY["bowl"], name="fruit bowl", aliases=("fruit dish",), paper=False,
        envelope=Envelope(height=(0.06, 0.2), aspect=(0.0, 0.6), widths=(("height/width", 0.3), ("height", 0.2))),
        params=ContainerParams(droplets=Droplets(max_radius=0.05), basin_length=0.1))]
    for row in rows:
        (back,) = read_text(row_toml(row))
        assert dataclasses.replace(back.row, paper=row.paper) == row, row.name


def read_text(text: str):
    from rail_mj.affordances.files import parse

    return parse(text, "written")
