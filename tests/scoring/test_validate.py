"""Adversarial scoring code: every case is rejected at compile time or contained at run time.

After each case no file has appeared (in the test's cwd, in a watched
directory the attacks aim at, or in any worker's working directory) and a
legitimate function still scores correctly in the same parent process.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

from rail_mj.core.errors import ScoringRuntimeError, UnsafeCodeError
from rail_mj.core.types import SCORING_ARGS
from rail_mj.scoring import compile_scoring, pool, warm_up

SIGNATURE = f"def score({', '.join(SCORING_ARGS)}):\n"
LEGIT = SIGNATURE + "    return np.sum(contacts_object, axis=1) - 0.5\n"
W = "{W}"  # replaced by the watched directory's path

# (id, body lines of score) — each must raise UnsafeCodeError from compile_scoring
REJECTED = [
    ("import", "import os\nos.system('touch {W}/x')"),
    ("import-as-numpy", "import numpy as np2"),
    ("from-import", "from os import system"),
    ("dunder-import", "__import__('os').system('touch {W}/x')"),
    ("dunder-import-string", "f = 'os'\nreturn '__import__'"),
    ("importlib-walk", "return np.linalg.__spec__.loader"),
    ("class-mro-walk", "return ().__class__.__mro__[1].__subclasses__()"),
    ("np-dict", "return np.__dict__['save']"),
    ("score-globals", "return score.__globals__"),
    ("getattr-built-string", "return getattr(np, 'sa' + 've')"),
    ("open-write", "open('{W}/x', 'w').write('x')"),
    ("np-save", "np.save('{W}/x.npy', agent_pos)"),
    ("np-load", "return np.load('{W}/x.npy')"),
    ("np-fromfile", "return np.fromfile('/etc/passwd')"),
    ("np-lib-os", "np.lib.format.os.system('touch {W}/x')"),
    ("np-ctypeslib", "return np.ctypeslib.as_array(agent_pos)"),
    ("np-memmap", "m = np.memmap('{W}/x', mode='w+', shape=(3,))"),
    ("np-genfromtxt", "return np.genfromtxt('/etc/passwd')"),
    ("tofile", "agent_pos.tofile('{W}/x.bin')"),
    ("dump", "agent_pos.dump('{W}/x.pkl')"),
    ("ctypes", "return agent_pos.ctypes.data"),
    ("base", "return agent_pos.base"),
    ("data-buffer", "return agent_pos.data"),
    ("exec", "exec('import os')"),
    ("eval", "return eval('1')"),
    ("compile", "c = compile('1', 'x', 'eval')"),
    ("format-attr", "s = ('{0.' + '_' + '_class_' + '_}').format(agent_pos)"),
    ("format-dunder-string", "s = '{0.__class__}'"),
    ("f-string", "s = f'{agent_pos}'"),
    ("lambda", "f = lambda x: x\nreturn f(object_tilt)"),
    ("class", "class A:\n    pass"),
    ("global", "global g\ng = 1"),
    ("nonlocal", "x = 1\ndef h():\n    nonlocal x\n    x = 2"),
    ("try-except", "try:\n    x = 1\nexcept Exception:\n    pass"),
    ("with", "with open('{W}/x', 'w') as f:\n    pass"),
    ("raise", "raise ValueError('x')"),
    ("del", "del agent_pos"),
    ("yield", "yield object_tilt"),
    ("type", "return type(agent_pos)"),
    ("object", "return object"),
    ("globals", "return globals()"),
    ("vars", "return vars()"),
    ("breakpoint", "breakpoint()"),
    ("input", "return input()"),
    ("generator-frame", "g = (x for x in [1])\nreturn g.gi_frame.f_globals"),
    ("subclasses-comprehension", "return [c for c in ().__class__.__base__.__subclasses__()]"),
    ("kwargs-unpack", "return np.sum(agent_pos, **{'axis': 1})"),
    ("np-alias", "m = np\nm.save('{W}/x.npy', agent_pos)"),
    ("np-rebind", "np = agent_pos"),
    ("np-attr-assign", "np.sum = None"),
    ("attr-assign", "agent_pos.shape = (1,)"),
    ("decorated-helper", "@np.vectorize\ndef h(x):\n    return x"),
    ("private-name", "_x = 1"),
    ("bytes", "b = b'x'"),
    ("async-def", "async def h():\n    pass"),
    ("match", "match object_tilt:\n    case _:\n        pass"),
    ("np-testing", "return np.testing"),
    ("view", "return agent_pos.view('u1')"),
]

# whole-source cases
REJECTED_SOURCES = [
    ("top-level-code", "x = open('{W}/x', 'w')\n" + LEGIT),
    ("two-functions", LEGIT + "def helper():\n    return 1\n"),
    ("decorated-score", "@np.vectorize\n" + LEGIT),
    ("defaults", LEGIT.replace("object_half_extents)", "object_half_extents=1)")),
    ("too-long", LEGIT + "#" * 25_000),
    ("too-many-nodes", SIGNATURE + "    x = " + "+".join(["1"] * 6000) + "\n    return object_tilt\n"),
    ("deep-nesting", SIGNATURE + "    x = " + "-" * 3000 + "1\n    return object_tilt\n"),
    ("syntax-error", SIGNATURE + "    return (\n"),
    ("null-byte", LEGIT + "\x00"),
]

# (id, body lines, timeout_s, memory_mb, message regex) — each compiles and must raise ScoringRuntimeError
CONTAINED = [
    ("while-true", "while True:\n    pass", 0.3, 1024, "wall-time"),
    ("c-level-loop", "return sum(range(10**13))", 0.3, 1024, "wall-time|killed"),
    ("huge-array", "return np.ones(10**12)", 2.0, 1024, "memory"),
    ("huge-list", "return [0] * 10**10", 2.0, 1024, "memory"),
    ("big-array-over-limit", "x = np.zeros((20000, 20000))\nreturn x.sum(axis=0)[:1] * object_tilt", 2.0, 256,
     "memory"),
    ("growing-list", "xs = []\nwhile True:\n    xs.append(np.ones(10**6))", 5.0, 256, "memory"),
    ("deep-recursion", "def f(n):\n    return f(n + 1)\nreturn f(0)", 2.0, 1024, "recursion"),
    ("scalar-output", "return 1.0", 2.0, 1024, r"shape \(6,\)"),
    ("string-output", "return 'ok'", 2.0, 1024, "numeric"),
    ("list-of-strings", "return ['ok'] * object_tilt.shape[0]", 2.0, 1024, "numeric"),
    ("wrong-shape", "return agent_pos[:, 0, :2]", 2.0, 1024, r"shape \(6,\)"),
    ("none-output", "x = 1", 2.0, 1024, "numeric"),
    ("ragged-output", "return [[1], [1, 2]]", 2.0, 1024, "numeric"),
    ("nan-output", "return object_tilt * np.nan", 2.0, 1024, "non-finite"),
    ("inf-output", "return object_tilt / 0.0", 2.0, 1024, "non-finite"),
    ("zero-division", "return 1 / 0", 2.0, 1024, "ZeroDivisionError"),
    ("index-error", "return agent_pos[10**6]", 2.0, 1024, "IndexError"),
    ("name-error", "return undefined_name", 2.0, 1024, "NameError"),
    ("int-bomb", "return 10 ** 10 ** 9", 0.3, 1024, "wall-time|killed|memory"),
]


def _body(lines: str) -> str:
    return SIGNATURE + "".join(f"    {line}\n" for line in lines.splitlines())


@pytest.fixture(scope="module")
def arena(tmp_path_factory):
    """A watched directory the attacks aim at, a fresh cwd, a warm worker and a small batch."""
    watched = tmp_path_factory.mktemp("watched")
    cwd = tmp_path_factory.mktemp("cwd")
    old = os.getcwd()
    os.chdir(cwd)
    warm_up(1)
    rng = np.random.default_rng(0)
    batch = {
        "agent_pos": rng.normal(size=(6, 4, 3)), "agent_quat": rng.normal(size=(6, 4, 4)),
        "agent_vel": rng.normal(size=(6, 4, 3)), "contacts_object": rng.integers(0, 3, (6, 4)),
        "contacts_agents": rng.integers(0, 3, (6, 4)), "contacts_ground": rng.integers(0, 3, (6, 4)),
        "object_pos": rng.normal(size=(6, 3)), "object_tilt": rng.random(6) + 0.1,
        "object_half_extents": np.ones((6, 3)),
    }
    yield watched, cwd, batch
    os.chdir(old)


def _assert_unharmed(watched, cwd, batch):
    assert list(watched.iterdir()) == []
    assert list(cwd.iterdir()) == []
    for worker in list(pool._LIVE):  # each runs in a folder removed once it started: nothing written there stays
        if worker.ready and worker.proc.poll() is None:
            assert os.readlink(f"/proc/{worker.proc.pid}/cwd").endswith("(deleted)")
    np.testing.assert_array_equal(compile_scoring(LEGIT)(**batch), batch["contacts_object"].sum(axis=1) - 0.5)


def test_corpus_is_large_enough():
    assert len(REJECTED) + len(REJECTED_SOURCES) + len(CONTAINED) >= 30


@pytest.mark.parametrize("case_id,lines", REJECTED, ids=[c[0] for c in REJECTED])
def test_rejected_in_body(arena, case_id, lines):
    watched, cwd, batch = arena
    with pytest.raises(UnsafeCodeError, match=r"line \d+: .* not allowed"):
        compile_scoring(_body(lines.replace(W, str(watched))))
    _assert_unharmed(watched, cwd, batch)


@pytest.mark.parametrize("case_id,source", REJECTED_SOURCES, ids=[c[0] for c in REJECTED_SOURCES])
def test_rejected_source(arena, case_id, source):
    watched, cwd, batch = arena
    with pytest.raises(UnsafeCodeError, match="not allowed"):
        compile_scoring(source.replace(W, str(watched)))
    _assert_unharmed(watched, cwd, batch)


@pytest.mark.parametrize("case_id,lines,timeout_s,memory_mb,message", CONTAINED, ids=[c[0] for c in CONTAINED])
def test_contained_at_run_time(arena, case_id, lines, timeout_s, memory_mb, message):
    watched, cwd, batch = arena
    f = compile_scoring(_body(lines), timeout_s=timeout_s, memory_mb=memory_mb)
    with pytest.raises(ScoringRuntimeError, match=message):
        f(**batch)
    _assert_unharmed(watched, cwd, batch)


def test_worker_killed_mid_call_is_replaced(arena):
    watched, cwd, batch = arena
    f = compile_scoring(_body("while True:\n    pass"), timeout_s=10.0)
    with pool._LOCK:
        pids = [w.proc.pid for w in pool._IDLE]
    assert pids, "the arena keeps a warm worker"
    # the call takes the most recently released worker; kill every idle one to be sure
    timers = [threading.Timer(0.3, os.kill, (pid, signal.SIGSEGV)) for pid in pids]
    for t in timers:
        t.start()
    with pytest.raises(ScoringRuntimeError, match="segmentation fault"):
        f(**batch)
    for t in timers:
        t.join()
    _assert_unharmed(watched, cwd, batch)


def test_idle_worker_that_died_is_replaced_silently(arena):
    watched, cwd, batch = arena
    compile_scoring(LEGIT)(**batch)
    with pool._LOCK:
        workers = list(pool._IDLE)
    for w in workers:
        w.proc.kill()
        w.proc.wait()
    _assert_unharmed(watched, cwd, batch)
    assert all(w not in pool._LIVE for w in workers)


def test_a_parent_that_exits_without_its_clean_up_leaves_no_folder(tmp_path):
    """A forked eval worker leaves with os._exit, which skips atexit and the workers' clean-up: their folders are
    gone already (269 had piled up in /tmp)."""
    code = "import os; from rail_mj.scoring import warm_up; warm_up(1); os._exit(0)"
    subprocess.run([sys.executable, "-c", code], env={**os.environ, "TMPDIR": str(tmp_path)}, check=True, timeout=120)
    assert list(tmp_path.iterdir()) == []


def test_huge_error_message_is_clipped(arena):
    watched, cwd, batch = arena
    f = compile_scoring(_body("assert False, 'x' * 10**6"))
    with pytest.raises(ScoringRuntimeError, match="AssertionError") as info:
        f(**batch)
    assert len(str(info.value)) < 3000
    _assert_unharmed(watched, cwd, batch)


# ---- memory escapes (issue 11 §2): RSS of the worker that served the calls, read from /proc ----

def _serving_worker() -> pool._Worker:
    """The worker the next call will take (the most recently released one)."""
    with pool._LOCK:
        return pool._IDLE[-1]


def _status_mb(pid: int, field: str = "VmRSS") -> float:
    """A memory figure of /proc/PID/status (VmRSS resident, VmSize address space, VmPeak its peak), in MB."""
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith(field + ":")) / 1024


def test_huge_assert_message_is_formatted_under_the_limits(arena):
    watched, cwd, batch = arena
    worker = _serving_worker()
    before = _status_mb(worker.proc.pid)
    # str() of this list is 10 GB: built after the limits were lifted, it grew the worker until the parent's kill
    f = compile_scoring(_body("s = 'x' * 10**5\nc = [s] * 10**5\nassert False, c"), timeout_s=2.0, memory_mb=64)
    with pytest.raises(ScoringRuntimeError, match=r"at line 4: AssertionError: \['xxx") as info:
        f(**batch)
    assert "timed out" not in str(info.value) and len(str(info.value)) < 3000
    assert _serving_worker() is worker and worker.proc.poll() is None  # answered by the worker, not killed
    assert _status_mb(worker.proc.pid) < before + 64
    _assert_unharmed(watched, cwd, batch)


def test_message_too_big_to_build_under_the_limit_is_replaced(arena):
    watched, cwd, batch = arena
    # repr() of the 50 MB key needs another 50 MB, more than is left of the call's 64 MB (+ slack)
    f = compile_scoring(_body("k = 'x' * (50 * 2**20)\nd = {}\nreturn d[k]"), memory_mb=64)
    with pytest.raises(ScoringRuntimeError,
                       match=r"at line 4: KeyError: \(the message could not be shown: MemoryError"):
        f(**batch)
    _assert_unharmed(watched, cwd, batch)


def test_message_that_cannot_be_formatted_is_reported(arena):
    watched, cwd, batch = arena
    # str() of a 5001-digit int raises ValueError; raised in the worker's error handler it killed the worker
    f = compile_scoring(_body("assert False, 10 ** 5000"))
    with pytest.raises(ScoringRuntimeError, match=r"at line 2: AssertionError: \(the message could not be shown"):
        f(**batch)
    _assert_unharmed(watched, cwd, batch)


@pytest.mark.parametrize("elements,memory_mb,calls", [(3 * 10**7, 512, 6), (10**7, 256, 20)],
                         ids=["240MB-x6-cap512", "80MB-x20-cap256"])
def test_cyclic_garbage_is_collected_and_the_cap_does_not_ratchet(arena, elements, memory_mb, calls):
    watched, cwd, batch = arena
    # the memory is measured, not the time: 240 MB filled six times once passed the 2 s default on a loaded machine
    f = compile_scoring(_body(f"x = [np.ones({elements})]\nx.append(x)\nreturn object_tilt"), memory_mb=memory_mb,
                        timeout_s=20.0)
    pool.close_workers()
    warm_up(1)  # a fresh worker, so that its VmPeak covers these calls only
    worker = _serving_worker()
    rss_before, size_before = _status_mb(worker.proc.pid), _status_mb(worker.proc.pid, "VmSize")
    rss = []
    for _ in range(calls):
        np.testing.assert_array_equal(f(**batch), batch["object_tilt"])
        rss.append(_status_mb(worker.proc.pid))
    # each call's cycle held 8 * elements bytes; uncollected, they piled up (258 → 1402 MB) while each call's
    # cap, measured afresh above them, let the next call add as much again
    assert max(rss) < rss_before + 64, f"worker RSS after each call (MB): {rss}, before: {rss_before:.0f}"
    assert _status_mb(worker.proc.pid, "VmPeak") < size_before + memory_mb + pool.RESTING_SLACK_MB + 16
    assert _serving_worker() is worker  # nothing was left to recycle it for
    _assert_unharmed(watched, cwd, batch)


def test_worker_resting_above_its_budget_is_retired(arena, monkeypatch):
    watched, cwd, batch = arena
    f = compile_scoring(LEGIT)
    want = batch["contacts_object"].sum(axis=1) - 0.5
    np.testing.assert_array_equal(f(**batch), want)
    first = _serving_worker()
    monkeypatch.setattr(pool, "RESTING_SLACK_MB", -1)  # every worker now ends its call above its budget
    np.testing.assert_array_equal(f(**batch), want)
    assert first.proc.poll() is not None and first not in pool._LIVE and first not in pool._IDLE
    np.testing.assert_array_equal(f(**batch), want)  # a fresh worker served it
    monkeypatch.undo()
    _assert_unharmed(watched, cwd, batch)
