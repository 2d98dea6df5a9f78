"""How much error one episode's measurements leave, whatever the controller does with them: a linearised
information bound for ``mpc`` on the tuning benches.

``PYTHONPATH=. python benchmarks/information_bound.py --benches 20 --out runs/information_bound [--workers 2]
[--limit-run runs/t200_limit] [--mpc FIELD=VALUE]``

For each of the first tuning benches (stream ``agents.heldout.TUNING_SEED``) ``mpc`` (with the ``--mpc`` settings,
as ``bench_mpc.py`` takes them) runs one episode and its commands are kept; along them
:func:`agents.information_bound.deviation_bound` (whose docstring has the method) gives ``reference bound`` (the
mimicry error left to a controller that could put the block exactly where the measurements so far place the case-C
path) and ``deviation bound`` (what the controller cannot know about its own error when it acts), on v1's default
bench. The tables' ``information_bound`` rows (``triplanar evaluate --controller information_bound``) use the same
function along ``limit``'s commands after ``mpc``'s start; this benchmark reads ``mpc``'s own commands.

What it is and is not: a bound for controllers that see what ``mpc`` saw (its commands set what is excited; another
excitation would give another bound, at a cost in error), linearised (stick/slip switches make the signals only
piecewise smooth) and with a Gaussian in place of the uniform prior. It says how much of ``mpc``'s error the
information explains, not that no controller could do better. Writes ``OUT/summary.json`` (atomically), with a
per-episode checkpoint under ``OUT/tasks`` (running it again resumes). Results go to ``docs/actuator-study.md`` by hand.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from bench_mpc import controller_settings, run_base

from agents.heldout import TUNING_SEED, random_benches, run_episode
from agents.information_bound import deviation_bound
from agents.mpc import MPCController
from experiments.stats import bootstrap_ci
from triplanar.executor import TaskCheckpoint, pool_scope, run_tasks
from triplanar.workbench.report import write_json


class Recorder:
    """A bench controller that passes ``controller``'s actions on and keeps them."""

    def __init__(self, controller: MPCController):
        self.controller, self.name, self.commands = controller, controller.name, []

    def reset(self, load_N: float, config) -> None:
        self.controller.reset(load_N, config)

    def act(self, obs: np.ndarray) -> np.ndarray:
        action = self.controller.act(obs)
        self.commands.append(np.array(action, dtype=float))
        return action


def bench_task(task: tuple[int, tuple]) -> dict:
    index, settings = task
    bench = random_benches(index + 1, TUNING_SEED)[index]
    recorder = Recorder(MPCController(**dict(settings)))
    outcome = run_episode(recorder, bench, seed=index, bench_set="tuning", index=index)
    result = deviation_bound(bench, np.array(recorder.commands)) or {}
    return {"index": index, "success": outcome.success, "mpc_error_mm": outcome.mimicry_error_mm, **result}


def mean_ci(values: list[float]) -> tuple[float, float, float]:
    """The mean over benches and its bootstrap 95 % interval (:func:`experiments.stats.bootstrap_ci`)."""
    return bootstrap_ci(np.asarray(values, dtype=float)[None, :], lambda t: float(np.nanmean(t)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--benches", type=int, default=20, help="the first N tuning benches (N >= 1)")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--limit-run", type=Path, help="a bench_mpc.py run of limit on the tuning stream, at least as "
                        "many benches")
    parser.add_argument("--mpc", action="append", default=[], metavar="FIELD=VALUE", help="an MPCController setting")
    args = parser.parse_args()
    settings = tuple(sorted(controller_settings(args.mpc, "--mpc", MPCController).items()))
    with pool_scope(args.workers) as ex:
        results = run_tasks(bench_task, [(i, settings) for i in range(args.benches)], ex, progress=True, desc="bound",
                            checkpoint=TaskCheckpoint(args.out / "tasks"))
    rows = [r for r in results if r["success"] and "deviation_bound_mm" in r]
    if not rows:
        raise SystemExit(f"none of the {args.benches} benches pooled (mpc failed or a perturbed bench ended early)")
    summary = {"benches": args.benches, "stream": TUNING_SEED, "mpc": dict(settings), "pooled": len(rows),
               "left_out": [r["index"] for r in results if r not in rows]}
    limit = {}
    if args.limit_run:  # its errors per bench, the same benches checked as bench_mpc.py's --against does
        base = run_base(summary, args.limit_run, "--limit-run")
        if "limit" not in base:
            raise SystemExit(f"--limit-run {args.limit_run}: no limit row in its summary.json")
        limit = {i: math.nan if e is None else float(e) for i, e in enumerate(base["limit"][1])}
    columns = {"reference bound": "reference_bound_mm", "deviation bound": "deviation_bound_mm",
               "mpc error": "mpc_error_mm"}
    print(f"{len(rows)} of {args.benches} tuning benches (mpc successful, differences defined); mean (95 % CI), mm:")
    for label, key in columns.items():
        summary[key] = mean_ci([r[key] for r in rows])
        print(f"  {label}: {summary[key][0]:.3f} ({summary[key][1]:.3f}-{summary[key][2]:.3f})")
    if limit:
        mine = [r for r in rows if r["index"] in limit]
        summary["limit_error_mm"] = mean_ci([limit[r["index"]] for r in mine])
        summary["quadrature_mm"] = mean_ci([math.hypot(limit[r["index"]], r["deviation_bound_mm"]) for r in mine])
        excess = [r["mpc_error_mm"] - limit[r["index"]] for r in mine]
        summary["excess_mm"] = mean_ci(excess)
        summary["excess_bound_correlation"] = float(np.corrcoef(excess, [r["deviation_bound_mm"] for r in mine])[0, 1])
        print(f"  limit error ({args.limit_run}, {len(mine)} benches): {summary['limit_error_mm'][0]:.3f} "
              f"({summary['limit_error_mm'][1]:.3f}-{summary['limit_error_mm'][2]:.3f}); limit and deviation bound in "
              f"quadrature: {summary['quadrature_mm'][0]:.3f}; mpc minus limit: {summary['excess_mm'][0]:.3f} "
              f"({summary['excess_mm'][1]:.3f}-{summary['excess_mm'][2]:.3f}), its correlation with the deviation "
              f"bound bench by bench {summary['excess_bound_correlation']:.2f}")
    fractions = np.linspace(0.1, 1.0, 10)
    profile = np.mean([np.interp(fractions, r["travel_fraction"], r["deviation_profile_mm"]) for r in rows], axis=0)
    summary["deviation_profile_mm"] = profile.tolist()
    print("  deviation bound at 10 %, 20 %, ..., 100 % of the travel: " + " ".join(f"{v:.2f}" for v in profile))
    write_json(summary, args.out / "summary.json")


if __name__ == "__main__":
    main()
