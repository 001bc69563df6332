"""Physics throughput of the imagination backends on one scene: a CoACD cup and a grid of droplets.

    python benchmarks/rollout_throughput.py --batch 8,64,512 --json out.json
    python benchmarks/rollout_throughput.py --quick

Every backend steps the same worlds (cup upright, 27 droplets released above it) for the same number of
steps; steps/s = batch × steps / wall. Also: fraction of droplets inside the cup per backend (agreement),
MJX compile time and a second same-bucket object, and the wall time of one whole imagination
(all stable poses × 5 plans) per backend.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

os.environ.setdefault("JAX_PLATFORMS", "cpu")

import coacd
import jax
import mujoco
import mujoco.batch
import numpy as np
import trimesh

from rail_mj.core.types import AgentSetup, RailObject
from rail_mj.imagination import ImaginationConfig, get_backend, imagine, prepare
from rail_mj.imagination.mjx import hull_bucket
from rail_mj.stable_poses import find_stable_poses, pose_from_up

jax.config.update("jax_cpu_enable_async_dispatch", False)

DROPLET = ('<mujoco><worldbody><body name="drop"><geom type="sphere" size="0.006" mass="0.001"/></body></worldbody>'
           '</mujoco>')


def cup_object(radius: float = 0.04, height: float = 0.08, wall: float = 0.004, name: str = "cup") -> RailObject:
    """A revolved ≈ 8 cm cup, convex-decomposed by CoACD."""
    profile = np.array([[0, 0], [radius, 0], [radius, height], [radius - wall, height], [radius - wall, wall],
                        [0, wall]])
    mesh = trimesh.creation.revolve(profile, sections=32)
    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=0.05, max_convex_hull=16, seed=0)
    hulls = tuple(np.asarray(v) for v, _ in parts)
    density = 800.0
    return RailObject(name=name, mesh=mesh, hulls=hulls, mesh_hash=f"bench-{name}-{radius}-{height}",
                      obb_dims=np.sort(mesh.extents)[::-1], com=mesh.center_mass, mass=float(mesh.volume * density),
                      density=density)


def droplets(n: int = 3, spacing: float = 0.016) -> AgentSetup:
    g = (np.arange(n) - (n - 1) / 2) * spacing
    return AgentSetup(fragment=DROPLET, offsets=np.array([[x, y, z] for x in g for y in g for z in g]))


def _scene_state(obj: RailObject, agents: AgentSetup, batch: int, cfg: ImaginationConfig, backend: str = "native"):
    """The backend's scene, the initial states of ``batch`` upright cups with the droplets above, the pose."""
    pose = pose_from_up(obj, np.array([0.0, 0.0, 1.0]), 1.0)
    scene = get_backend(backend, cfg).scene(obj, agents)
    plan = np.array([[0, 0, pose.half_extents[2] + 0.04, 1, 0, 0, 0]])
    return scene, prepare(obj, [pose] * batch, agents, [plan], cfg).initial_qpos(scene), pose


def _inside(agent_world: np.ndarray, pose) -> float:
    rel = agent_world - np.array([0, 0, pose.half_extents[2]])
    return float((np.abs(rel) <= pose.half_extents + 1e-3).all(-1).mean())


def run_native(scene, qpos0, pose, nsteps: int, nthread: int):
    batch = mujoco.batch.Batch(scene.model, len(qpos0), nthread=nthread, persistent=True)
    qpos = batch.bind("qpos")
    batch.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)
    qpos[:] = qpos0
    batch.forward()
    t = time.perf_counter()
    batch.step(nstep=nsteps)
    wall = time.perf_counter() - t
    return wall, _agents_inside(scene, np.array(qpos), pose)


def run_serial(scene, qpos0, pose, nsteps: int):
    data = mujoco.MjData(scene.model)
    finals = []
    t = time.perf_counter()
    for q in qpos0:
        mujoco.mj_resetData(scene.model, data)
        data.qpos[:] = q
        mujoco.mj_step(scene.model, data, nsteps)
        finals.append(data.qpos.copy())
    wall = time.perf_counter() - t
    return wall, _agents_inside(scene, np.array(finals), pose)


def _agents_inside(scene, qpos: np.ndarray, pose) -> float:
    return _inside(np.stack([qpos[:, a : a + 3] for a in scene.agent_qpos], axis=1), pose)


