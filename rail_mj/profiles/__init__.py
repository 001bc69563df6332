"""Profile folders in the paper authors' format: imported as imagination profiles, and written.

One folder per affordance holds ``analysis.txt`` (between ``<Start of analysis>`` and ``<End of analysis>``,
with ``Class of object: ...`` and ``Requested Affordance: ...`` lines), ``agent.urdf`` (links of box, sphere or
cylinder shapes), ``arrangement.json`` (``{"agent_1": [x, y, z], ...}``, offsets from the group centre, m),
``plan.json`` (``{"plan_1": [[x, y, z], ...], ...}``, the group centre's via-points, m) and/or
``agents_traj.json`` (``{"plan_1": [[[x, y, z], ...] for each agent], ...}``), and sometimes ``evaluation.py``
(``is_successful(...)`` for one rollout, run in the scoring sandbox). :func:`import_profile` reads one,
:func:`save_profile` writes one, :func:`find_folder` picks a folder of a DIR for an affordance.
"""

from __future__ import annotations

from rail_mj.profiles.evaluation import PAPER_ARGS, evaluation_source
from rail_mj.profiles.folder import AGREE_M, ORIGIN_LIFT, Origin, import_profile, save_profile
from rail_mj.profiles.source import (
    PROFILE_DIR_ENV,
    check_profile_dir,
    default_profile_dir,
    find_folder,
    folder_task,
    is_profile_folder,
)
from rail_mj.urdf.agent import fragment_to_urdf, urdf_to_fragment

__all__ = [
    "AGREE_M",
    "ORIGIN_LIFT",
    "Origin",
    "PAPER_ARGS",
    "PROFILE_DIR_ENV",
    "check_profile_dir",
    "default_profile_dir",
    "evaluation_source",
    "find_folder",
    "folder_task",
    "fragment_to_urdf",
    "import_profile",
    "is_profile_folder",
    "save_profile",
    "urdf_to_fragment",
]
