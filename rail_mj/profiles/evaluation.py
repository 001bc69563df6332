"""A paper-format ``evaluation.py`` as scoring code: its ``is_successful`` called once per rollout in the sandbox.

The file's code goes, indented, inside a generated ``def score(...)`` followed by an adapter that builds
``is_successful``'s arguments from the batched outcome arrays, rollout by rollout; the whole is checked by
the scoring sandbox's allow-list (:mod:`rail_mj.scoring.validate`) and runs there under its time and memory
limits, like any generated scoring code. ``import numpy as np`` is accepted (``np`` is provided there); any
other import is refused.

``is_successful(agent_pos_list, agent_rotm_list, agent_obj_contact_number_list, agent_ground_contact_list,
obj_center, obj_bbox) -> (score, judgement, successful_agents)`` gets, for one rollout, each agent's position
(array (3,)) and rotation matrix (array (3, 3)), its number of contact points with the object and whether it
touches the ground, the centre of the object's box and its full size (arrays (3,)), in the object's frame with
the chosen origin (:data:`rail_mj.profiles.folder.Origin`). The rollout's score is ``1 + score`` when
``judgement`` is true and ``-1 / (1 + score)`` when it is false (score clipped at 0): success when > 0, and
higher for a higher ``score`` either way.
"""

from __future__ import annotations

import ast
import re

from rail_mj.core.errors import ProfileFolderError, ScoringRuntimeError, UnsafeCodeError
from rail_mj.core.profile import ScoringCode
from rail_mj.core.types import SCORING_ARGS
from rail_mj.scoring import compile_scoring, probe_outcomes

__all__ = ["PAPER_ARGS", "evaluation_source", "evaluation_scoring", "probe_scoring"]

#: The parameters of the paper's ``is_successful``, in order.
PAPER_ARGS = ("agent_pos_list", "agent_rotm_list", "agent_obj_contact_number_list", "agent_ground_contact_list",
              "obj_center", "obj_bbox")

# Names start with rail_ so that they do not meet the file's own (which become locals of score too).
_ADAPTER = '''
rail_scores = []
for rail_b in range(agent_pos.shape[0]):
    rail_h = object_half_extents[rail_b]
    rail_centre = np.array([0.0, 0.0, {lift} * rail_h[2]])
    rail_q = agent_quat[rail_b]
    rail_w, rail_x, rail_y, rail_z = rail_q[:, 0], rail_q[:, 1], rail_q[:, 2], rail_q[:, 3]
    rail_rotm = np.stack([
        np.stack([1 - 2 * (rail_y * rail_y + rail_z * rail_z), 2 * (rail_x * rail_y - rail_z * rail_w),
                  2 * (rail_x * rail_z + rail_y * rail_w)], axis=-1),
        np.stack([2 * (rail_x * rail_y + rail_z * rail_w), 1 - 2 * (rail_x * rail_x + rail_z * rail_z),
                  2 * (rail_y * rail_z - rail_x * rail_w)], axis=-1),
        np.stack([2 * (rail_x * rail_z - rail_y * rail_w), 2 * (rail_y * rail_z + rail_x * rail_w),
                  1 - 2 * (rail_x * rail_x + rail_y * rail_y)], axis=-1)], axis=1)
    rail_out = is_successful([rail_p + rail_centre for rail_p in agent_pos[rail_b]], [m for m in rail_rotm],
                             [int(c) for c in contacts_object[rail_b]], [bool(c > 0) for c in contacts_ground[rail_b]],
                             rail_centre.copy(), 2.0 * rail_h)
    assert isinstance(rail_out, (tuple, list)) and len(rail_out) == 3, (
        "is_successful must return (score, judgement, successful_agents); it returned something else")
    rail_score = max(float(rail_out[0]), 0.0)
    assert rail_score == rail_score, "is_successful returned a NaN score"
    rail_scores.append(1.0 + rail_score if bool(rail_out[1]) else -1.0 / (1.0 + rail_score))
return np.array(rail_scores)
'''


def _indent(source: str) -> str:
    lines = source.splitlines()
    unit = "\t" if any(line.startswith("\t") for line in lines) else "    "
    return "\n".join(unit + line if line.strip() else line for line in lines)


