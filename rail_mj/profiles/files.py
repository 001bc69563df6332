"""The files of a paper-format profile folder, read and checked one by one, and written.

Each reader raises :class:`~rail_mj.core.errors.ProfileFolderError` naming the file and what was wrong;
each writer gives the text that its reader reads back. Positions are metres.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rail_mj.core.errors import ProfileFolderError
from rail_mj.llm.schemas import AffordanceAnalysis

__all__ = [
    "ANALYSIS", "AGENT", "ARRANGEMENT", "PLAN", "AGENTS_TRAJ", "EVALUATION", "SCORING", "SIDECAR", "PAPER_FILES",
    "MIN_PLANS", "MAX_PLANS", "MIN_POINTS", "MAX_POINTS",
    "PaperAnalysis", "read_text", "read_analysis", "analysis_text", "read_arrangement", "arrangement_text",
    "read_plans", "plans_text", "read_agents_traj", "agents_traj_text", "normalize",
]

ANALYSIS = "analysis.txt"
AGENT = "agent.urdf"
ARRANGEMENT = "arrangement.json"
PLAN = "plan.json"
AGENTS_TRAJ = "agents_traj.json"
EVALUATION = "evaluation.py"
#: rail_mj's own additions: its vectorised scoring code, and what the paper's files cannot carry exactly.
SCORING = "scoring.py"
SIDECAR = "rail_mj.json"
PAPER_FILES = (ANALYSIS, AGENT, ARRANGEMENT, PLAN, AGENTS_TRAJ, EVALUATION)

#: A profile's plans (stage 4's answer: at least five directions, at most sixteen) and via-points per plan.
MIN_PLANS, MAX_PLANS = 5, 16
MIN_POINTS, MAX_POINTS = 2, 8
_MAX_FILE_BYTES = 1 << 20  # a profile file is a few KB; refuse to read anything absurd
_START, _END = "<start of analysis>", "<end of analysis>"
#: analysis.txt's labelled lines that rail_mj reads (besides the two the format requires) and writes.
_LABELS = {"dimensions fit": "fits", "reason": "reason", "alternative": "alternative",
           "interaction-based definition": "ibd", "agent": "agent_description",
           "interaction": "interaction_description", "expected outcome": "expected_outcome"}


def normalize(name: str) -> str:
    """An affordance or folder name compared loosely: lower case, '_' and '-' as spaces, spaces collapsed."""
    return " ".join(re.sub(r"[_\-]+", " ", name).lower().split())


def read_text(path: Path) -> str:
    try:
        size = path.stat().st_size
        if size > _MAX_FILE_BYTES:
            raise ProfileFolderError(f"{path}: {size} bytes, more than {_MAX_FILE_BYTES}; a profile file is small")
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProfileFolderError(f"{path}: cannot be read ({exc})") from None


def _json(path: Path) -> Any:
    def constant(name: str) -> float:
        raise ProfileFolderError(f"{path}: {name} is not a number; positions must be finite metres")
    try:
        return json.loads(read_text(path), parse_constant=constant)
    except json.JSONDecodeError as exc:
        raise ProfileFolderError(f"{path}: not valid JSON ({exc})") from None


@dataclass(frozen=True)
class PaperAnalysis:
    """analysis.txt: the text between the markers, its two required lines and any labelled lines rail_mj reads."""

    text: str
    object_class: str
    affordance: str
    fields: dict[str, str]


def read_analysis(path: Path) -> PaperAnalysis:
    raw = read_text(path)
    low = raw.lower()
    start, end = low.find(_START), low.find(_END)
    if start < 0 or end < start:
        raise ProfileFolderError(f"{path}: the analysis must stand between the lines <Start of analysis> and "
                                 "<End of analysis>")
    text = raw[start + len(_START):end].strip()
    found: dict[str, str] = {}
    for line in text.splitlines():
        label, sep, value = line.partition(":")
        if sep and value.strip():
            found.setdefault(label.strip().lower(), value.strip())
    missing = [n for n in ("class of object", "requested affordance") if n not in found]
    if missing:
        raise ProfileFolderError(f"{path}: no line {' or '.join(repr(m.capitalize() + ': ...') for m in missing)} "
                                 "in the analysis; both are required")
    fields = {key: found[label] for label, key in _LABELS.items() if label in found}
    if "fits" in fields and fields["fits"].lower() not in ("yes", "no"):
        raise ProfileFolderError(f"{path}: 'Dimensions fit: {fields['fits']}'; valid: yes, no")
    return PaperAnalysis(text=text, object_class=found["class of object"],
                         affordance=found["requested affordance"], fields=fields)


def analysis_text(analysis: AffordanceAnalysis, object_class: str) -> str:
    """analysis.txt for an analysis (each field on one labelled line)."""
    one = lambda s: " ".join(str(s).split())  # noqa: E731 - a field is one line
    lines = [f"Class of object: {one(object_class)}", f"Requested Affordance: {one(analysis.affordance)}",
             f"Dimensions fit: {'yes' if analysis.fits else 'no'}", f"Reason: {one(analysis.reason)}",
             f"Alternative: {one(analysis.alternative or 'none')}",
             f"Interaction-based definition: {one(analysis.ibd)}", f"Agent: {one(analysis.agent_description)}",
             f"Interaction: {one(analysis.interaction_description)}",
             f"Expected outcome: {one(analysis.expected_outcome)}"]
    return "<Start of analysis>\n" + "\n".join(lines) + "\n<End of analysis>\n"


def _point(path: Path, where: str, value: Any) -> list[float]:
    if not (isinstance(value, list) and len(value) == 3
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        raise ProfileFolderError(f"{path}: {where} must be [x, y, z], three numbers in metres; got {value!r}"[:400])
    if not all(math.isfinite(v) for v in value):
        raise ProfileFolderError(f"{path}: {where} is {value}; positions must be finite numbers (no NaN or inf)")
    return [float(v) for v in value]


def _numbered(path: Path, data: Any, prefix: str, example: str) -> list[tuple[str, Any]]:
    """The entries of ``{"prefix_1": ..., "prefix_2": ...}`` in numeric order."""
    if not isinstance(data, dict) or not data:
        raise ProfileFolderError(f"{path}: must be a JSON object like {example}; got {type(data).__name__}")
    bad = [k for k in data if not re.fullmatch(rf"{prefix}_\d+", k)]
    if bad:
        raise ProfileFolderError(f"{path}: key {bad[0]!r} is not {prefix}_<number>; e.g. {example}")
    return sorted(data.items(), key=lambda kv: int(kv[0].rsplit("_", 1)[1]))


def read_arrangement(path: Path) -> np.ndarray:
    """(N, 3) offsets of the agents from the group centre."""
    items = _numbered(path, _json(path), "agent", '{"agent_1": [x, y, z], "agent_2": [x, y, z]}')
    return np.array([_point(path, k, v) for k, v in items])


def arrangement_text(offsets: np.ndarray) -> str:
    return json.dumps({f"agent_{i + 1}": [float(v) for v in p] for i, p in enumerate(offsets)}, indent=1) + "\n"


def _plan_count(path: Path, n: int) -> None:
    if not MIN_PLANS <= n <= MAX_PLANS:
        raise ProfileFolderError(f"{path}: {n} plans; a profile has {MIN_PLANS} to {MAX_PLANS} (the paper's planner "
                                 "gives five, from different directions)")


def _points(path: Path, name: str, value: Any) -> np.ndarray:
    if not isinstance(value, list) or not MIN_POINTS <= len(value) <= MAX_POINTS:
        n = len(value) if isinstance(value, list) else type(value).__name__
        raise ProfileFolderError(f"{path}: {name} must be a list of {MIN_POINTS} to {MAX_POINTS} via-points "
                                 f"[x, y, z]; got {n}")
    return np.array([_point(path, f"{name} point {i + 1}", p) for i, p in enumerate(value)])


def read_plans(path: Path) -> dict[str, np.ndarray]:
    """Each plan's via-points (K, 3) of the group centre, relative to the object."""
    items = _numbered(path, _json(path), "plan", '{"plan_1": [[x, y, z], [x, y, z]], ...}')
    _plan_count(path, len(items))
    return {k: _points(path, k, v) for k, v in items}


