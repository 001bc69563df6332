"""Which profile folder, if any, serves a requested affordance: DIR itself, or DIR's sub-folder of that name."""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

import rail_mj.profiles.files as F
from rail_mj.core.errors import ConfigError, ProfileFolderError, UnknownAffordanceError
from rail_mj.llm.providers import Provider
from rail_mj.llm.schemas import TaskDescription
from rail_mj.llm.stages import task_description

__all__ = ["PROFILE_DIR_ENV", "default_profile_dir", "check_profile_dir", "is_profile_folder", "find_folder",
           "folder_task"]

#: The environment variable that gives runs their default profile folder (the robot command sets it, so that
#: every classification it makes, in any worker, reads the folder).
PROFILE_DIR_ENV = "RAIL_MJ_PROFILE_DIR"


def default_profile_dir() -> Path | None:
    value = os.environ.get(PROFILE_DIR_ENV, "").strip()
    return Path(value) if value else None


def is_profile_folder(path: Path) -> bool:
    """Whether ``path`` holds a profile's files itself (not sub-folders of them)."""
    return any((path / name).is_file() for name in (*F.PAPER_FILES, F.SCORING))


def check_profile_dir(path: Path) -> Path:
    """``path`` made absolute, once it is a profile folder or a folder of them (ConfigError otherwise)."""
    path = Path(path).expanduser().resolve()
    if not path.is_dir():
        raise ConfigError(f"profile_dir {path} is not a folder; give a profile folder (analysis.txt, agent.urdf, "
                          "arrangement.json, plan.json, ...) or a folder of them named by affordance")
    if not is_profile_folder(path) and not any(is_profile_folder(p) for p in path.iterdir() if p.is_dir()):
        raise ConfigError(f"profile_dir {path} holds no profile folder: no {', '.join(F.PAPER_FILES)} in it or in "
                          "a sub-folder of it")
    return path


def _names_of(folder: Path) -> set[str]:
    """The names a folder answers to: its own, and its analysis's affordance and object class when readable (a
    broken analysis.txt is reported when that folder is used, never while another affordance looks for its)."""
    names = {F.normalize(folder.name)}
    if (folder / F.ANALYSIS).is_file():
        try:
            paper = F.read_analysis(folder / F.ANALYSIS)
            names |= {F.normalize(paper.affordance), F.normalize(paper.object_class)}
        except ProfileFolderError:
            pass
    return names


def find_folder(profile_dir: Path, names: Iterable[str]) -> Path | None:
    """The folder for an affordance known by ``names`` (as requested, canonical): ``profile_dir`` itself when it is
    one profile folder (for any name if it has no analysis.txt), else its sub-folder named for it (or whose
    analysis names it); None when there is none."""
    wanted = {F.normalize(n) for n in names if n}
    if is_profile_folder(profile_dir):
        if not (profile_dir / F.ANALYSIS).is_file() or _names_of(profile_dir) & wanted:
            return profile_dir
        return None
    subs = sorted(p for p in profile_dir.iterdir() if p.is_dir() and is_profile_folder(p))
    by_name = [p for p in subs if F.normalize(p.name) in wanted]
    if by_name:
        return by_name[0]
    return next((p for p in subs if _names_of(p) & wanted), None)


def folder_task(affordance: str, obb_dims: Sequence[float] | np.ndarray, provider: Provider, *,
                scale: float = 1.0) -> TaskDescription:
    """The task for an affordance served by a folder: the provider's name for it when it knows the name, else
    the name as given (a folder imagines a use no provider knows)."""
    try:
        return task_description(affordance, obb_dims, provider, scale=scale)
    except UnknownAffordanceError:
        dims = sorted((float(d) for d in np.asarray(obb_dims, dtype=float).ravel()), reverse=True)
        return TaskDescription(affordance=" ".join(affordance.split()), obb_dims=dims, scale=scale)
