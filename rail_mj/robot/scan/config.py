"""What a scan is asked for and what it needs: ScanConfig, ScanError, and the optional open3d extra."""

from __future__ import annotations

import math
import sys
from types import ModuleType
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from rail_mj.core.errors import RobotError
from rail_mj.robot.control import RobotConfig

__all__ = [
    "INSTALL_HINT",
    "ScanError",
    "ScanConfig",
    "load_open3d",
]

INSTALL_HINT = "pip install -e '.[scan]'  (installs open3d-cpu)"


class ScanError(RobotError):
    """A scan could not be made: open3d missing, too few reachable views, or nothing seen."""


class ScanConfig(BaseModel):
    """How the wrist-camera scan is made and fused (SI units, angles in degrees)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    n_views: int = Field(default=12, ge=1, le=64, description="planned camera poses")
    min_views: int = Field(default=6, ge=1, description="fewest reachable views a scan needs")
    width: int = Field(default=320, ge=16, le=2048, description="depth image width, px")
    height: int = Field(default=240, ge=16, le=2048, description="depth image height, px")
    fovy: float = Field(default=58.0, gt=5, lt=150, description="vertical field of view (a RealSense D435's depth: 58)")
    distance: float = Field(default=0.33, gt=0.05, le=1.5, description="camera to look-at target, m")
    elevations: tuple[float, ...] = Field(default=(35.0, 60.0), min_length=1,
                                          description="view elevations above the table, cycled over the views")
    top_view: bool = Field(default=True, description="after the planned views, one more straight down onto the top of "
                           "what they fused: the only view that sees the bottom of a deep, narrow cavity")
    elevation_step: float = Field(default=10.0, ge=0,
                                  description="fallback: how much steeper to try an unreachable view")
    fallback_distance: float = Field(default=0.8, gt=0.3, le=1.0,
                                     description="fallback: the closer distance tried last, × distance")
    arm_clearance: float = Field(default=0.01, ge=0, description="closest the arm may come to the object at a view, m")
    target_height: float = Field(default=0.07, ge=0, description="look-at target above the table top, m")
    workspace_half: tuple[float, float, float] = Field(
        default=(0.2, 0.2, 0.35), description="the fused region: half x, half y and height above the table, m")
    depth_min: float = Field(default=0.07, gt=0, description="the sensor's nearest valid depth, m")
    depth_max: float = Field(default=1.2, gt=0, description="farthest depth fused, m")
    voxel_size: float = Field(default=0.0025, ge=0.0005, le=0.02, description="TSDF voxel edge, m")
    sdf_trunc: float = Field(default=4.0, ge=1.0, le=10.0, description="TSDF truncation, in voxels")
    min_observations: int = Field(default=1, ge=1,
                                  description="fewest views that must have fused a voxel of the surface")
    depth_noise: float = Field(default=0.0, ge=0, le=0.05,
                               description="Gaussian depth noise, standard deviation per metre of depth")
    dropout: float = Field(default=0.0, ge=0, lt=1, description="fraction of valid pixels lost at random")
    edge_dropout: float = Field(default=0.0, ge=0, le=1,
                                description="chance a pixel next to a depth discontinuity is lost")
    edge_jump: float = Field(default=0.01, gt=0, description="depth step between neighbours counted as an edge, m")
    plane_distance: float = Field(default=0.004, gt=0, description="RANSAC inlier distance for the table plane, m")
    cluster_eps: float = Field(default=0.01, gt=0, description="DBSCAN neighbourhood radius, m")
    carve: bool = Field(default=True, description="remove surface a view saw through (the TSDF's fattened edges)")
    close_bottom: bool = Field(default=True, description="cap the open outline where the object meets the table")
    watertight: bool = Field(default=True, description="close every other hole and make the mesh a closed manifold "
                             "(manifold3d), simplified within simplify_tolerance")
    simplify_tolerance: float = Field(default=0.3, ge=0, le=2.0,
                                      description="surface the simplification may move, in voxels; it grows "
                                      "(up to 2 voxels) only while the mesh has over max_faces faces")
    max_faces: int = Field(default=5_000, ge=500, le=20_000, description="most faces of the watertight mesh")
    closing: Literal["auto", "volume", "fans"] = Field(
        default="auto", description="how the watertight step closes the scan: 'fans' fans the fused mesh's holes and "
        "repairs it (may stay open); 'volume' meshes the space no view saw through (always closed, but unseen "
        "space - a deep cavity's bottom, under a table top - comes out solid); 'auto': fans, else volume")
    solid_voxel: float = Field(default=1.0, ge=0.25, le=1.0, description="the volume closing's grid step, × voxel_size")
    solid_max_points: int = Field(default=600_000, ge=10_000, description="the volume closing's grid has at most this "
                                  "many points: past it the step grows. Marching cubes' faces grow with the grid, "
                                  "and their quadric decimation (Open3D, which holds the GIL) took 5 of the 0.35 m "
                                  "trash bin's 10 s at 0.9M points")
    solid_offset: float = Field(default=0.0, ge=0.0, le=1.0,
                                description="how far the volume closing's surface lies outside the free space, "
                                "in grid steps")
    chamfer_points: int = Field(default=20000, ge=100,
                                description="points sampled on each mesh for the Chamfer distance")
    seed: int = 0
    robot: RobotConfig = Field(default_factory=RobotConfig, description="table and object placement")

    @model_validator(mode="after")
    def _check(self) -> "ScanConfig":
        if self.min_views > self.n_views:
            raise ValueError(f"min_views ({self.min_views}) must be at most n_views ({self.n_views})")
        if self.depth_min >= self.depth_max:
            raise ValueError(f"depth_min ({self.depth_min}) must be below depth_max ({self.depth_max})")
        if any(not 5.0 <= e <= 90.0 for e in self.elevations):
            raise ValueError(f"elevations must lie in [5, 90] degrees, got {self.elevations}")
        return self

    @property
    def fovx(self) -> float:
        """Horizontal field of view, degrees (square pixels)."""
        return math.degrees(2 * math.atan(math.tan(math.radians(self.fovy) / 2) * self.width / self.height))

    def intrinsics(self) -> tuple[float, float, float, float]:
        """Pinhole (fx, fy, cx, cy) of the rendered images, px."""
        f = self.height / 2 / math.tan(math.radians(self.fovy) / 2)
        return f, f, (self.width - 1) / 2, (self.height - 1) / 2


def _preload_libusb() -> bool:
    """Load the libusb that the ``libusb-package`` wheel ships; whether there was one to load.

    open3d-cpu's library links ``libusb-1.0.so.0`` (for RealSense cameras), which a bare machine lacks; once a
    library with that soname is loaded, the dynamic loader uses it for open3d too, so no system package is needed.
    """
    import ctypes  # noqa: PLC0415

    try:
        import libusb_package  # noqa: PLC0415 - part of the [scan] extra
    except ImportError:
        return False
    path = libusb_package.get_library_path()
    if path is None:
        return False
    ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)
    return True


def load_open3d() -> ModuleType:
    """The open3d module, or :class:`ScanError` naming the extra to install."""
    try:
        import open3d  # noqa: PLC0415 - an optional extra, imported only when a scan runs
    except (ImportError, OSError) as first:
        if "libusb" not in str(first) or not _preload_libusb():
            raise ScanError(f"the scan needs open3d, an optional extra: {INSTALL_HINT} ({first})") from first
        for name in [m for m in sys.modules if m == "open3d" or m.startswith("open3d.")]:
            del sys.modules[name]  # the failed import left half-initialised modules behind
        try:
            import open3d  # noqa: PLC0415
        except (ImportError, OSError) as exc:
            raise ScanError(f"the scan needs open3d, an optional extra: {INSTALL_HINT} ({exc})") from exc
    return open3d
