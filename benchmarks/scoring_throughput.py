"""Sandboxed scoring throughput: cold worker start, then ms per call for 30, 1k and 10k rollouts.

Run: ``python benchmarks/scoring_throughput.py [--agents 27] [--repeats 20]``.
Prints, per batch size, the median and best wall time of one sandboxed call
(containment score over B rollouts × N agents, all nine SCORING_ARGS arrays
shipped to the worker) next to the same function run directly in-process.
B=30 is the pipeline's size (stable poses × plans), where the per-call overhead
dominates. The last lines time the worker's housekeeping after each call
(:func:`rail_mj.scoring.sandbox.collect_garbage`; ``trim_heap`` runs only
when a worker rests above its budget) in an interpreter set up like a worker
(:func:`~rail_mj.scoring.sandbox.settle_startup`).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

import numpy as np

from rail_mj.core.types import SCORING_ARGS
from rail_mj.scoring import close_workers, compile_scoring, sandbox, warm_up

CONTAINMENT = f"def score({', '.join(SCORING_ARGS)}):\n" + """
    h = object_half_extents[:, None, :]
    inside = np.all(np.abs(agent_pos) <= h, axis=-1)
    kept = np.logical_and(inside, contacts_ground == 0)
    return kept.mean(axis=1) - 0.5
"""


def batch_arrays(batch: int, agents: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {
        "agent_pos": rng.normal(0.0, 0.1, (batch, agents, 3)),
        "agent_quat": rng.normal(size=(batch, agents, 4)),
        "agent_vel": rng.normal(size=(batch, agents, 3)),
        "contacts_object": rng.integers(0, 3, (batch, agents)),
        "contacts_agents": rng.integers(0, 3, (batch, agents)),
        "contacts_ground": rng.integers(0, 2, (batch, agents)),
        "object_pos": rng.normal(size=(batch, 3)),
        "object_tilt": rng.random(batch),
        "object_half_extents": np.full((batch, 3), 0.1),
    }


def direct(arrays: dict[str, np.ndarray]) -> np.ndarray:
    inside = np.all(np.abs(arrays["agent_pos"]) <= arrays["object_half_extents"][:, None, :], axis=-1)
    return np.logical_and(inside, arrays["contacts_ground"] == 0).mean(axis=1) - 0.5


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agents", type=int, default=27)
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()

    close_workers()
    t0 = time.perf_counter()
    warm_up(1)
    print(f"cold start (spawn worker, import numpy): {(time.perf_counter() - t0) * 1e3:.0f} ms")
    fn = compile_scoring(CONTAINMENT)
    for batch in (30, 1_000, 10_000):
        arrays = batch_arrays(batch, args.agents)
        mb = sum(a.nbytes for a in arrays.values()) / 2**20
        assert np.array_equal(fn(**arrays), direct(arrays))  # first call also caches the code in the worker
        sandboxed, inproc = [], []
        for _ in range(args.repeats):
            t = time.perf_counter()
            fn(**arrays)
            sandboxed.append((time.perf_counter() - t) * 1e3)
            t = time.perf_counter()
            direct(arrays)
            inproc.append((time.perf_counter() - t) * 1e3)
        print(f"B={batch:>6} x {args.agents} agents ({mb:.1f} MB in): sandboxed median "
              f"{statistics.median(sandboxed):.1f} ms, best {min(sandboxed):.1f} ms | in-process numpy median "
              f"{statistics.median(inproc):.1f} ms")
    close_workers()
    for batch in (30, 10_000):
        print(f"worker housekeeping after each call (gc.collect, startup objects frozen), "
              f"B={batch}: median {housekeeping_ms(args, batch):.3f} ms")


_HOUSEKEEPING = """
import statistics, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
import sandbox
repeats, batch, agents = (int(a) for a in sys.argv[2:])
sandbox.make_globals()
sandbox.settle_startup()
namespace = sandbox.make_globals()
exec(compile(sys.stdin.read(), sandbox.SOURCE_FILENAME, "exec"), namespace)
rng = np.random.default_rng(0)
per_agent = {"agent_pos": 3, "agent_quat": 4, "agent_vel": 3}
arrays = {n: rng.normal(0.0, 0.1, (batch, agents, k)) for n, k in per_agent.items()}
contacts = ("contacts_object", "contacts_agents", "contacts_ground")
arrays.update({n: rng.integers(0, 2, (batch, agents)) for n in contacts})
arrays.update(object_pos=rng.normal(size=(batch, 3)), object_tilt=rng.random(batch),
              object_half_extents=np.full((batch, 3), 0.1))
times = []
for _ in range(repeats):
    namespace["score"](**arrays)
    t = time.perf_counter()
    sandbox.collect_garbage()
    times.append((time.perf_counter() - t) * 1e3)
print(statistics.median(times))
"""


def housekeeping_ms(args: argparse.Namespace, batch: int) -> float:
    """The worker's after-call housekeeping, timed in an interpreter set up like a worker after one call each."""
    out = subprocess.run(
        [sys.executable, "-P", "-B", "-c", _HOUSEKEEPING, os.path.dirname(sandbox.__file__), str(args.repeats),
         str(batch), str(args.agents)],
        input=CONTAINMENT, capture_output=True, text=True, check=True, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"},
    )
    return float(out.stdout)


if __name__ == "__main__":
    main()