def _accepted_import(node: ast.stmt) -> bool:
    return isinstance(node, ast.Import) and [(a.name, a.asname) for a in node.names] in ([("numpy", "np")],)


def evaluation_source(source: str, where: str, *, lift: float) -> str:
    """The scoring source wrapping ``source`` (an evaluation.py); ``lift`` is 1 when positions are measured from
    the ground under the box centre, 0 from the box centre. ProfileFolderError naming ``where`` and the line."""
    try:
        tree = ast.parse(source)
    except SyntaxError as exc:
        raise ProfileFolderError(f"{where}: line {exc.lineno}: invalid syntax ({exc.msg})") from None
    lines = source.splitlines()
    for node in tree.body:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            if not _accepted_import(node):
                names = ", ".join(a.name for a in node.names)
                raise ProfileFolderError(f"{where}: line {node.lineno}: import of {names} is not allowed; scoring "
                                         "code gets numpy as np and nothing else (`import numpy as np` may stay)")
            others = [n for n in tree.body if n is not node and n.lineno <= node.end_lineno  # type: ignore[operator]
                      and (n.end_lineno or n.lineno) >= node.lineno]
            if others:
                raise ProfileFolderError(f"{where}: line {node.lineno}: put `import numpy as np` on a line of its own")
            for i in range(node.lineno - 1, node.end_lineno or node.lineno):
                lines[i] = "pass" if i == node.lineno - 1 else ""
    defs = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "is_successful"]
    if not defs:
        raise ProfileFolderError(f"{where}: defines no top-level is_successful({', '.join(PAPER_ARGS)})")
    a = defs[-1].args
    if a.vararg is None and (a.posonlyargs or a.kwonlyargs or len(a.args) - len(a.defaults) > 6 or len(a.args) < 6):
        raise ProfileFolderError(f"{where}: line {defs[-1].lineno}: is_successful must take the six arguments "
                                 f"({', '.join(PAPER_ARGS)})")
    adapter = _ADAPTER.format(lift=float(lift))
    return f"def score({', '.join(SCORING_ARGS)}):\n" + _indent("\n".join(lines)) + "\n" + _indent(adapter) + "\n"


def _where_line(message: str, where: str, last: int, offset: int) -> str:
    """A message about a wrapped source with its line numbers turned into the file's (the wrapper adds
    ``offset`` lines before it); a line past ``last`` is the adapter's, and named so."""
    def line(match: re.Match) -> str:
        n = int(match.group(2))
        return f"{match.group(1)}{n - offset}" if offset < n <= last else "in the adapter that calls is_successful,"
    return f"{where}: " + re.sub(r"((?:^|at )line )(\d+)", line, message)


def probe_scoring(source: str, where: str, *, n_agents: int, n_plans: int, half_extents: list[list[float]],
                  offset: int = 0, last: int | None = None) -> None:
    """Check ``source`` (a ``score`` function) and run it once on a synthetic batch of ``n_agents`` agents and
    ``n_plans`` plans over ``half_extents`` (one row per pose), so that code which loops forever, allocates
    without bound or returns the wrong shape is refused now; ProfileFolderError naming ``where`` and its line
    (the source's line less ``offset``; lines past ``last`` are an adapter's)."""
    try:
        score = compile_scoring(source)
        score(probe_outcomes(n_agents, n_plans, half_extents))
    except (UnsafeCodeError, ScoringRuntimeError) as exc:
        last = source.count("\n") + 1 if last is None else last
        raise ProfileFolderError(_where_line(str(exc), where, last, offset)) from None


def evaluation_scoring(source: str, where: str, *, lift: float, n_agents: int, n_plans: int,
                       half_extents: list[list[float]]) -> ScoringCode:
    """``source`` (an evaluation.py) as checked scoring code, probed as :func:`probe_scoring` does."""
    wrapped = evaluation_source(source, where, lift=lift)
    probe_scoring(wrapped, where, n_agents=n_agents, n_plans=n_plans, half_extents=half_extents, offset=1,
                  last=len(source.splitlines()) + 1)
    return ScoringCode(description=f"is_successful of {where}, called once per rollout", source=wrapped)
