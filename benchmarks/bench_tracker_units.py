"""The Gauss-Newton tracker's units of work (:data:`agents.deviation_tracker.START_UNITS`, ``BARE_START_UNITS``): how
many periods stepped one fresh start of a hypothesis costs, with and without its case-C reference.

``PYTHONPATH=. taskset -c 0 python benchmarks/bench_tracker_units.py [--benches 3] [--starts 20]`` runs the tracker
beside the first judge benches (:func:`experiments.train_student.judge_draws`) under the nominal command until it
has a centre, then times (thread CPU) ``--starts`` fresh starts of hypotheses drawn around the centre (1 % of each
unknown's range: distinct hypotheses, which the env's start cache does not serve) and up to 30 periods stepped from
each, and as many starts without the reference (other hypotheses); prints, as JSON, per bench the mean start, bare
start and step in ms and the starts' ratios to a step, and the machine's load average.

``--prices RUN [--episodes 12]`` instead fits what :class:`agents.estimate_worker.WorkPrices` charges a hypothesis
period: ``banked:RUN`` (UNPICKLED: only yours) drives the first judge benches while every period its bank (and
tracker) steps is timed (thread CPU) with its kernel evaluations; prints the least-squares line us = a + b *
evaluations over them (the first 1,000 periods left out: numba's loading), their count and percentiles.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from threadpoolctl import threadpool_limits

from agents.deviation_tracker import GaussNewtonTracker, TrackerSettings
from agents.mpc import nominal_command
from envs.triplanar_shear_v1 import TriPlanarShearV1Env
from experiments.train_student import judge_draws


def bench_units(bench, starts: int, rng: np.random.Generator) -> dict[str, float]:
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=0, options={"bench": bench})
    tracker = GaussNewtonTracker(TrackerSettings(start=4))
    tracker.reset(bench.load_N, env.unwrapped.config)
    action = nominal_command(env.unwrapped.config).astype(np.float64)
    while tracker.centre is None:
        tracker.estimate(obs)
        tracker.advance(action)
        obs, *_ = env.step(action)
    centre = tracker.centre.theta
    start_s, bare_s, step_s, steps = 0.0, 0.0, 0.0, 0
    for _ in range(starts):
        z = tracker._z(centre) + rng.normal(0.0, 0.01, int(tracker.free.sum()))
        bare = tracker._theta(tracker._z(centre) + rng.normal(0.0, 0.01, int(tracker.free.sum())), centre)
        started = time.thread_time()
        tracker.bank.start_hypothesis(bare, reference=False)
        bare_s += time.thread_time() - started
        started = time.thread_time()
        state, _ = tracker.bank.start_hypothesis(tracker._theta(z, centre))
        began = time.thread_time()
        start_s += began - started
        for _ in range(30 if state is not None else 0):
            ended, _ = tracker.bank.step_hypothesis(state, action)
            steps += 1
            if ended:
                break
        step_s += time.thread_time() - began
    start_ms, bare_ms, step_ms = 1e3 * start_s / starts, 1e3 * bare_s / starts, 1e3 * step_s / max(steps, 1)
    return {"start_ms": start_ms, "bare_start_ms": bare_ms, "step_ms": step_ms, "steps": steps,
            "ratio": start_ms / step_ms, "bare_ratio": bare_ms / step_ms}


def period_prices(run: str, episodes: int) -> dict:
    """The line us = a + b * evaluations through every hypothesis period ``banked:RUN``'s estimator steps."""
    from agents import estimator as E
    from agents.banked_deviation import BankedDeviationPolicy
    from agents.controller_base import play
    timed: list[tuple[float, float]] = []
    step = E.SpecimenBank._step

    def timed_step(bank, state, raw):
        evaluations, started = bank.work_counts()[1], time.thread_time_ns()
        ended = step(bank, state, raw)
        timed.append((1e-3 * (time.thread_time_ns() - started), bank.work_counts()[1] - evaluations))
        return ended
    controller = BankedDeviationPolicy.load(run)
    E.SpecimenBank._step = timed_step
    try:
        for i, (_, bench) in enumerate(judge_draws(episodes, {})):
            env = TriPlanarShearV1Env()
            obs, _ = env.reset(seed=i, options={"bench": bench})
            play(controller, env, obs, bench.load_N)
    finally:
        E.SpecimenBank._step = step
    us, evaluations = np.array(timed[1000:]).T
    (a, b), *_ = np.linalg.lstsq(np.stack([np.ones_like(evaluations), evaluations], axis=1), us, rcond=None)
    return {"run": run, "periods": int(len(us)), "period_us": float(a), "evaluation_us": float(b),
            "evaluations_p50_p99_max": np.percentile(evaluations, [50, 99, 100]).tolist(),
            "us_p50_p99_max": np.percentile(us, [50, 99, 100]).tolist()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--benches", type=int, default=3)
    parser.add_argument("--starts", type=int, default=20)
    parser.add_argument("--prices", metavar="RUN", help="fit a hypothesis period's price instead (module docstring)")
    parser.add_argument("--episodes", type=int, default=12)
    args = parser.parse_args(argv)
    if args.benches < 1 or args.starts < 1 or args.episodes < 1:
        parser.error(f"--benches, --starts and --episodes must be >= 1, got {args.benches}, {args.starts}, "
                     f"{args.episodes}")
    rng = np.random.default_rng(0)
    with threadpool_limits(1):
        if args.prices:
            result = period_prices(args.prices, args.episodes)
        else:
            result = {"benches": [bench_units(bench, args.starts, rng) for _, bench in judge_draws(args.benches, {})]}
    with open("/proc/loadavg") as f:
        result["load"] = f.read().split()[:3]
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
