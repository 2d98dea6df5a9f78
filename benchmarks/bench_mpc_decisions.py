"""``mpc``'s cost per decision along an episode: does a decision cost more the longer the episode has run?

``PYTHONPATH=. python benchmarks/bench_mpc_decisions.py --benches 6 --out runs/mpc_decisions [--mpc FIELD=VALUE]``
runs ``mpc`` on the first ``--benches`` tuning benches (stream ``agents.heldout.TUNING_SEED``, never the held-out
one), one episode after another in this process (``--workers 1``) or through the project's executor, and records
each decision's CPU time (``time.process_time`` around ``act``: the estimator's update, its resample-moves and
refinements, and the plan) with the period it was made in and whether the bank resample-moved or refined in it.
Prints the mean, median, p99 and largest decision time, the mean per block of 50 periods (a cost that grows with
the episode's length shows here), the CPU per episode and each episode's outcome; writes ``OUT/decisions.json``
(atomically). ``--against OUT``: also the bench-by-bench score difference from an earlier run on the same benches
(a variant against the current settings; a handful of benches is a small sample: the interval says how small),
with both runs' successes and CPU per episode.

Resumable and chunkable: each episode is checkpointed under ``OUT/tasks`` by its settings and bench index alone, so
running again resumes, and runs of ``--first F --benches K`` chunks into one ``OUT`` are read back by a run over
their union (``--first 0 --benches N``) without running anything again. Before its first timed episode each
process runs a short untimed one (:func:`warm_up`), so that numba's cache loading (decisions of several seconds)
is not counted as a decision's cost.
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
_BENCHES: dict[int, list] = {}  # per stream, the longest prefix drawn in this process (a prefix does not depend on n)
_WARM: list[bool] = []  # whether this process has run its untimed episode


def bench_of(index: int, stream: int):
    """Bench ``index`` of ``stream`` (``random_benches(n, stream)[index]`` for any ``n`` > ``index``)."""
    drawn = _BENCHES.get(stream, [])
    if index >= len(drawn):
        drawn = _BENCHES[stream] = random_benches(max(index + 1, 2 * len(drawn)), stream)
    return drawn[index]


def warm_up() -> None:
    """A short untimed ``mpc`` episode with tiny settings that still resample-move, refine and plan: the first
    episode of a process loads numba's compiled functions from its cache, and that is not a decision's cost."""
    if _WARM:
        return
    short = {"time_limit_s": 0.05}
    tiny = {"bank_size": 4, "elites": 2, "horizon": 8, "hypotheses": 2, "iterations": 1, "refine_evaluations": 2,
            "refine_every": 1, "samples": 8, "start_periods": 2}
    run_episode(MPCController(**tiny), random_benches(1, TUNING_SEED, short)[0], env_kwargs=short)
    _WARM.append(True)


def episode(task: tuple[dict, int, int]) -> dict:
    """One ``mpc`` episode on tuning bench ``index`` of ``stream``: its outcome and, per decision,
    (period, CPU s, resample-moved, refined)."""
    params, index, stream = task
    warm_up()
    bench = bench_of(index, stream)
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
    tasks = [(params, i, TUNING_SEED) for i in range(args.first, n)]
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
        against(s, Path(args.against), args.first)


def against(s: dict, base_out: Path, first: int) -> None:
    """The bench-by-bench score difference from an earlier run on the same benches, with its 95 % bootstrap
    interval over the benches, and both runs' successes and CPU per episode."""
    from experiments.stats import bootstrap_ci
    run = json.loads((base_out / "decisions.json").read_text())
    base = run["summary"]
    if len(base["scores"]) != len(s["scores"]) or run.get("first", 0) != first:
        raise SystemExit(f"--against {base_out}: benches {run.get('first', 0)}+{len(base['scores'])}, not "
                         f"{first}+{len(s['scores'])}")
    d = np.array(s["scores"]) - np.array(base["scores"])
    mean, lo, hi = bootstrap_ci(d[None, :], lambda t: float(np.mean(t)))
    print(f"score minus {base_out}'s: {mean:+.3f} mm ({lo:+.3f} to {hi:+.3f}, 95 % bootstrap over {len(d)} benches; "
          f"single benches {d.min():+.3f} to {d.max():+.3f}); successes {s['success']} against {base['success']}; "
          f"CPU per episode {s['cpu_s_per_episode']:.2f} s against {base['cpu_s_per_episode']:.2f} s")


if __name__ == "__main__":
    main()
