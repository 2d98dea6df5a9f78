"""Throughput of TriPlanarShear-v0 (one core): ``PYTHONPATH=. python benchmarks/bench_env.py [--quick]``; ``--v1``:
TriPlanarShear-v1 in bench mode with randomisation against v0, in the same process; ``--batched-v1``: the batched
v1 (``gym.make_vec``, bench mode, randomised, random actions; without and with the start bank) against the batched
v0 (random actions) at ``--num-envs`` (1024) envs, interleaved in one process.

Measures, best of ``--repeats`` runs (the machine is shared, so the best run is the least disturbed one):

* the kernel floor: one 5 ms control period (``triplanar.kernel.integrate``, one RK4 step) in a compiled loop;
* single-env ``step()`` (no wrappers, autoreset by hand): random actions, and the steel tip's constant action;
* the vector env (``gym.make_vec``) at several sizes, random and constant actions;
* PPO wall-clock to the tracking tip's mimicry error at 27.8 N, read from the study's learning curves
  (``--runs``, default ``runs/ppo``) if they exist.

Random actions make the block stop, stick and restart often; the kernel steps to each predicted stop, but a
period whose fixed steps still break the energy balance by more than 1e-8 J is redone with the kernel's adaptive
integrator (see ``docs/environment.md``), so random actions are the slow case. The fraction of such periods is
printed.
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from numba import njit

from envs import v0_on_purpose  # (importing envs registers TriPlanarShear-v0 and -v1)
from envs.triplanar_shear import TriPlanarShearEnv
from triplanar import kernel as K, stepping
from triplanar.atomic import write_atomic
from triplanar.outcome import Outcome


@njit  # not cached: a cached copy would keep an old kernel built in (numba caches per file)
def _kernel_periods(y0, p, modes, n, x1_target):
    out_t = np.empty(1)
    out_y = np.empty((1, K.N_STATE))
    out_aux = np.empty((1, K.N_AUX))
    armed = np.zeros(5, np.bool_)
    y = y0.copy()
    ws = stepping.new_workspace()  # as the env: one workspace for the loop
    K.modes_of(ws)[:] = modes
    for i in range(n):
        y[:] = y0
        opts = stepping.StepOptions(stepping.METHOD_RK4, 0.0, 0.0, 0.01, x1_target, 1e-5, 0.0)
        rec = stepping.Recording(False, out_t, out_y, out_y, out_aux, np.empty((0, 3)))
        stepping.integrate_ws(0.005, y, p, armed, 0.005, opts, rec, 0, ws)


CLOCK = [time.perf_counter]  # --cpu-time: time.process_time (this process's CPU time; the machine is shared)


def best_of(repeats: int, fn) -> float:
    return max(fn() for _ in range(repeats))


def kernel_floor(n: int) -> float:
    env = TriPlanarShearEnv(load_N=27.8)
    env.reset(seed=0)
    state = env.get_state()
    y, p, modes = state.y, state.p, state.modes
    _kernel_periods(y, p, modes, 10, 1.0)
    t0 = CLOCK[0]()
    _kernel_periods(y, p, modes, n, 1.0)
    return n / (CLOCK[0]() - t0)


def single(n: int, policy: str, stats: dict) -> float:
    env = TriPlanarShearEnv(load_N=27.8)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (n, 2)).astype(np.float32) if policy == "random" else np.zeros((n, 2), np.float32)
    env.reset(seed=0)
    env.step(actions[0])  # compiled code loaded (or compiled) before timing
    env.reset(seed=0)
    adaptive = episodes = 0
    t0 = CLOCK[0]()
    for i in range(n):
        _, _, terminated, truncated, info = env.step(actions[i])
        adaptive += info["adaptive_steps"] > 0
        if terminated or truncated:
            episodes += 1
            env.reset()
    rate = n / (CLOCK[0]() - t0)
    stats[f"single_{policy}"] = {"adaptive_fraction": adaptive / n, "mean_episode_steps": n / max(episodes, 1)}
    return rate


_V1_RUNS = [0]


def single_v1(n: int, stats: dict, **kwargs) -> float:
    """TriPlanarShear-v1 (default: bench observations, unknown specimens), random actions, autoreset by hand.

    Each call starts from a seed of its own: with the same seed a repeat would draw the same specimens, whose starts
    a long-lived env finds in its start cache (``envs.core.StartCache``), which training never does."""
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env
    env = TriPlanarShearV1Env(**{"observation_mode": "bench", "randomize": True, **kwargs})
    actions = np.random.default_rng(0).uniform(-1, 1, (n, 2)).astype(np.float32)
    env.reset(seed=0)
    env.step(actions[0])
    _V1_RUNS[0] += 1
    env.reset(seed=1000 + _V1_RUNS[0])
    episodes = 0
    t0 = CLOCK[0]()
    for i in range(n):
        _, _, terminated, truncated, _ = env.step(actions[i])
        if terminated or truncated:
            episodes += 1
            env.reset()
    rate = n / (CLOCK[0]() - t0)
    stats["single_v1_" + "_".join(f"{k}={v}" for k, v in kwargs.items())] = {"mean_episode_steps": n / max(episodes, 1)}
    return rate


def v1_against_v0(repeats: int, n: int, stats: dict) -> dict:
    """v1 in bench mode with randomisation at >= 0.8x v0's single-env random-action throughput,
    measured in the same process (interleaved, best of ``repeats``)."""
    out = {"v0_random_steps_per_s": best_of(repeats, lambda: single(n, "random", stats)),
           "v1_bench_random_steps_per_s": best_of(repeats, lambda: single_v1(n, stats)),
           "v1_bench_fixed_load_steps_per_s": best_of(repeats, lambda: single_v1(n, stats, randomize=False,
                                                                                   load_N=27.8))}
    out["v1_over_v0"] = out["v1_bench_random_steps_per_s"] / out["v0_random_steps_per_s"]
    return out


def v1_reset_cost(n: int) -> dict:
    """CPU microseconds per randomised v1 reset (fresh specimens), and how much of it is compiled physics that no
    restructuring of the Python around it can remove: the start-mode search (``start_motion_ws``: the actuator
    start of every draw, the hydrostatic start of the reference run), the reference run's integration
    (``driver.drive``), the statics LP and the first control period(s). Wraps those entry points with timers
    (a few hundred ns each)."""
    import sys

    import envs.core as v0
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env
    from triplanar import equilibrium
    simulate_module = sys.modules["triplanar.simulate"]
    spent: dict[str, float] = {}
    calls: dict[str, int] = {}
    originals = []

    def timed(module, name: str) -> None:
        fn = getattr(module, name)
        originals.append((module, name, fn))

        def wrapper(*args, **kwargs):
            t0 = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[name] = spent.get(name, 0.0) + time.process_time() - t0
                calls[name] = calls.get(name, 0) + 1
        setattr(module, name, wrapper)

    timed(stepping, "start_motion_ws")
    timed(simulate_module.driver, "drive")   # (the env's own periods call it inside compiled code: not counted)
    timed(equilibrium, "holds")
    timed(v0, "control_step")
    try:
        env = TriPlanarShearV1Env(observation_mode="bench", randomize=True)
        env.reset(seed=0)
        for _ in range(10):
            env.reset()
        spent.clear()
        calls.clear()
        t0 = time.process_time()
        for _ in range(n):
            env.reset()
        total = time.process_time() - t0
    finally:
        for module, name, fn in originals:
            setattr(module, name, fn)
    out = {"reset_cpu_us": 1e6 * total / n, "compiled_cpu_us": 1e6 * sum(spent.values()) / n}
    out.update({f"{name}_us_per_reset": 1e6 * spent[name] / n for name in spent})
    out.update({f"{name}_calls_per_reset": calls[name] / n for name in calls})
    return out


def vector(num_envs: int, steps: int, policy: str) -> float:
    with v0_on_purpose():
        vec = gym.make_vec("TriPlanarShear-v0", num_envs=num_envs, load_N=27.8)
    vec.reset(seed=0)
    rng = np.random.default_rng(0)
    shape = (steps + 1, num_envs, 2)
    batches = rng.uniform(-1, 1, shape).astype(np.float32) if policy == "random" else np.zeros(shape, np.float32)
    vec.step(batches[0])
    t0 = CLOCK[0]()
    for i in range(1, steps + 1):
        vec.step(batches[i])
    return num_envs * steps / (CLOCK[0]() - t0)


def vector_env_rate(env_id: str, num_envs: int, steps: int, seed: int, **kwargs) -> tuple[float, float]:
    """(env-steps/s of ``steps`` random-action steps of ``gym.make_vec(env_id)``, mean episode length in steps)."""
    with v0_on_purpose():
        vec = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)
    vec.reset(seed=seed)
    rng = np.random.default_rng(seed)
    batches = rng.uniform(-1, 1, (steps + 5, num_envs, 2)).astype(np.float32)
    for i in range(5):   # compiled code loaded, and the first resets past
        vec.step(batches[i])
    episodes = 0
    t0 = CLOCK[0]()
    for i in range(5, steps + 5):
        _, _, terminated, truncated, _ = vec.step(batches[i])
        episodes += int(np.count_nonzero(terminated | truncated))
    return num_envs * steps / (CLOCK[0]() - t0), num_envs * steps / max(episodes, 1)


def batched_v1_against_v0(repeats: int, num_envs: int, steps: int) -> dict:
    """The batched v1 (bench mode, unknown specimens, random actions) against the batched v0 (random actions), best of
    ``repeats`` interleaved runs; each run draws new specimens (a seed of its own: the start cache never helps)."""
    setups = {"v0": ("TriPlanarShear-v0", {}),
              "v1_bench_randomized": ("TriPlanarShear-v1", {"randomize": True}),
              "v1_bench_randomized_start_bank": ("TriPlanarShear-v1", {"randomize": True, "start_bank": max(1, num_envs // 4)})}
    best: dict[str, float] = {}
    lengths: dict[str, float] = {}
    for repeat in range(repeats):
        for name, (env_id, kwargs) in setups.items():
            rate, length = vector_env_rate(env_id, num_envs, steps, 1000 * (repeat + 1), **kwargs)
            best[name] = max(best.get(name, 0.0), rate)
            lengths[name] = length
    out = {f"{name}_env_steps_per_s": rate for name, rate in best.items()}
    out.update({f"{name}_mean_episode_steps": length for name, length in lengths.items()})
    for name in setups:
        if name != "v0":
            out[f"{name}_over_v0"] = best[name] / best["v0"]
    return out


def ppo_time_to_target(runs: Path, target_mm: float = 7.73, load: str = "27.8") -> list[dict]:
    out = []
    for curve in sorted(runs.glob("seed_*/learning_curve.csv")):
        with open(curve) as f:
            rows = list(csv.DictReader(f))
        hit = next((r for r in rows if float(r[f"error_mm_{load}N"]) <= target_mm
                    and r[f"reason_{load}N"] == Outcome.TRAVEL.label), None)
        out.append({"run": curve.parent.name, "timesteps": int(hit["timesteps"]) if hit else None,
                    "wall_s": float(hit["wall_s"]) if hit else None})
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps (a smoke run)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--runs", default="runs/ppo", help="PPO runs with learning_curve.csv")
    parser.add_argument("--target-mm", type=float, default=None,
                        help="tracking tip's error at 27.8 N (default: evaluated now)")
    parser.add_argument("--json", help="also write the numbers here")
    parser.add_argument("--v1", action="store_true", help="only the single v1-against-v0 comparison")
    parser.add_argument("--batched-v1", action="store_true", help="only the batched v1-against-v0 comparison")
    parser.add_argument("--num-envs", type=int, default=1024, help="envs of the batched comparison")
    parser.add_argument("--cpu-time", action="store_true",
                        help="steps per CPU-second of this process instead of per wall-clock second (less disturbed "
                             "by other work on a shared machine)")
    args = parser.parse_args()
    if args.cpu_time:
        CLOCK[0] = time.process_time
    if args.batched_v1:
        result = batched_v1_against_v0(args.repeats, args.num_envs, 20 if args.quick else 200)
        for key, value in result.items():
            print(f"{key}: {value:,.2f}")
        if args.json:
            write_atomic(args.json, lambda tmp: tmp.write_text(json.dumps(result, indent=2)))
        return 0
    if args.v1:
        stats_v1: dict = {}
        result = v1_against_v0(args.repeats, 2_000 if args.quick else 20_000, stats_v1)
        result["v1_reset"] = v1_reset_cost(40 if args.quick else 400)
        for key, value in {**result, "stats": stats_v1}.items():
            print(f"{key}: {value if not isinstance(value, float) else f'{value:,.2f}'}")
        if args.json:
            write_atomic(args.json, lambda tmp: tmp.write_text(json.dumps({**result, "stats": stats_v1}, indent=2)))
        return 0
    scale = 0.1 if args.quick else 1.0
    stats: dict = {}
    results = {"kernel_floor_periods_per_s": best_of(args.repeats, lambda: kernel_floor(int(200_000 * scale)))}
    work = {"random": 0.25, "constant": 1.0}  # random actions are ~10x slower per step: fewer of them
    for policy in ("random", "constant"):
        results[f"single_{policy}_steps_per_s"] = best_of(
            args.repeats, lambda: single(int(100_000 * scale * work[policy]), policy, stats))
    for num_envs in (1, 64, 1024, 4096):
        for policy in ("random", "constant"):
            steps = max(60, int(200_000 * scale * work[policy]) // num_envs)  # past the start transient
            results[f"vector_{num_envs}_{policy}_env_steps_per_s"] = best_of(
                args.repeats, lambda: vector(num_envs, steps, policy))
    target = args.target_mm
    if target is None:
        from agents import TrackingTip, evaluate
        target = evaluate(TrackingTip(), 27.8).mimicry_error_mm
    results["tracking_tip_error_27.8N_mm"] = target
    results["ppo_time_to_tracking_tip"] = ppo_time_to_target(Path(args.runs), target)
    results["stats"] = stats
    for key, value in results.items():
        print(f"{key}: {value if not isinstance(value, float) else f'{value:,.0f}' if value > 100 else f'{value:.3f}'}")
    if args.json:
        write_atomic(args.json, lambda tmp: tmp.write_text(json.dumps(results, indent=2)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
