"""Static allow-list check of generated scoring source (the first barrier; the sandbox is the second).

Allowed: one top-level ``def score(<SCORING_ARGS>)`` (an optional module
docstring before it), arithmetic, comparisons, boolean logic, ``if``/``for``/
``while``, assignments (augmented, tuple unpacking, walrus), subscripts and
slices, list/tuple/dict/set literals, comprehensions and generator
expressions, ``assert``, calls to ``np.<allow-listed>`` and to safe builtins,
and the attribute names in :data:`rail_mj.scoring.sandbox.OBJECT_ATTRIBUTES`.

Nested helper functions (``def`` inside ``score``) are allowed: they are
checked by the same rules, cannot carry decorators, and their recursion is
bounded by the interpreter's recursion limit in the worker. Type annotations
are accepted and stripped (never evaluated).

Rejected, with the line: imports, ``lambda``, classes, ``global``/
``nonlocal``, ``with``, ``try``, ``raise``, ``del``, ``yield``/``await``/
async, ``match``, f-strings, bytes literals, strings containing ``__``,
any name or attribute starting with ``_``, attribute assignment, ``**``
unpacking in calls, the bare name ``np``, attributes outside the allow-lists
and the names exec, eval, compile, open, getattr, … (see :data:`DENIED_NAMES`).
"""

from __future__ import annotations

import ast

from rail_mj.core.errors import UnsafeCodeError
from rail_mj.core.types import SCORING_ARGS
from rail_mj.scoring.sandbox import (
    LINALG_FUNCTIONS,
    NUMPY_CONSTANTS,
    NUMPY_FUNCTIONS,
    OBJECT_ATTRIBUTES,
    SAFE_BUILTINS,
)

__all__ = [
    "MAX_SOURCE_CHARS",
    "MAX_AST_NODES",
    "DENIED_NAMES",
    "RejectedCodeError",
    "check_source",
    "scoring_rules",
]

MAX_SOURCE_CHARS = 20_000
MAX_AST_NODES = 5_000

#: Names refused outright (most are absent from the sandbox anyway; refusing
#: them statically gives a clear message instead of a NameError at run time).
DENIED_NAMES: frozenset[str] = frozenset(
    {
        "exec", "eval", "compile", "open", "getattr", "setattr", "delattr", "hasattr",
        "globals", "locals", "vars", "dir", "type", "object", "breakpoint", "input", "print",
        "help", "memoryview", "bytearray", "bytes", "super", "classmethod", "staticmethod",
        "property", "exit", "quit", "id", "iter", "next", "callable", "format", "chr", "ord",
        "os", "sys", "subprocess", "importlib", "builtins", "numpy", "ctypes", "io", "pickle",
        "socket", "shutil", "pathlib",
    }
)

_ALLOWED = (
    "arithmetic, comparisons, boolean logic, if/for/while, assignments, subscripts/slices, "
    "list/tuple/dict/set literals, comprehensions, nested def, and calls to np.<allow-listed> "
    "functions and safe builtins"
)

_STATEMENTS = (
    ast.FunctionDef, ast.Return, ast.Assign, ast.AugAssign, ast.For, ast.While, ast.If,
    ast.Expr, ast.Pass, ast.Break, ast.Continue, ast.Assert,
)
_EXPRESSIONS = (
    ast.BoolOp, ast.NamedExpr, ast.BinOp, ast.UnaryOp, ast.IfExp, ast.Dict, ast.Set,
    ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp, ast.Compare, ast.Call,
    ast.Constant, ast.Attribute, ast.Subscript, ast.Starred, ast.Name, ast.List, ast.Tuple,
    ast.Slice,
)
_OTHERS = (
    ast.Module, ast.Load, ast.Store, ast.comprehension, ast.arguments, ast.arg, ast.keyword,
    ast.boolop, ast.operator, ast.unaryop, ast.cmpop,
)
_ALLOWED_NODES = _STATEMENTS + _EXPRESSIONS + _OTHERS

#: What a refused node type is called in messages.
_CONSTRUCT_NAMES: dict[type, str] = {
    ast.Import: "import statement (np is already provided)",
    ast.ImportFrom: "from-import statement (np is already provided)",
    ast.Lambda: "lambda (use a nested def)",
    ast.ClassDef: "class definition",
    ast.AsyncFunctionDef: "async function",
    ast.Global: "global statement",
    ast.Nonlocal: "nonlocal statement",
    ast.With: "with statement",
    ast.AsyncWith: "async with statement",
    ast.AsyncFor: "async for loop",
    ast.Try: "try statement",
    ast.TryStar: "try/except* statement",
    ast.Raise: "raise statement",
    ast.Delete: "del statement",
    ast.Yield: "yield",
    ast.YieldFrom: "yield from",
    ast.Await: "await",
    ast.Match: "match statement",
    ast.JoinedStr: "f-string",
    ast.FormattedValue: "f-string",
    ast.Del: "del",
}


