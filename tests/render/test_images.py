"""Pictures: the captioned result picture, the contact sheet, units/up in the eval report, image and video files."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from PIL import Image

from rail_mj import llm
from rail_mj.core.errors import RailError
from rail_mj.core.results import AffordanceResult, PlanInfo, PoseInfo
from rail_mj.core.types import RailObject
from rail_mj.dataset.labels import LabelRecord
from rail_mj.dataset.shapes.parts import _revolve
from rail_mj.render.captions import caption, nothing_to_draw
from rail_mj.render.files import write_frames, write_image
from rail_mj.render.images import render_contact_sheet, render_result
from rail_mj.render.scene import AGENT_RGBA

R_TOP, HEIGHT, WALL, BASE = 0.04, 0.07, 0.004, 0.006
DROPLET_R = 0.005
DROPLET = ('<mujoco><worldbody><body name="droplet"><geom name="droplet_geom" type="sphere" size="0.005" '
           'mass="0.0005" rgba="0.2 0.5 0.9 1"/></body></worldbody></mujoco>')
W, H = 320, 240


def _cup_mesh() -> trimesh.Trimesh:
    return _revolve([(0.0, 0.0), (R_TOP, 0.0), (R_TOP, HEIGHT), (R_TOP - WALL, HEIGHT), (R_TOP - WALL, BASE),
                     (0.0, BASE)], sections=24)


def _ring_hulls(n: int = 12) -> tuple[np.ndarray, ...]:
    """The cup as convex parts without CoACD: a base disc and ``n`` wall segments."""
    a = np.linspace(0, 2 * np.pi, n + 1)
    disc = [(R_TOP * np.cos(t), R_TOP * np.sin(t), z) for t in a[:-1] for z in (0.0, BASE)]
    walls = tuple(
        np.array([(r * np.cos(t), r * np.sin(t), z) for r in (R_TOP - WALL, R_TOP) for t in a[k:k + 2]
                  for z in (0.0, HEIGHT)])
        for k in range(n)
    )
    return (np.array(disc), *walls)


@pytest.fixture(scope="module")
def cup() -> RailObject:
    mesh = _cup_mesh()
    return RailObject(name="cup", mesh=mesh, hulls=_ring_hulls(), mesh_hash="test-cup",
                      obb_dims=np.array([2 * R_TOP, 2 * R_TOP, HEIGHT]), com=np.array([0.0, 0.0, HEIGHT / 3]),
                      mass=0.1, density=500.0)


def _pose(index: int, quat, probability: float) -> PoseInfo:
    """A resting placement of the cup with orientation ``quat``: box centred on x = y = 0, lowest point on z = 0."""
    q = np.asarray(quat, dtype=float)
    rot = trimesh.transformations.quaternion_matrix(q)[:3, :3]
    v = _cup_mesh().vertices @ rot.T
    lo, hi = v.min(axis=0), v.max(axis=0)
    pos = -np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    up = rot.T @ np.array([0.0, 0.0, 1.0])
    return PoseInfo(index=index, pos=pos.tolist(), quat=q.tolist(), probability=probability,
                    half_extents=((hi - lo) / 2).tolist(), up_in_mesh_frame=up.tolist())


def _droplets_by_the_near_wall() -> list[list[float]]:
    """Five droplets resting on the cup's floor against the wall on the +x -y side (task frame). A camera
    fixed at azimuth 135°, elevation -55° looks over that wall and does not see them."""
    z = -HEIGHT / 2 + BASE + DROPLET_R
    d = np.array([1.0, -1.0]) / np.sqrt(2)
    side = np.array([1.0, 1.0]) / np.sqrt(2)
    r = R_TOP - WALL - DROPLET_R - 0.001
    return [[*(r * d + s * side), z] for s in (-0.012, -0.006, 0.0, 0.006, 0.012)]


def _result(fragment: str = DROPLET, plans: list[str] | None = None, **extra) -> AffordanceResult:
    plans = plans or ["above", "above_front"]
    upright = _pose(0, [1, 0, 0, 0], 0.8)
    base = dict(
        object="cup", affordance="cup", requested="cup", dims_fit=True, functional=True,
        functional_pose=upright, stable_poses=[upright, _pose(1, [0, 1, 0, 0], 0.2)], plans=plans,
        scores=[[0.5] + [0.25] * (len(plans) - 1), [-0.5] * len(plans)],
        best_plan=PlanInfo(index=0, name=plans[0], description="pour from above", via_poses=[], score=0.5),
        agent_fragment=fragment, evidence_pose=0, evidence_agent_pos=_droplets_by_the_near_wall(),
        provider="offline", backend="native",
    )
    return AffordanceResult(**{**base, **extra})


def _image(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB")).astype(int)


def _agent_pixels(rgb: np.ndarray) -> int:
    """Pixels of the agent colour (a saturated blue under any shading), nothing of the tan object or grey ground."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    assert AGENT_RGBA[2] > AGENT_RGBA[0] + 0.5  # the test's idea of the agent colour
    return int(np.sum((b > 90) & (b > r + 60) & (b > g + 30)))


