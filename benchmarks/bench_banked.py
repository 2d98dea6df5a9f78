"""``banked:RUN``'s decision time and its estimate's error (:class:`agents.banked_deviation.BankedDeviationPolicy`,
finding 13b of ``docs/notes/student-experiments.md``), on the first ``--n`` judge draws, driven by itself.

``PYTHONPATH=. taskset -c 0 python benchmarks/bench_banked.py --run RUN [--n 20] [--bank-size 16]`` prints, as JSON,
the median, 99th percentile and largest thread CPU of a decision (the new measurement weighed, the estimate, the
policy: what stands between a measurement and its command) and of the whole period (the bank's prediction for the
command decided included, which a bench runs in the period's slack), from the controller's own ``info``; and the
estimate's error against the env's true deviation (:meth:`envs.base.ShearEnvBase.reference_deviation`: the mean
over the three contact points of the x-z distance, mm) by span of decisions. The issue's target: 1 ms at the 99th
percentile on one pinned core with nothing else running. numpy's BLAS and torch are held to one thread.
"""

from __future__ import annotations

import argparse
import json

import numpy as np
from threadpoolctl import threadpool_limits

from agents.banked_deviation import BANK_SIZE, BankedDeviationPolicy
from agents.controller_base import play
from envs.triplanar_shear_v1 import TriPlanarShearV1Env
from experiments.train_student import judge_draws

SPANS = ((0, 8), (8, 16), (16, 32), (32, 10_000))   # decision indices


def estimate_error_mm(estimate: np.ndarray, truth: np.ndarray) -> float:
    """The mean over the three contact points of the x-z distance between two deviations' first six values."""
    d = (np.asarray(estimate)[:6] - np.asarray(truth)[:6]).reshape(3, 2)
    return float(np.mean(np.hypot(d[:, 0], d[:, 1])))


def episode(controller: BankedDeviationPolicy, bench, seed: int) -> list[tuple[float, float, float]]:
    """(decision CPU s, period CPU s, the estimate's error mm) of every decision of one episode."""
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=seed, options={"bench": bench})
    rows = []

    def record(decided_on: np.ndarray, action: np.ndarray) -> None:
        info = controller.info
        rows.append((info["decision_cpu_s"], info["period_cpu_s"],
                     estimate_error_mm(controller.estimate, env.unwrapped.reference_deviation())))

    play(controller, env, obs, bench.load_N, on_decision=record)
    return rows


def summary(rows: list[list[tuple[float, float, float]]]) -> dict:
    flat = np.array([r for episode_rows in rows for r in episode_rows])
    out: dict = {"decisions": int(len(flat)), "episodes": len(rows)}
    for k, name in ((0, "decision"), (1, "period")):
        out.update({f"{name}_p50_ms": 1e3 * float(np.percentile(flat[:, k], 50)),
                    f"{name}_p99_ms": 1e3 * float(np.percentile(flat[:, k], 99)),
                    f"{name}_max_ms": 1e3 * float(flat[:, k].max())})
    for lo, hi in SPANS:
        errors = [r[2] for episode_rows in rows for r in episode_rows[lo:hi]]
        out[f"error_mm_decisions_{lo}_{min(hi, 999)}"] = float(np.mean(errors)) if errors else None
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", required=True, help="a reference_deviation PPO run (UNPICKLED: load only yours)")
    parser.add_argument("--n", type=int, default=20, help="the first N judge draws (default 20)")
    parser.add_argument("--bank-size", type=int, default=BANK_SIZE)
    args = parser.parse_args(argv)
    import torch
    torch.set_num_threads(1)
    controller = BankedDeviationPolicy.load(args.run, bank_size=args.bank_size)
    with threadpool_limits(1):
        rows = [episode(controller, bench, i) for i, (_, bench) in enumerate(judge_draws(args.n, {}))]
    with open("/proc/loadavg") as f:
        load = f.read().split()[:3]
    print(json.dumps({"run": args.run, "bank_size": args.bank_size, **summary(rows), "load": load}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
