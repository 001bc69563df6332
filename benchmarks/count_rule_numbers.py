"""Count the hand-set numbers in the affordance rules (``rail_mj/affordances/``), issue 22's rules discipline.

Counting rule (one number = one hand-set choice):

* every int/float literal in the code (an AST ``Constant``; a bool is no number), wherever it stands: a
  size range in a registry row, a threshold in a kind, a default of a parameter model;
* and every number written inside a string that is code, not words: the numpy scoring templates the
  kinds format (a string constant holding ``np.``) and the expressions handed to them (``"... - 0.005"``);
* except 0, 1, -1 and 2, which stand for structure (an index, a half, a sign, "none", "all"), the numbers
  inside a subscript (a slice of a word, ``key[:-3]``) and the digits ``round`` keeps, and except the
  numbers of docstrings, comments and messages (they repeat a number counted where it is set).

``--list`` prints each counted number with its file and line, so a count can be checked by hand.

    python benchmarks/count_rule_numbers.py [--list] [DIR]
"""

from __future__ import annotations

import argparse
import ast
import re
import sys
from pathlib import Path

#: Literals that stand for structure, not a hand-set quantity.
STRUCTURE = {0, 1, -1, 2}
_CODE_NUMBER = re.compile(r"(?<![\w.\[:])(\d+\.\d*|\.\d+|\d+)(?![\w.])")


def _is_code(text: str) -> bool:
    """A string that is code: a scoring template, or an expression over the pose's half extents."""
    return "np." in text or "h[:, :, 2]" in text


def _docstrings(tree: ast.AST) -> set[int]:
    ids = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                ids.add(id(first.value))
    return ids


def _structural(tree: ast.AST) -> set[int]:
    """The constants that index or slice, and ``round``'s digits."""
    ids = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Subscript):
            ids.update(id(n) for n in ast.walk(node.slice) if isinstance(n, ast.Constant))
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "round"
              and len(node.args) == 2):
            ids.update(id(n) for n in ast.walk(node.args[1]) if isinstance(n, ast.Constant))
    return ids


def count_file(path: Path) -> list[tuple[int, str]]:
    """(line, number as written) of each hand-set number in one Python file."""
    tree = ast.parse(path.read_text(), str(path))
    docs = _docstrings(tree) | _structural(tree)
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Constant) or id(node) in docs:
            continue
        v = node.value
        if isinstance(v, bool):
            continue
        if isinstance(v, (int, float)):
            if v not in STRUCTURE:
                found.append((node.lineno, repr(v)))
        elif isinstance(v, str) and _is_code(v):
            for m in _CODE_NUMBER.finditer(v):
                if float(m.group(1)) not in STRUCTURE:
                    found.append((node.lineno, m.group(1)))
    return sorted(found)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("root", nargs="?", default=str(Path(__file__).resolve().parents[1] / "rail_mj" / "affordances"))
    parser.add_argument("--list", action="store_true", help="print every counted number")
    args = parser.parse_args(argv)
    root = Path(args.root)
    total = 0
    for path in sorted(root.rglob("*.py")):
        found = count_file(path)
        total += len(found)
        print(f"{len(found):4d}  {path.relative_to(root.parent)}")
        if args.list:
            for line, text in found:
                print(f"        {line:4d}: {text}")
    print(f"{total:4d}  hand-set numbers in {root}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
