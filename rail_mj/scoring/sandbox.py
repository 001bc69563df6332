"""The scoring worker: runs allow-listed scoring code over arrays in a locked-down process.

This file is executed as a script (``python -P -B sandbox.py ...``), in an
empty temporary working directory, by :mod:`rail_mj.scoring.pool`, so it
imports nothing but the standard library and numpy — never the ``rail_mj``
package, whose ``__init__`` may pull in JAX or MuJoCo. The parent imports it too, for the allow-lists below (one
source of truth for the AST check and the runtime namespace).

Protocol (one request at a time):

* parent → worker: a pickled ``dict`` (trusted direction) carrying the code
  object the parent compiled from the checked tree (marshal), the input
  arrays already written into the shared memory file at the offsets it lists;
* worker → parent: a JSON header (never pickle: the parent must not unpickle
  what the untrusted side produced), then, on success, the raw ``float64``
  scores.

Memory: the worker's resting address-space size is measured once, when it
starts. Every call's cap is that size plus the mapped inputs, ``memory_mb``
and the parent's ``slack_mb``, so what earlier calls left behind never raises
it. Garbage (cycles included) is collected after each call, the heap trimmed
if the worker still rests more than ``slack_mb`` above its size, and the
header reports the excess (``resting_mb``) so that the parent can retire a
worker that stays bloated.
"""

from __future__ import annotations

import builtins
import ctypes
import gc
import json
import marshal
import math
import mmap
import os
import pickle
import reprlib
import resource
import signal
import sys
import types
import warnings
from multiprocessing.connection import Connection

import numpy as np

__all__ = [
    "NUMPY_FUNCTIONS",
    "NUMPY_CONSTANTS",
    "LINALG_FUNCTIONS",
    "SAFE_BUILTINS",
    "OBJECT_ATTRIBUTES",
    "SOURCE_FILENAME",
    "make_globals",
    "settle_startup",
    "collect_garbage",
    "trim_heap",
    "main",
]

#: ``np.<name>`` callables available to scoring code (pure array maths, no I/O).
NUMPY_FUNCTIONS: frozenset[str] = frozenset(
    {
        "abs", "absolute", "all", "any", "allclose", "amax", "amin", "arange", "arccos",
        "arcsin", "arctan", "arctan2", "argmax", "argmin", "argsort", "around", "array",
        "asarray", "atleast_1d", "atleast_2d", "broadcast_to", "cbrt", "ceil", "clip",
        "column_stack", "concatenate", "cos", "cosh", "count_nonzero", "cross", "cumprod",
        "cumsum", "deg2rad", "degrees", "diag", "diff", "divide", "dot", "einsum", "empty",
        "empty_like", "equal", "exp", "expand_dims", "fabs", "floor", "fmax", "fmin", "full",
        "full_like", "greater", "greater_equal", "hypot", "isclose", "isfinite", "isinf",
        "isnan", "less", "less_equal", "linspace", "log", "log10", "log1p", "log2",
        "logical_and", "logical_not", "logical_or", "logical_xor", "matmul", "max",
        "maximum", "mean", "median", "min", "minimum", "mod", "multiply", "nan_to_num",
        "nanmax", "nanmean", "nanmin", "nansum", "negative", "nonzero", "not_equal", "ones",
        "ones_like", "outer", "percentile", "power", "prod", "ptp", "quantile", "rad2deg",
        "radians", "ravel", "reciprocal", "repeat", "reshape", "round", "sign", "sin",
        "sinh", "sort", "sqrt", "square", "squeeze", "stack", "std", "subtract", "sum",
        "swapaxes", "take", "take_along_axis", "tan", "tanh", "tile", "trace", "transpose",
        "tril", "triu", "unique", "var", "vstack", "hstack", "where", "zeros", "zeros_like",
        "float64", "float32", "int64", "int32", "bool_",
    }
)
#: ``np.<name>`` constants.
NUMPY_CONSTANTS: frozenset[str] = frozenset({"pi", "e", "inf", "nan", "newaxis"})
#: ``np.linalg.<name>`` callables.
LINALG_FUNCTIONS: frozenset[str] = frozenset({"norm", "det", "inv", "solve", "eigh", "svd"})
#: Builtins in the exec namespace; everything else (open, exec, getattr, type, …) is absent.
SAFE_BUILTINS: frozenset[str] = frozenset(
    {
        "abs", "all", "any", "bool", "divmod", "enumerate", "float", "int", "isinstance",
        "len", "list", "max", "min", "pow", "range", "reversed", "round", "sorted", "sum",
        "tuple", "zip", "dict", "set", "True", "False", "None",
    }
)
#: Attribute names allowed on any value other than ``np`` (arrays, lists, dicts).
#: Deliberately absent: ctypes, base, data, tofile, dump, dumps, view, flags,
#: setflags, format, tobytes, __anything__.
OBJECT_ATTRIBUTES: frozenset[str] = frozenset(
    {
        "shape", "ndim", "size", "T", "sum", "mean", "min", "max", "any", "all", "astype",
        "copy", "reshape", "ravel", "flatten", "clip", "std", "var", "prod", "argmax",
        "argmin", "argsort", "cumsum", "cumprod", "round", "transpose", "squeeze", "dot",
        "nonzero", "item", "tolist", "sort", "swapaxes", "append", "extend", "insert", "pop",
        "count", "index", "items", "keys", "values", "get",
    }
)
#: Code objects compiled from scoring source carry this file name (tracebacks → line).
SOURCE_FILENAME = "<scoring>"