class RejectedCodeError(UnsafeCodeError):
    """Scoring source refused by the static check; ``line`` and ``construct`` say where and what."""

    def __init__(self, line: int | None, construct: str, detail: str = "") -> None:
        where = f"line {line}" if line is not None else "source"
        super().__init__(f"{where}: {construct} is not allowed{'; ' + detail if detail else ''}")
        self.line = line
        self.construct = construct


def _sorted(names: frozenset[str]) -> str:
    return ", ".join(sorted(names))


def scoring_rules() -> str:
    """The allow-list in words, for the scoring-function prompt and for error messages."""
    return (
        f"Write exactly one top-level function `def score({', '.join(SCORING_ARGS)}):` returning a float "
        "array of shape (B,) (success when > 0). No imports: `np` is provided. Allowed: "
        f"{_ALLOWED}. numpy: np.{{{_sorted(NUMPY_FUNCTIONS)}}}, constants np.{{{_sorted(NUMPY_CONSTANTS)}}}, "
        f"np.linalg.{{{_sorted(LINALG_FUNCTIONS)}}}. Builtins: {_sorted(SAFE_BUILTINS)}. "
        f"Attributes on arrays/lists/dicts: .{{{_sorted(OBJECT_ATTRIBUTES)}}}. "
        "Not allowed: names or attributes starting with '_', lambda, class, try/raise/with, global, "
        "del, yield, f-strings, assigning to attributes, **kwargs unpacking, file or system access."
    )


class _StripAnnotations(ast.NodeTransformer):
    """Drop type annotations so they are neither checked nor evaluated."""

    def visit_arg(self, node: ast.arg) -> ast.arg:
        node.annotation = None
        return node

    def visit_FunctionDef(self, node: ast.FunctionDef) -> ast.FunctionDef:
        node.returns = None
        self.generic_visit(node)
        return node

    def visit_AnnAssign(self, node: ast.AnnAssign) -> ast.stmt:
        if node.value is None:
            return ast.copy_location(ast.Pass(), node)
        assign = ast.Assign(targets=[node.target], value=node.value)
        return ast.copy_location(assign, node)


class _Checker:
    """Walks the tree (iteratively: deep nesting must not crash the checker) and refuses on sight."""

    def __init__(self, tree: ast.Module) -> None:
        self.parent: dict[ast.AST, ast.AST] = {}
        for node in ast.walk(tree):
            for child in ast.iter_child_nodes(node):
                self.parent[child] = node

    def run(self, tree: ast.Module) -> None:
        for node in ast.walk(tree):
            self.check(node)

    def refuse(self, node: ast.AST, construct: str, detail: str = "") -> None:
        line = getattr(node, "lineno", None)
        if line is None and node in self.parent:
            line = getattr(self.parent[node], "lineno", None)
        raise RejectedCodeError(line, construct, detail or f"allowed: {_ALLOWED}")

    def check(self, node: ast.AST) -> None:
        if not isinstance(node, _ALLOWED_NODES):
            name = _CONSTRUCT_NAMES.get(type(node), f"{type(node).__name__} node")
            self.refuse(node, name)
        if isinstance(node, ast.Name):
            self.check_name(node)
        elif isinstance(node, ast.Attribute):
            self.check_attribute(node)
        elif isinstance(node, ast.Constant):
            if isinstance(node.value, bytes):
                self.refuse(node, "bytes literal")
            if isinstance(node.value, str) and "__" in node.value:
                self.refuse(node, f"string constant containing '__' ({node.value[:40]!r})",
                            "dunder names are never needed in scoring code")
        elif isinstance(node, ast.FunctionDef):
            if node.decorator_list:
                self.refuse(node, f"decorator on function {node.name!r}")
            if node.name.startswith("_"):
                self.refuse(node, f"function name {node.name!r} starting with '_'")
        elif isinstance(node, ast.arg):
            if node.arg.startswith("_") or node.arg in DENIED_NAMES or node.arg == "np":
                self.refuse(node, f"parameter name {node.arg!r}")
        elif isinstance(node, ast.keyword):
            if node.arg is None:
                self.refuse(node, "**mapping unpacking in a call", "pass keyword arguments by name")
            elif node.arg.startswith("_"):
                self.refuse(node, f"keyword argument {node.arg!r} starting with '_'")
        elif isinstance(node, ast.comprehension) and node.is_async:
            self.refuse(node, "async comprehension")

    def check_name(self, node: ast.Name) -> None:
        if node.id.startswith("_"):
            self.refuse(node, f"name {node.id!r} (names starting with '_')")
        if node.id in DENIED_NAMES:
            self.refuse(node, f"name {node.id!r}", f"safe builtins are: {_sorted(SAFE_BUILTINS)}")
        if node.id == "np":
            parent = self.parent.get(node)
            if not isinstance(node.ctx, ast.Load):
                self.refuse(node, "assigning to 'np'")
            if not (isinstance(parent, ast.Attribute) and parent.value is node):
                self.refuse(node, "using 'np' other than as np.<function>",
                            "call allow-listed functions directly, e.g. np.sum(x)")

    def check_attribute(self, node: ast.Attribute) -> None:
        attr = node.attr
        if attr.startswith("_"):
            self.refuse(node, f"attribute {attr!r} (attributes starting with '_')")
        if not isinstance(node.ctx, ast.Load):
            self.refuse(node, f"assigning to attribute {attr!r}", "assign to a local name instead")
        base = node.value
        if isinstance(base, ast.Name) and base.id == "np":
            if attr == "linalg":
                parent = self.parent.get(node)
                if not (isinstance(parent, ast.Attribute) and parent.value is node):
                    self.refuse(node, "using 'np.linalg' other than as np.linalg.<function>")
            elif attr not in NUMPY_FUNCTIONS | NUMPY_CONSTANTS:
                self.refuse(node, f"np.{attr}", f"allowed numpy names: {_sorted(NUMPY_FUNCTIONS | NUMPY_CONSTANTS)}")
        elif isinstance(base, ast.Attribute) and base.attr == "linalg" and isinstance(base.value, ast.Name) \
                and base.value.id == "np":
            if attr not in LINALG_FUNCTIONS:
                self.refuse(node, f"np.linalg.{attr}", f"allowed: np.linalg.{{{_sorted(LINALG_FUNCTIONS)}}}")
        elif attr not in OBJECT_ATTRIBUTES:
            self.refuse(node, f"attribute .{attr}", f"allowed attributes: {_sorted(OBJECT_ATTRIBUTES)}")