def run_mjx(obj, agents, batch: int, nsteps: int, cfg: ImaginationConfig):
    """MJX scan of plain steps on the backend's box-bucket scene; returns (compile_s, run_s, inside)."""
    from mujoco import mjx

    scene, qpos0, pose = _scene_state(obj, agents, batch, cfg, "mjx")
    m = get_backend("mjx", cfg).put_model(scene)

    @jax.jit
    def roll(m, qpos0):
        d0 = jax.vmap(lambda q: mjx.make_data(m).replace(qpos=q))(qpos0)
        step = jax.vmap(mjx.step, in_axes=(None, 0))
        return jax.lax.fori_loop(0, nsteps, lambda _, d: step(m, d), d0).qpos

    qpos0 = jax.numpy.asarray(qpos0)
    t = time.perf_counter()
    compiled = roll.lower(m, qpos0).compile()
    compile_s = time.perf_counter() - t
    t = time.perf_counter()
    out = np.asarray(compiled(m, qpos0))
    return compile_s, time.perf_counter() - t, _agents_inside(scene, out, pose)


def run_pybullet(obj, agents, pose, batch: int, nsteps: int, dt: float):
    import pybullet as pb

    client = pb.connect(pb.DIRECT)
    pb.setGravity(0, 0, -9.81, physicsClientId=client)
    pb.setTimeStep(dt, physicsClientId=client)
    pb.createMultiBody(0, pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=client), physicsClientId=client)
    shapes = [pb.createCollisionShape(pb.GEOM_MESH, vertices=h.tolist(), physicsClientId=client) for h in obj.hulls]
    cup = pb.createMultiBody(
        obj.mass / len(shapes), shapes[0], basePosition=pose.pos.tolist(), physicsClientId=client,
        linkMasses=[obj.mass / len(shapes)] * (len(shapes) - 1), linkCollisionShapeIndices=shapes[1:],
        linkVisualShapeIndices=[-1] * (len(shapes) - 1), linkPositions=[[0, 0, 0]] * (len(shapes) - 1),
        linkOrientations=[[0, 0, 0, 1]] * (len(shapes) - 1), linkInertialFramePositions=[[0, 0, 0]] * (len(shapes) - 1),
        linkInertialFrameOrientations=[[0, 0, 0, 1]] * (len(shapes) - 1), linkParentIndices=[0] * (len(shapes) - 1),
        linkJointTypes=[pb.JOINT_FIXED] * (len(shapes) - 1), linkJointAxis=[[0, 0, 1]] * (len(shapes) - 1),
    )
    sphere = pb.createCollisionShape(pb.GEOM_SPHERE, radius=0.006, physicsClientId=client)
    start = np.asarray(agents.offsets) + np.array([0, 0, 2 * pose.half_extents[2] + 0.04])
    balls = [pb.createMultiBody(0.001, sphere, basePosition=p.tolist(), physicsClientId=client) for p in start]
    state = pb.saveState(physicsClientId=client)
    finals = []
    t = time.perf_counter()
    for _ in range(batch):  # the paper's loop: one world after another
        pb.restoreState(state, physicsClientId=client)
        for _ in range(nsteps):
            pb.stepSimulation(physicsClientId=client)
        finals.append([pb.getBasePositionAndOrientation(b, physicsClientId=client)[0] for b in balls])
    wall = time.perf_counter() - t
    pb.disconnect(client)
    del cup
    return wall, _inside(np.array(finals), pose)