_PROTOCOL_FDS = 3  # argv: request fd, reply fd, shared-memory fd
_CODE_CACHE_SIZE = 64
_MAX_MESSAGE = 2000  # the parent reads at most 64 KiB of header; messages come from untrusted code
_MB = 2**20


class _ScoringTimeout(BaseException):
    """Raised by SIGALRM inside the scoring code; BaseException so nothing the code does masks it."""


class _BadOutput(Exception):
    """The code ran but returned something that is not B finite numbers."""


def _numpy_only_import(name, globals=None, locals=None, fromlist=(), level=0):
    """``__import__`` for numpy's C code, which imports through the caller's builtins.

    Scoring code itself cannot name it (the checker refuses names starting with '_').
    """
    if level == 0 and (name == "numpy" or name.startswith("numpy.")):
        return builtins.__import__(name, globals, locals, fromlist, level)
    raise ImportError(f"import of {name!r} is not available to scoring code")


def make_globals() -> dict:
    """A fresh exec namespace: restricted builtins and the allow-listed numpy subset."""
    linalg = types.SimpleNamespace(**{n: getattr(np.linalg, n) for n in sorted(LINALG_FUNCTIONS)})
    names = {n: getattr(np, n) for n in sorted(NUMPY_FUNCTIONS | NUMPY_CONSTANTS)}
    return {
        "__builtins__": {
            "__import__": _numpy_only_import,
            **{n: getattr(builtins, n) for n in sorted(SAFE_BUILTINS)},
        },
        "np": types.SimpleNamespace(linalg=linalg, **names),
    }


def _glibc():
    """The C library if it is glibc (it has ``malloc_trim``), else None."""
    try:
        libc = ctypes.CDLL(None)
        libc.malloc_trim  # noqa: B018 (probe)
    except (OSError, AttributeError):
        return None
    return libc


_LIBC = _glibc()


def settle_startup() -> None:
    """Once, after the imports: startup objects frozen (they live as long as the worker and are left out of
    the collection after every call), then the heap trimmed, as :func:`trim_heap` may do after a call."""
    gc.collect()
    gc.freeze()
    trim_heap()


def collect_garbage() -> None:
    """After every call: collect what it left behind, cycles included (cheap: startup objects are frozen)."""
    gc.collect()


def trim_heap() -> None:
    """Hand freed heap back to the system (glibc only). Done only when the worker rests above its budget:
    the next call would fault those pages in again."""
    if _LIBC is not None:
        _LIBC.malloc_trim(0)