def plans_text(plans: dict[str, np.ndarray]) -> str:
    return json.dumps({k: [[float(v) for v in p] for p in pts] for k, pts in plans.items()}, indent=1) + "\n"


def read_agents_traj(path: Path) -> dict[str, np.ndarray]:
    """Each plan's via-points per agent, (N, K, 3)."""
    items = _numbered(path, _json(path), "plan", '{"plan_1": [[[x, y, z], ...] for each agent], ...}')
    _plan_count(path, len(items))
    out = {}
    for k, agents in items:
        if not isinstance(agents, list) or not agents:
            raise ProfileFolderError(f"{path}: {k} must be a list with one list of via-points per agent")
        paths = [_points(path, f"{k} agent {i + 1}", a) for i, a in enumerate(agents)]
        if len({len(p) for p in paths}) != 1:
            raise ProfileFolderError(f"{path}: {k}: the agents have {[len(p) for p in paths]} via-points; every "
                                     "agent needs as many")
        out[k] = np.stack(paths)
    if len({a.shape[0] for a in out.values()}) != 1:
        raise ProfileFolderError(f"{path}: the plans move {[a.shape[0] for a in out.values()]} agents; every plan "
                                 "moves the same agents")
    return out


def agents_traj_text(trajs: dict[str, np.ndarray]) -> str:
    return json.dumps({k: [[[float(v) for v in p] for p in agent] for agent in a] for k, a in trajs.items()},
                      indent=1) + "\n"