def _check_signature(tree: ast.Module) -> None:
    body = list(tree.body)
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        body = body[1:]
    if len(body) != 1 or not isinstance(body[0], ast.FunctionDef) or body[0].name != "score":
        found = ", ".join(
            f"line {s.lineno}: {getattr(s, 'name', type(s).__name__)}" for s in body
        ) or "nothing"
        raise RejectedCodeError(
            body[0].lineno if body else None,
            "top-level code other than one `def score(...)`",
            f"found {found}; put constants and helpers inside score",
        )
    fn = body[0]
    a = fn.args
    names = [x.arg for x in a.args]
    if a.posonlyargs or a.vararg or a.kwonlyargs or a.kwarg or a.defaults or names != list(SCORING_ARGS):
        raise RejectedCodeError(
            fn.lineno,
            "this signature of score",
            f"the parameters must be exactly ({', '.join(SCORING_ARGS)}) in this order, without defaults, "
            "*args or **kwargs",
        )


def check_source(source: str) -> ast.Module:
    """Parse and allow-list ``source``; returns the tree (annotations stripped) ready to compile.

    Raises :class:`RejectedCodeError` (an ``UnsafeCodeError``) naming the line and the construct.
    """
    if not isinstance(source, str):
        raise UnsafeCodeError(f"scoring source must be a str, got {type(source).__name__}")
    if len(source) > MAX_SOURCE_CHARS:
        raise RejectedCodeError(None, f"source of {len(source)} characters",
                                f"the limit is {MAX_SOURCE_CHARS} characters")
    try:
        tree = ast.parse(source, filename="<scoring>", mode="exec")
    except SyntaxError as exc:
        raise RejectedCodeError(exc.lineno, "invalid syntax", f"{exc.msg}") from None
    except (ValueError, RecursionError, MemoryError) as exc:
        raise RejectedCodeError(None, "unparsable source", f"{type(exc).__name__}: {exc}") from None
    n_nodes = sum(1 for _ in ast.walk(tree))
    if n_nodes > MAX_AST_NODES:
        raise RejectedCodeError(None, f"a syntax tree of {n_nodes} nodes", f"the limit is {MAX_AST_NODES} nodes")
    try:
        tree = ast.fix_missing_locations(_StripAnnotations().visit(tree))
    except RecursionError:
        raise RejectedCodeError(None, "nesting this deep", "flatten the expressions") from None
    _Checker(tree).run(tree)
    _check_signature(tree)
    return tree