def _vm_bytes() -> int:
    """Current virtual address-space size of this process (what RLIMIT_AS counts)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")


def _error_line(tb) -> int | None:
    """The last line of the scoring source in a traceback (None if it failed elsewhere)."""
    line = None
    while tb is not None:
        if tb.tb_frame.f_code.co_filename == SOURCE_FILENAME:
            line = tb.tb_lineno
        tb = tb.tb_next
    return line


def _clip(text: str) -> str:
    return text if len(text) <= _MAX_MESSAGE else text[:_MAX_MESSAGE] + f"... ({len(text)} characters)"


def _short_repr() -> reprlib.Repr:
    short = reprlib.Repr()
    short.maxlevel, short.maxstring, short.maxother = 3, 200, 200
    short.maxlist = short.maxtuple = short.maxdict = short.maxset = short.maxfrozenset = short.maxdeque = 8
    return short


_SHORT = _short_repr()


def _describe(exc: BaseException) -> str:
    """``Type: message``, clipped; called with the limits held, so a message too big to build fails inside them."""
    try:
        if len(exc.args) == 1 and not isinstance(exc.args[0], str):
            # e.g. `assert ok, big_list`: show the start of the object, never build its whole text
            text = _SHORT.repr(exc.args[0])
        else:
            text = str(exc)
    except Exception as err:  # MemoryError under the limit, ValueError from a huge int's digits, ...
        text = f"(the message could not be shown: {type(err).__name__} while formatting it)"
    return _clip(f"{type(exc).__name__}: {text}" if text else type(exc).__name__)


def _on_alarm(signum, frame):
    raise _ScoringTimeout


def _lock_down() -> None:
    """Process-wide limits that no scoring call needs lifted: no files written, no children."""
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    resource.setrlimit(resource.RLIMIT_NPROC, (0, 0))


def _limit_call(timeout_s: float, ceiling: int) -> None:
    """Per-call limits: address space up to ``ceiling`` bytes, CPU seconds (SIGXCPU kills), a wall-time alarm."""
    _, as_hard = resource.getrlimit(resource.RLIMIT_AS)
    resource.setrlimit(resource.RLIMIT_AS, (ceiling, as_hard))
    usage = resource.getrusage(resource.RUSAGE_SELF)
    cpu_now = usage.ru_utime + usage.ru_stime
    _, cpu_hard = resource.getrlimit(resource.RLIMIT_CPU)
    resource.setrlimit(resource.RLIMIT_CPU, (math.ceil(cpu_now + timeout_s) + 1, cpu_hard))
    signal.setitimer(signal.ITIMER_REAL, timeout_s)


def _unlimit_call() -> None:
    signal.setitimer(signal.ITIMER_REAL, 0)
    _, as_hard = resource.getrlimit(resource.RLIMIT_AS)
    resource.setrlimit(resource.RLIMIT_AS, (as_hard, as_hard))
    _, cpu_hard = resource.getrlimit(resource.RLIMIT_CPU)
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_hard, cpu_hard))


def _check_output(out, batch: int) -> np.ndarray:
    """Coerce to float64 (B,) or raise _BadOutput saying what was returned."""
    try:
        arr = np.asarray(out)
    except (ValueError, TypeError) as exc:
        raise _BadOutput(f"score must return a numeric array of shape ({batch},); got a {type(out).__name__} "
                         f"numpy cannot convert ({exc})") from None
    if arr.dtype.kind not in "biuf":
        raise _BadOutput(f"score must return a numeric array; got dtype {arr.dtype} ({type(out).__name__})")
    if arr.ndim == 0:
        raise _BadOutput(f"score returned a scalar ({type(out).__name__}), expected an array of shape ({batch},) — "
                         "one score per rollout")
    if arr.shape != (batch,):
        raise _BadOutput(f"score must return shape ({batch},) — one score per rollout; got shape {arr.shape}")
    arr = arr.astype(np.float64)
    bad = ~np.isfinite(arr)
    if bad.any():
        raise _BadOutput(
            f"score returned {int(bad.sum())} non-finite values (NaN or inf), first at rollout {int(np.argmax(bad))}"
        )
    return arr


def _timed_out(req: dict) -> dict:
    return {"ok": False, "kind": "timeout", "message": f"timed out after {req['timeout_s']:g} s (the wall-time limit)"}


def _out_of_memory(req: dict, exc: MemoryError) -> dict:
    return {"ok": False, "kind": "memory", "line": _error_line(exc.__traceback__),
            "message": f"exceeded the memory limit of {req['memory_mb']} MB ({_describe(exc)})"}


def _outcome(score, arrays: dict[str, np.ndarray], req: dict) -> dict:
    """Run ``score`` and describe what happened; called with the limits held, error texts included."""
    try:
        return {"ok": True, "scores": _check_output(score(**arrays), req["batch"])}
    except _ScoringTimeout:
        return _timed_out(req)
    except _BadOutput as exc:
        return {"ok": False, "kind": "output", "message": _clip(str(exc))}
    except RecursionError as exc:
        return {"ok": False, "kind": "recursion", "message": f"recursion too deep ({_describe(exc)})",
                "line": _error_line(exc.__traceback__)}
    except MemoryError as exc:
        return _out_of_memory(req, exc)
    except Exception as exc:
        return {"ok": False, "kind": "exception", "message": _describe(exc), "line": _error_line(exc.__traceback__)}


class _Worker:
    def __init__(self, request: Connection, reply: Connection, shm_fd: int) -> None:
        self.request = request
        self.reply = reply
        self.shm_fd = shm_fd
        self.shm: mmap.mmap | None = None
        self.code: dict[str, types.CodeType] = {}
        self.resting = _vm_bytes()  # fixed for the worker's life: calls must not ratchet their budget up

    def _map(self, size: int) -> memoryview:
        if self.shm is None or len(self.shm) != size:
            # an old map still exported to arrays stays alive until those die; just drop it
            self.shm = mmap.mmap(self.shm_fd, size)
        return memoryview(self.shm)

    def _code(self, digest: str, payload: bytes) -> types.CodeType:
        code = self.code.get(digest)
        if code is None:
            if len(self.code) >= _CODE_CACHE_SIZE:
                self.code.pop(next(iter(self.code)))
            code = self.code[digest] = marshal.loads(payload)
        return code

    def _run(self, req: dict) -> dict:
        """One call, then garbage collection; the result says how far above its resting size the worker ended."""
        result = self._call(req)
        assert self.shm is not None  # _call mapped it
        collect_garbage()  # what the call left behind would otherwise eat into the next call's budget
        excess = _vm_bytes() - self.resting - len(self.shm)
        if excess > req["slack_mb"] * _MB:
            trim_heap()
            excess = _vm_bytes() - self.resting - len(self.shm)
        result["resting_mb"] = round(excess / _MB, 1)
        return result

    def _call(self, req: dict) -> dict:
        view = self._map(req["shm_size"])
        assert self.shm is not None  # _map mapped it
        arrays = {
            name: np.frombuffer(view, dtype=np.dtype(dtype), count=math.prod(shape), offset=offset).reshape(shape)
            for name, dtype, shape, offset in req["arrays"]
        }
        namespace = make_globals()
        exec(self._code(req["digest"], req["code"]), namespace)
        ceiling = self.resting + len(self.shm) + (req["memory_mb"] + req["slack_mb"]) * _MB
        try:
            _limit_call(req["timeout_s"], ceiling)
            try:
                return _outcome(namespace["score"], arrays, req)
            finally:
                _unlimit_call()
        except _ScoringTimeout:  # the alarm fired while an error was being described or the limits lifted
            return _timed_out(req)
        except MemoryError as exc:  # describing an error needed more than the limit
            return _out_of_memory(req, exc)
        finally:
            # idempotent; also covers an alarm that fired inside the inner finally
            _unlimit_call()

    def serve(self) -> None:
        self.reply.send_bytes(json.dumps({"ready": True, "pid": os.getpid(),
                                          "resting_mb": round(self.resting / _MB, 1)}).encode())
        while True:
            try:
                req = pickle.loads(self.request.recv_bytes())
            except EOFError:
                return
            result = self._run(req)
            scores = result.pop("scores", None)
            self.reply.send_bytes(json.dumps(result).encode())
            if scores is not None:
                self.reply.send_bytes(memoryview(scores))


def main(argv: list[str]) -> None:
    """Entry point: ``sandbox.py REQUEST_FD REPLY_FD SHM_FD``."""
    if len(argv) != _PROTOCOL_FDS:
        raise SystemExit(f"usage: sandbox.py REQUEST_FD REPLY_FD SHM_FD (got {argv})")
    request_fd, reply_fd, shm_fd = (int(a) for a in argv)
    warnings.simplefilter("ignore")
    np.seterr(all="ignore")
    signal.signal(signal.SIGALRM, _on_alarm)
    make_globals()  # resolve every allow-listed numpy name now, before the limits
    _lock_down()
    settle_startup()  # before the worker measures its resting size
    _Worker(Connection(request_fd, writable=False), Connection(reply_fd, readable=False), shm_fd).serve()


if __name__ == "__main__":
    main(sys.argv[1:])