def test_picture_size_caption_and_droplets(cup, tmp_path):
    path = render_result(cup, _result(), tmp_path / "cup.png", width=W, height=H)
    rgb = _image(path)
    assert rgb.shape[1] == W and rgb.shape[0] > H + 30  # the picture and a caption band under it
    band = rgb[H:]
    assert np.sum(band.max(axis=2) < 100) > 200  # dark text on the light band
    assert _agent_pixels(rgb[:H]) > 5 * 20  # the five droplets, each more than a few pixels


def test_caption_states_what_is_drawn(cup):
    r = _result()
    text = " | ".join(caption(r, cup))
    for part in ("cup", "affordance 'cup'", "FUNCTIONAL", "pose #0", "p = 0.80", "plan 'above'", "score 0.50",
                 f"{len(cup.hulls)} CoACD convex hulls"):
        assert part in text, (part, text)
    assert "original mesh" in " ".join(caption(r, cup, draw_mesh=True))
    no = caption(_result(functional=False, functional_pose=None, best_plan=None, evidence_pose=1), cup)
    assert "NOT FUNCTIONAL" in no[0] and "pose #1" in no[1] and "best-scoring" in no[1]


def test_draw_mesh_draws_the_original_mesh(cup, tmp_path):
    hulls = _image(render_result(cup, _result(), tmp_path / "h.png", width=W, height=H))
    mesh = _image(render_result(cup, _result(), tmp_path / "m.png", width=W, height=H, draw_mesh=True))
    assert np.mean(np.abs(hulls[:H] - mesh[:H])) > 0.5  # another drawing of the same cup
    assert _agent_pixels(mesh[:H]) > 5 * 20