def cpu_model() -> str:
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def imagination_wall(obj, agents, backend: str, cfg: ImaginationConfig) -> tuple[float, int]:
    poses = find_stable_poses(obj)
    top = float(max(p.half_extents[2] for p in poses))
    plans = [np.array([[dx, 0.0, top + 0.04, 1, 0, 0, 0]]) for dx in (-0.02, -0.01, 0.0, 0.01, 0.02)]
    t = time.perf_counter()
    imagine(obj, poses, agents, plans, backend=backend, config=cfg)
    return time.perf_counter() - t, len(poses)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--batch", default="8,64,512", help="comma-separated batch sizes")
    ap.add_argument("--steps", type=int, default=300, help="physics steps per rollout")
    ap.add_argument("--mjx-max-batch", type=int, default=64, help="largest batch run on mjx (CPU MJX is slow)")
    ap.add_argument("--no-mjx", action="store_true")
    ap.add_argument("--quick", action="store_true", help="batch 8 and 64 steps: a smoke run")
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args()
    batches = [8] if args.quick else [int(b) for b in args.batch.split(",")]
    nsteps = 64 if args.quick else args.steps
    cfg = ImaginationConfig()
    obj, agents = cup_object(), droplets()
    device = {"jax_devices": [str(d) for d in jax.devices()], "cpu": cpu_model(), "threads": os.cpu_count(),
              "mujoco": mujoco.__version__, "hulls": len(obj.hulls), "agents": len(agents.offsets)}
    print(f"device: {device}")
    results, agreement = [], {}
    for b in batches:
        scene, qpos0, pose = _scene_state(obj, agents, b, cfg)
        runs = {"native-serial": run_serial(scene, qpos0, pose, nsteps),
                "native": run_native(scene, qpos0, pose, nsteps, 0)}
        try:
            runs["pybullet"] = run_pybullet(obj, agents, pose, b, nsteps, cfg.timestep)
        except ImportError:
            print("pybullet not importable: skipped")
        for name, (wall, inside) in runs.items():
            results.append({"backend": name, "batch": b, "steps_per_s": b * nsteps / wall, "wall_s": wall,
                            "compile_s": 0.0})
            agreement[name] = inside
        if not args.no_mjx and b <= args.mjx_max_batch:
            compile_s, wall, inside = run_mjx(obj, agents, b, nsteps, cfg)
            results.append({"backend": "mjx", "batch": b, "steps_per_s": b * nsteps / wall, "wall_s": wall,
                            "compile_s": compile_s})
            agreement["mjx"] = inside
    print(f"\n{'backend':14s} {'batch':>6s} {'steps/s':>10s} {'wall s':>8s} {'compile s':>9s}")
    for r in results:
        print(f"{r['backend']:14s} {r['batch']:6d} {r['steps_per_s']:10.0f} {r['wall_s']:8.3f} {r['compile_s']:9.1f}")
    rate = {(r["backend"], r["batch"]): r["steps_per_s"] for r in results}
    ratios = {}
    for b in batches:
        for num, den in (("native", "pybullet"), ("native", "native-serial"), ("mjx", "native")):
            if (num, b) in rate and (den, b) in rate:
                ratios[f"{num}/{den}@{b}"] = rate[num, b] / rate[den, b]
    print("ratios: " + ", ".join(f"{k} {v:.2f}" for k, v in ratios.items()))
    print("agreement (fraction of droplets inside the upright cup, largest batch): "
          + ", ".join(f"{k} {v:.2f}" for k, v in agreement.items()))

    bucket = {}
    if not args.no_mjx:
        small = droplets(2)
        mjx_backend = get_backend("mjx", cfg)
        before = mjx_backend.compiles
        t = time.perf_counter()
        imagination_wall(obj, small, "mjx", cfg)
        first = time.perf_counter() - t
        other = cup_object(radius=0.035, height=0.07, name="cup2")
        t = time.perf_counter()
        same = hull_bucket(len(obj.hulls)) == hull_bucket(len(other.hulls))
        imagination_wall(other, small, "mjx", cfg)
        bucket = {"first_object_s": first, "second_object_s": time.perf_counter() - t,
                  "compiles": mjx_backend.compiles - before, "same_bucket": same}
        print(f"mjx second object (hulls {len(obj.hulls)} vs {len(other.hulls)}): {bucket}")

    imagination = {}
    for name, backend, c in (("native", "native", cfg),
                             ("native-serial", "native", cfg.model_copy(update={"nthread": 1})),
                             *((("mjx", "mjx", cfg),) if not args.no_mjx else ())):
        wall, n_poses = imagination_wall(obj, agents, backend, c)
        imagination[name] = {"wall_s": wall, "poses": n_poses, "per_pose_s": wall / n_poses}
    print("imagination of one object (all stable poses x 5 plans, 27 droplets): "
          + ", ".join(f"{k} {v['wall_s']:.2f} s ({v['poses']} poses, {v['per_pose_s']:.2f} s/pose)"
                      for k, v in imagination.items()))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"device": device, "steps": nsteps, "results": results, "ratios": ratios, "agreement": agreement,
                       "mjx_bucket": bucket, "imagination": imagination}, f, indent=2)


if __name__ == "__main__":
    main()
