"""``mpc``'s cost per decision along an episode: does a decision cost more the longer the episode has run?

``PYTHONPATH=. python benchmarks/bench_mpc_decisions.py --benches 6 --out runs/mpc_decisions [--mpc FIELD=VALUE]``
runs ``mpc`` on the first ``--benches`` tuning benches (stream ``agents.heldout.TUNING_SEED``, never the held-out
one), one episode after another in this process (``--workers 1``) or through the project's executor, and records
each decision's CPU time (``time.process_time`` around ``act``: the estimator's update, its resample-moves and
refinements, and the plan) with the period it was made in and whether the bank resample-moved or refined in it.
Prints the mean, median, p99 and largest decision time, the mean per block of 50 periods (a cost that grows with
the episode's length shows here), the CPU per episode and each episode's outcome; writes ``OUT/decisions.json``
(atomically). ``--against OUT``: also the bench-by-bench score difference from an earlier run on the same benches
(a variant against the current settings; a handful of benches is a small sample: the interval says how small).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from agents.heldout import FAILURE_SCORE_MM, TUNING_SEED, random_benches, run_episode
from agents.mpc import MPCController
from triplanar.executor import TaskCheckpoint, pool_scope, run_tasks
from triplanar.workbench.report import write_json

BLOCK = 50  # periods per row of the along-the-episode table


def episode(task: tuple[dict, int, int, int]) -> dict:
    """One ``mpc`` episode on tuning bench ``index`` (of ``n`` drawn from ``stream``): its outcome and, per decision,
    (period, CPU s, resample-moved, refined)."""
    params, index, n, stream = task
    bench = random_benches(n, stream)[index]
    controller = MPCController(**params)
    act, decisions = controller.act, []

    def timed(obs):
        bank = getattr(controller, "bank", None)
        before = (bank.rejuvenations, bank.refinements) if bank is not None and hasattr(bank, "rejuvenations") \
            else (0, 0)
        action = act(obs)
        bank = controller.bank
        decisions.append((len(decisions) + 1, controller.info["cpu_s"], bank.rejuvenations > before[0],
                          bank.refinements > before[1]))
        return action
    controller.act = timed
    start = time.process_time()
    outcome = run_episode(controller, bench, seed=index, index=index, bench_set="tuning")
    return {"index": index, "success": outcome.success, "reason": outcome.reason,
            "mimicry_error_mm": outcome.mimicry_error_mm, "steps": outcome.steps,
            "cpu_s": time.process_time() - start, "decisions": decisions}


def summary_of(results: list[dict]) -> dict:
    cpu = np.array([d[1] for r in results for d in r["decisions"]])
    period = np.array([d[0] for r in results for d in r["decisions"]])
    moved = np.array([d[2] for r in results for d in r["decisions"]], dtype=bool)
    refined = np.array([d[3] for r in results for d in r["decisions"]], dtype=bool)
    blocks = []
    for lo in range(0, int(period.max()), BLOCK):
        mine = (period > lo) & (period <= lo + BLOCK)
        blocks.append({"periods": f"{lo + 1}-{lo + BLOCK}", "decisions": int(mine.sum()),
                       "mean_ms": 1e3 * float(cpu[mine].mean()), "p99_ms": 1e3 * float(np.percentile(cpu[mine], 99)),
                       "moved": int((moved & mine).sum()), "refined": int((refined & mine).sum()),
                       "mean_ms_plain": 1e3 * float(cpu[mine & ~moved & ~refined].mean())
                       if (mine & ~moved & ~refined).any() else math.nan})
    scores = [r["mimicry_error_mm"] if r["success"] else FAILURE_SCORE_MM for r in results]
    return {"decisions": len(cpu), "mean_ms": 1e3 * float(cpu.mean()), "median_ms": 1e3 * float(np.median(cpu)),
            "p99_ms": 1e3 * float(np.percentile(cpu, 99)), "max_ms": 1e3 * float(cpu.max()),
            "cpu_s_per_episode": float(np.mean([r["cpu_s"] for r in results])),
            "success": int(sum(r["success"] for r in results)), "episodes": len(results),
            "score_mm": float(np.mean(scores)), "scores": scores, "blocks": blocks}


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--benches", type=int, default=6)
    parser.add_argument("--first", type=int, default=0, help="the first tuning bench (default 0)")
    parser.add_argument("--out", default="runs/mpc_decisions")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--mpc", action="append", default=[], metavar="FIELD=VALUE",
                        help="an MPCController setting, e.g. --mpc move_periods=15 (repeatable)")
    parser.add_argument("--against", metavar="OUT", default=None,
                        help="an earlier run on the same benches: the bench-by-bench score difference")
    return parser.parse_args()


def settings(pairs: list[str]) -> dict:
    out = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or name not in MPCController.__dataclass_fields__:
            raise SystemExit(f"--mpc {pair!r}: expected FIELD=VALUE with FIELD one of MPCController's settings")
        out[name] = json.loads(value)
    return out


def main() -> None:
    args = parse_args()
    out, params = Path(args.out), settings(args.mpc)
    n = args.first + args.benches
    tasks = [(params, i, n, TUNING_SEED) for i in range(args.first, n)]
    with pool_scope(args.workers) as ex:
        results = run_tasks(episode, tasks, ex, progress=True, desc="mpc", checkpoint=TaskCheckpoint(out / "tasks"))
    s = summary_of(results)
    write_json({"settings": params, "first": args.first, "benches": args.benches, "summary": s, "episodes": results},
               out / "decisions.json")
    print(f"mpc {params or '(defaults)'} on tuning benches {args.first}-{n - 1} (stream {TUNING_SEED}): {s['episodes']} "
          f"episodes, {s['success']} successes, score {s['score_mm']:.3f} mm; {s['decisions']} decisions: mean "
          f"{s['mean_ms']:.1f} ms, median {s['median_ms']:.1f} ms, p99 {s['p99_ms']:.1f} ms, max {s['max_ms']:.1f} ms; "
          f"{s['cpu_s_per_episode']:.1f} CPU s per episode")
    print("| periods | decisions | mean ms | p99 ms | resample-moves | refinements | mean ms without either |")
    for b in s["blocks"]:
        print(f"| {b['periods']} | {b['decisions']} | {b['mean_ms']:.1f} | {b['p99_ms']:.1f} | {b['moved']} | "
              f"{b['refined']} | {b['mean_ms_plain']:.1f} |")
    for r in results:
        print(f"  bench {r['index']}: {r['reason']}, error {r['mimicry_error_mm']:.3f} mm, {r['steps']} steps, "
              f"{r['cpu_s']:.1f} CPU s")
    if args.against:
        from experiments.stats import bootstrap_ci
        base = json.loads((Path(args.against) / "decisions.json").read_text())["summary"]["scores"]
        if len(base) != len(s["scores"]):
            raise SystemExit(f"--against {args.against}: {len(base)} benches, not {len(s['scores'])}")
        d = np.array(s["scores"]) - np.array(base)
        mean, lo, hi = bootstrap_ci(d[None, :], lambda t: float(np.mean(t)))
        print(f"score minus {args.against}'s: {mean:+.3f} mm ({lo:+.3f} to {hi:+.3f}, {len(d)} benches)")


if __name__ == "__main__":
    main()