def test_nothing_to_draw_when_the_dimension_check_failed(cup, tmp_path):
    r = AffordanceResult(object="cup", affordance="chair", requested="chair", dims_fit=False,
                         analyzer_reasons=["The object (largest 0.080 m) does not fit: a chair is 0.4-1.2 m"])
    why = nothing_to_draw(r)
    assert "nothing to draw" in why and "dimension check failed" in why and "does not fit" in why
    with pytest.raises(RailError, match="dimension check failed"):
        render_result(cup, r, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()
    assert nothing_to_draw(_result()) is None


def test_contact_sheet_one_tile_per_stable_pose(cup, tmp_path):
    profile = llm.generate_profile("cup", cup.obb_dims, "offline")
    names = [p.name for p in profile.plans.plans]
    r = _result(fragment=profile.agent.mjcf, plans=names)
    tile = (200, 150)
    sheet = render_contact_sheet(cup, r, tmp_path / "sheet.png", profile=profile, tile=tile)
    assert sheet.tiles == ((0, 0), (1, 0))  # every stable pose once, with its best-scoring plan
    rgb = _image(sheet.path)
    assert sheet.columns == 2 and 2 * tile[0] < rgb.shape[1] < 2 * tile[0] + 40
    assert rgb.shape[0] > tile[1] + 40  # header + a row of captioned tiles
    other = llm.generate_profile("basket", cup.obb_dims, "offline")  # items, not water: another agent
    with pytest.raises(RailError, match="not the ones the result was imagined with"):
        render_contact_sheet(cup, r, tmp_path / "bad.png", profile=other, tile=tile)


def _sector_hulls(mesh: trimesh.Trimesh, config=None) -> tuple[np.ndarray, ...]:
    """A deterministic stand-in for CoACD (whose hulls change with the last bits of the input): the floor and
    twelve wall sectors of whatever mesh it gets, cut by its own box."""
    v = np.asarray(mesh.vertices)
    lo, hi = v.min(axis=0), v.max(axis=0)
    c = (lo + hi) / 2
    r = np.hypot(v[:, 0] - c[0], v[:, 1] - c[1])
    angle = np.degrees(np.arctan2(v[:, 1] - c[1], v[:, 0] - c[0])) % 360.0
    wall = r >= r.max() * (1 - WALL / R_TOP) * 0.99
    hulls = [v[v[:, 2] - lo[2] <= (hi[2] - lo[2]) * BASE / HEIGHT * 1.01]]
    for k in range(12):
        near = np.abs((angle - 30.0 * k - 15.0 + 180.0) % 360.0 - 180.0) <= 15.5  # the edges, both sides
        hulls.append(v[wall & near])
    return tuple(hulls)


def test_eval_report_draws_millimetre_y_up_meshes_like_metre_z_up(tmp_path, monkeypatch):
    """write_report reads each mesh with its label's units and up axis (it drew every mesh as metres, z up)."""
    import rail_mj.mesh.quality
    from rail_mj.eval import report, summary

    monkeypatch.setattr(rail_mj.mesh.quality, "decompose", _sector_hulls)

    root = tmp_path / "ds"
    root.mkdir()
    mesh = _cup_mesh()
    mesh.export(root / "m.obj")
    v = mesh.vertices  # the y-up file holds (x, z, -y): the loader turns its +y into +z
    trimesh.Trimesh(np.c_[v[:, 0], v[:, 2], -v[:, 1]] * 1000.0, mesh.faces).export(root / "mm.obj")
    records = [
        LabelRecord(mesh="m.obj", class_name="cup", affordances={"cup": True}, functional_up=(0, 0, 1)),
        LabelRecord(mesh="mm.obj", class_name="cup", affordances={"cup": True}, functional_up=(0, 1, 0),
                    units=0.001, up="y"),
    ]
    (root / "labels.jsonl").write_text("".join(json.dumps(r.model_dump(by_alias=True)) + "\n" for r in records))
    wrong = _result(functional=False, functional_pose=None, best_plan=None)  # misclassified: it gets a picture
    lines = [summary._line(rec, "cup", wrong.model_copy(update={"object": rec.mesh})) for rec in records]
    out = tmp_path / "out"
    out.mkdir()
    report.write_report(out, summary.summarize(lines), lines, root, render=True)
    metre, milli = _image(out / "renders" / "m.obj__cup.png"), _image(out / "renders" / "mm.obj__cup.png")
    h = 480  # the report's picture size; below it the captions differ (the object's name, its hull count)
    assert metre.shape[1] == milli.shape[1] and min(metre.shape[0], milli.shape[0]) > h
    differ = np.abs(metre[:h] - milli[:h]).max(axis=2) > 60
    assert differ.mean() < 0.03, f"{100 * differ.mean():.1f}% of the pixels differ"


def test_write_image_and_png_frames(tmp_path):
    rgb = np.zeros((9, 13, 3), dtype=np.uint8)
    rgb[..., 0] = 200
    assert np.array_equal(np.asarray(Image.open(write_image(tmp_path / "a.png", rgb))), rgb)
    folder = write_frames([rgb, rgb[::-1]], tmp_path / "frames")
    assert sorted(p.name for p in folder.iterdir()) == ["frame_00000.png", "frame_00001.png"]


def test_write_frames_mp4_decodes(tmp_path):
    import imageio.v2 as imageio

    frames = [np.full((49, 65, 3), 20 * i, dtype=np.uint8) for i in range(6)]  # odd sides are cropped
    path = write_frames(frames, tmp_path / "clip.mp4", fps=10)
    with imageio.get_reader(path) as reader:
        decoded = np.stack([frame for frame in reader])  # list(reader) asks its length, unknown for a stream
    assert decoded.shape == (6, 48, 64, 3)
    assert abs(float(decoded[-1].mean()) - 100.0) < 6  # the last frame's grey survives the encoding


def test_cli_says_plainly_when_nothing_can_be_drawn(tmp_path, capsys):
    from rail_mj.__main__ import main as cli

    _cup_mesh().export(tmp_path / "cup.obj")
    png, sheet = tmp_path / "out.png", tmp_path / "sheet.png"
    assert cli([str(tmp_path / "cup.obj"), "-a", "chair", "--provider", "offline", "--backend", "native",
                "--render", str(png), "--contact-sheet", str(sheet)]) == 0
    err = capsys.readouterr().err
    assert "nothing to draw" in err and "dimension check failed" in err and "error" not in err
    assert not png.exists() and not sheet.exists()


def test_cli_refuses_a_picture_format_before_any_work(tmp_path, capsys):
    from rail_mj.__main__ import main as cli

    with pytest.raises(SystemExit) as exit_:
        cli([str(tmp_path / "cup.obj"), "-a", "cup", "--render", str(tmp_path / "out.gif")])
    assert exit_.value.code == 2 and ".png or .jpg" in capsys.readouterr().err
